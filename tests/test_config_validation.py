"""hlcmp_drake.config.validation: an arm scenario the fast path cannot run is refused with the
field named."""

import pytest

from hlcmp_drake.config.loading import load_scenario


@pytest.mark.parametrize(
    "override, expected",
    [
        ("plant_config.use_sampled_output_ports=true", "use_sampled_output_ports"),
        ("plant_config.time_step=0.0", "discrete plant"),
        ("task.control_path=quick", "must be one of fast, modular"),
    ],
)
def test_an_arm_scenario_the_fast_path_cannot_run_is_refused_with_the_field_named(
    override, expected
):
    from hlcmp_drake.io.errors import InputError

    with pytest.raises(InputError, match=expected) as error:
        load_scenario("insertion", [override])
    assert override.split("=")[0] in str(error.value) and "\n" not in str(error.value)
