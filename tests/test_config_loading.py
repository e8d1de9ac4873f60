"""hlcmp_drake.config.loading: a bundled scenario loads into typed configs; a bad scenario
file (edited, a missing model, fuzzed bytes) is one error naming its file and line."""

import random
import re

import pytest
from conftest import INSERTION_DEMO, mutations, one_line_error, run_cli

from hlcmp_drake.config.loading import OptionOverride, load_scenario
from hlcmp_drake.config.scenario import HlcmpConfig, VariableImpedanceConfig
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.paths import DIAGRAMS_DIR

ONE_DOF = (DIAGRAMS_DIR / "one_dof.yaml").read_text()


def test_a_file_loaded_again_is_a_scenario_of_its_own():
    # The parsed text is kept for the next load of the same file: what one caller changes
    # (a sweep setting a field, a weld moved) must not reach the next one.
    first, _ = load_scenario("insertion")
    first.duration_s = 99.0
    first.controllers["hlcmp"].q_k[0] = -1.0
    first.directives[1].add_weld.parent = "nowhere"
    second, _ = load_scenario("insertion")
    assert second.duration_s != 99.0 and second.controllers["hlcmp"].q_k[0] != -1.0
    assert second.directives[1].add_weld.parent == "world"


def test_bundled_one_dof_loads_into_typed_configs():
    scenario, path = load_scenario("one_dof")
    assert path.name == "one_dof.yaml"
    assert list(scenario.controllers) == [
        "hlcmp",
        "hlcmp_per_step",
        "vic_fd_0.5",
        "vic_fd_1.5",
        "vic_fd_5.0",
    ]
    hl = scenario.controllers["hlcmp"]
    assert isinstance(hl, HlcmpConfig)
    assert (hl.q_k, hl.q_d, hl.q_v) == ([2000.0], [500.0], [0.0])
    assert isinstance(scenario.controllers["vic_fd_5.0"], VariableImpedanceConfig)
    assert scenario.controllers["vic_fd_5.0"].desired_force_N == [5.0]
    assert scenario.plant_config.time_step == 0.001
    assert scenario.simulator_config.integration_scheme == "runge_kutta2"
    assert not scenario.simulator_config.use_error_control


def _line_of(text, needle):
    return next(n for n, line in enumerate(text.splitlines(), 1) if needle in line)


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ("duration_s: 20.0", "duration_s: 20.0\nspeed: 3", "speed"),
        ("duration_s: 20.0", "duration_s: fast", "duration_s: must be a number, got 'fast'"),
        ("duration_s: 20.0", "duration_s: 4000.0", "duration_s: must be at most 3600 s, got 4000"),
        (
            "log_period_s: 0.01",
            "log_period_s: 0.00001",
            "log_period_s: must be at least 2e-05 s for a 20 s run, got 1e-05: at most 1e+06",
        ),
        (
            "log_period_s: 0.01",
            "log_period_s: 7.0",
            "log_period_s: must be at most 0.1 s, got 7: the metrics (peaks, reach times, "
            "smoothness) are read from the logged samples",
        ),
        ("q_k: [2000.0]", "q_k: 2000.0", "q_k: must be a list, got 2000.0"),
        ("axis: 0", "axis: x", "axis: must be an integer, got 'x'"),
        (
            "q_k: [2000.0]",
            "q_k: [-2000.0]",
            "q_k: controller 'hlcmp': every value must be non-negative",
        ),
        ("pi: 5.0 ", "pi: 0.0 ", "pi: controller 'hlcmp': pi must be > 0"),
        ("q_d: [500.0]", "q_d: [500.0, 1.0]", "q_d: controller 'hlcmp' needs 1 value(s)"),
        (
            "hlcmp: !HlcmpConfig",
            "hlcmp: !Hlcmp",
            "hlcmp: !Hlcmp is none of !HlcmpConfig, !HlcmpForgettingConfig, ",
        ),
        ("times_s: [0.0, 10.0]", "times_s: [0.0, 10.0", "expected ',' or ']'"),
        (  # relative: Drake would not read it, the existence check would look in the cwd
            "file: package://hlcmp_drake/models/one_dof_slider.sdf",
            "file: file://one_dof_slider.sdf",
            "file: 'file://one_dof_slider.sdf': a file:// URL takes an absolute path",
        ),
    ],
)
def test_bad_scenarios_name_file_and_line(tmp_path, old, new, expected):
    assert old in ONE_DOF
    path = tmp_path / "bad.yaml"
    path.write_text(ONE_DOF.replace(old, new, 1))
    with pytest.raises(InputError) as error:
        load_scenario(path)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(f"{path}:")
    assert expected in message
    assert re.match(rf"{re.escape(str(path))}:\d+: ", message), message


def test_unknown_key_points_at_its_line(tmp_path):
    path = tmp_path / "bad.yaml"
    text = ONE_DOF.replace("log_period_s: 0.01", "log_period_s: 0.01\nlog_rate: 3")
    path.write_text(text)
    with pytest.raises(InputError, match=rf":{_line_of(text, 'log_rate')}: .*log_rate"):
        load_scenario(path)


def test_missing_model_file_names_the_line(tmp_path):
    text = (
        (DIAGRAMS_DIR / "insertion.yaml").read_text().replace("foam_plank.sdf", "no_such_plank.sdf")
    )
    path = tmp_path / "s.yaml"
    path.write_text(text.replace("file: demos/insertion_demo.csv", f"file: {INSERTION_DEMO}"))
    line = one_line_error(run_cli("run", path, "--out", tmp_path / "o"))
    number = next(n for n, row in enumerate(text.splitlines(), 1) if "no_such_plank" in row)
    assert (
        f"{path}:{number}: file: model file "
        "'package://hlcmp_drake/models/no_such_plank.sdf' does not exist" in line
    )


def test_fuzzed_scenarios_never_crash(tmp_path):
    rng = random.Random(4321)
    good = (DIAGRAMS_DIR / "one_dof.yaml").read_text()
    path = tmp_path / "scenario.yaml"
    outcomes = {"ok": 0, "error": 0}
    for text in mutations(good, rng, 150):
        data = text.encode()
        if rng.random() < 0.1:
            cut = rng.randrange(len(data) + 1)
            data = data[:cut] + b"\xff" + data[cut:]
        path.write_bytes(data)
        try:
            load_scenario(path)
            outcomes["ok"] += 1
        except InputError as error:
            assert "\n" not in str(error) and str(error).startswith(str(path))
            outcomes["error"] += 1
    assert outcomes["ok"] > 0 and outcomes["error"] > 0


def test_a_dumped_scenario_reads_back_with_every_controller_of_its_own_class():
    """dump_scenario keeps a subclass config (the 6-D ones, the forgetting Hl-CMP) what it
    is, where yaml_dump_typed alone writes it as its base, HlcmpConfig or
    ConstantImpedanceConfig; a scenario without one is written as yaml_dump_typed does."""
    from pydrake.common.yaml import yaml_dump_typed

    from hlcmp_drake.config.loading import dump_scenario, load_scenario_text

    forgetting = (
        "controllers.forgetting=!HlcmpForgettingConfig {q_k: [2000.0], q_d: [500.0], "
        "q_v: [0.0], gain_l: [10.0], forgetting_per_s: 0.2}"
    )
    for name, overrides in (("peg_in_hole", []), ("one_dof", [forgetting])):
        scenario, path = load_scenario(name, overrides)
        back = load_scenario_text(dump_scenario(scenario), path)
        assert set(back.controllers) == set(scenario.controllers)
        for label, config in scenario.controllers.items():
            assert type(back.controllers[label]) is type(config), label
            assert back.controllers[label] == config, label
        plain = load_scenario_text(yaml_dump_typed(scenario), path)
        assert any(
            type(plain.controllers[k]) is not type(c) for k, c in scenario.controllers.items()
        )
    insertion, _ = load_scenario("insertion")
    assert dump_scenario(insertion) == yaml_dump_typed(insertion)


@pytest.mark.parametrize("text", ["", "\n  \n", "# only a comment\n\n# and another\n", "---\n"])
def test_an_empty_scenario_or_variant_file_is_one_line(tmp_path, text):
    empty = tmp_path / "empty.yaml"
    empty.write_text(text)
    expected = f"{empty}: holds no YAML (it is empty or only comments)"
    with pytest.raises(InputError, match=f"^{re.escape(expected)}$"):
        load_scenario(empty)
    with pytest.raises(InputError, match=f"^{re.escape(expected)}$"):
        load_scenario("one_dof", variant=empty)


def test_a_key_given_twice_is_refused_where_it_is_given_again(tmp_path):
    """YAML keeps the last of two equal keys: a controller's label given twice would drop
    the first controller without a word."""
    text = (DIAGRAMS_DIR / "one_dof.yaml").read_text()
    lines = text.splitlines()
    first = next(n for n, row in enumerate(lines, 1) if row.startswith("  vic_fd_0.5:"))
    again = next(n for n, row in enumerate(lines, 1) if row.startswith("  vic_fd_1.5:"))
    path = tmp_path / "twice.yaml"
    path.write_text(text.replace("  vic_fd_1.5:", "  vic_fd_0.5:"))
    expected = (
        f"{path}:{again}: 'vic_fd_0.5' is given twice in the same map (first at line {first})"
    )
    with pytest.raises(InputError, match=f"^{re.escape(expected)}$"):
        load_scenario(path)
    variant = tmp_path / "variant.yaml"
    variant.write_text("duration_s: 2.0\nlog_period_s: 0.01\nduration_s: 3.0\n")
    expected = f"{variant}:3: 'duration_s' is given twice in the same map (first at line 1)"
    with pytest.raises(InputError, match=f"^{re.escape(expected)}$"):
        load_scenario("one_dof", variant=variant)


@pytest.mark.parametrize(
    "old, new, expected",
    [
        (
            "    sample_period_s: 0.001\n",
            "    sample_period_s: [0.001]\n",
            "must be a number, got a list",
        ),
        ("    q_k: [2000.0]\n", "    q_k: '300'\n", "must be a list, got '300'"),
        (
            "  hlcmp_per_step: !HlcmpConfig",
            "  hlcmp_per_step: 5\n  x: !HlcmpConfig",
            "must be a map of fields, got 5",
        ),
    ],
)
def test_a_value_of_another_shape_is_refused_at_its_own_line(tmp_path, old, new, expected):
    """Drake's loader names no line, and reads text given for a list of numbers as one number a
    character ('300' as [3, 0, 0]): the value is found where the file gives it (the last
    of the fields of that name, the one changed)."""
    at = ONE_DOF.rindex(old)
    text = ONE_DOF[:at] + new + ONE_DOF[at + len(old) :]
    line = ONE_DOF[:at].count("\n") + 1
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as error:
        load_scenario(path)
    key = new.split(":")[0].strip()
    assert str(error.value) == f"{path}:{line}: {key}: {expected}"


def test_the_driver_channels_must_differ():
    """A client on one channel for two messages would read its own commands as statuses."""
    with pytest.raises(InputError, match="wrist_channel: must differ from status_channel"):
        load_scenario("insertion", ["iiwa_driver.wrist_channel=IIWA_STATUS"])
    with pytest.raises(InputError, match="command_channel: must differ from status_channel"):
        load_scenario("insertion", ["iiwa_driver.command_channel=IIWA_STATUS"])


def test_a_copied_scenario_finds_the_bundled_demonstration_by_package_url(tmp_path):
    """A scenario copied out of diagrams/ names the bundled demonstration as
    package://hlcmp_drake/diagrams/demos/...; a relative path would look beside the copy."""
    text = (DIAGRAMS_DIR / "insertion.yaml").read_text()
    assert "file: demos/insertion_demo.csv" in text
    copy = tmp_path / "my_insertion.yaml"
    copy.write_text(
        text.replace(
            "file: demos/insertion_demo.csv",
            "file: package://hlcmp_drake/diagrams/demos/insertion_demo.csv",
        )
    )
    scenario, _ = load_scenario(copy)
    assert INSERTION_DEMO.samefile(scenario.reference.file)
    copy.write_text(
        text.replace(
            "file: demos/insertion_demo.csv", "file: package://hlcmp_drake/diagrams/demos/nope.csv"
        )
    )
    with pytest.raises(
        InputError,
        match=r"my_insertion.yaml:\d+: file: demonstration file "
        r"'package://hlcmp_drake/diagrams/demos/nope.csv' not found \(looked for ",
    ):
        load_scenario(copy)
    copy.write_text(text)  # copied as it is: its relative path looks beside the copy
    with pytest.raises(InputError) as error:
        load_scenario(copy)
    assert str(error.value).endswith(
        f"(looked for {tmp_path / 'demos' / 'insertion_demo.csv'}); the bundled one is "
        "package://hlcmp_drake/diagrams/demos/insertion_demo.csv"
    )


@pytest.mark.parametrize(
    "override, nearest",
    [
        ("duration=4", "duration_s"),
        ("controllers.hlcmp.q_kk=[1,1,1]", "q_k"),
        ("plant_config.time_stepp=0.002", "time_step"),  # a Drake config struct's field
        ("zzz=1", None),
    ],
)
def test_a_misspelt_override_names_the_nearest_field(override, nearest):
    with pytest.raises(InputError) as error:
        load_scenario("insertion", [override])
    part = override.split("=")[0].split(".")[-1]
    message = f"override '{override}': no field '{part}' in the scenario"
    assert str(error.value) == message + (f" (did you mean '{nearest}'?)" if nearest else "")


@pytest.mark.parametrize(
    "override, expected",
    [
        # refused by the validation, alone and among --set overrides of the same field
        (
            ["duration_s=1000000000.0"],
            "--duration 1e9: duration_s: must be at most 3600 s, got 1e+09: ",
        ),
        (
            ["duration_s=2", "log_period_s=0.02", "duration_s=1000000000.0"],
            "--duration 1e9: duration_s: must be at most 3600 s, got 1e+09: ",
        ),
        (["duration_s=[1]"], "--duration 1e9: duration_s: "),  # by the schema, as it loads
    ],
)
def test_an_option_that_stands_for_an_override_is_named_as_typed(override, expected):
    """`hlcmp serve --duration 1e9` is the override duration_s=1000000000.0, which the user
    never typed: a message names the option as typed, as an override is named as typed."""
    import pickle

    *typed, own = override
    option = OptionOverride(own, "--duration 1e9")
    assert pickle.loads(pickle.dumps(option)).typed == "--duration 1e9"
    assert type(pickle.loads(pickle.dumps(option))) is OptionOverride
    with pytest.raises(InputError) as error:
        load_scenario("insertion", [*typed, option])
    assert str(error.value).startswith(expected), str(error.value)
    assert "override" not in str(error.value)


@pytest.mark.parametrize(
    "old, new, expected",
    [
        (
            "duration_s: 20.0",
            "duraton_s: 20.0",
            "duraton_s: no such field in Scenario (did you mean 'duration_s'?)",
        ),
        (
            "    q_k: [2000.0]",
            "    qk: [2000.0]",
            "qk: no such field in HlcmpConfig (did you mean 'q_k'?)",
        ),
        ("  axis: 0", "  axis: 0\n  zzz: 1", "zzz: no such field in SliderTask"),
    ],
)
def test_a_misspelt_key_in_a_file_names_its_line_and_the_nearest_field(
    tmp_path, old, new, expected
):
    assert old in ONE_DOF
    path = tmp_path / "typo.yaml"
    text = ONE_DOF.replace(old, new, 1)
    path.write_text(text)
    key = new.split("\n")[-1].split(":")[0].strip()
    with pytest.raises(InputError) as error:
        load_scenario(path)
    assert str(error.value) == f"{path}:{_line_of(text, key)}: {expected}"


def test_a_merge_key_is_not_taken_for_a_field(tmp_path):
    """`<<: *anchor` brings an anchor's fields in; it is no field of its own."""
    text = ONE_DOF.replace(
        "  hlcmp_per_step: !HlcmpConfig     # the same learner, Q read per control step "
        "(Table I): Q / 1 ms\n"
        "    q_k: [2000.0]\n    q_d: [500.0]\n    q_v: [0.0]\n    pi: 5.0\n    gain_l: [10.0]\n",
        "  hlcmp_per_step: !HlcmpConfig\n    <<: *learner\n",
    ).replace("  hlcmp: !HlcmpConfig\n", "  hlcmp: !HlcmpConfig &learner\n")
    assert "<<: *learner" in text and "&learner" in text
    path = tmp_path / "merged.yaml"
    path.write_text(text)
    scenario = load_scenario(path)[0]
    assert scenario.controllers["hlcmp_per_step"].q_k == [2000.0]
    assert scenario.controllers["hlcmp_per_step"].q_units == "per_step"


@pytest.mark.parametrize(
    "override",
    [
        "robot_imperfection=!RobotImperfection {velocity_filter_hz: 40.0}",
        "task.puncture=!PunctureConfig {depth_m: 0.01}",
    ],
)
def test_a_tag_on_a_field_of_one_kind_is_refused_by_name(override):
    """The README's `!Tag` form on a field that holds one class only: Drake's loader said
    "The fields ['_tag'] were unknown to the schema"."""
    key, _, value = override.partition("=")
    with pytest.raises(InputError) as error:
        load_scenario("insertion", [override])
    tag, kind = value.split()[0], value.split()[0][1:]
    assert str(error.value) == (
        f"override '{override}': {key.rsplit('.', 1)[-1]}: takes no tag ({tag}): it holds a "
        f"{kind} only; give its fields alone"
    )


INSERTION = (DIAGRAMS_DIR / "insertion.yaml").read_text()


def test_a_scenario_without_its_task_says_so_not_what_the_default_world_refuses(tmp_path):
    """Without `task` a scenario is the slider world (Scenario's default), which refused
    the arm's demonstration: the line blamed the reference."""
    start, end = INSERTION.index("task: !ArmTask"), INSERTION.index("reference: !Demo")
    path = tmp_path / "notask.yaml"
    text = INSERTION[:start] + INSERTION[end:]
    path.write_text(text.replace("file: demos/", "file: package://hlcmp_drake/diagrams/demos/"))
    with pytest.raises(InputError) as error:
        load_scenario(path)
    assert str(error.value) == (
        f"{path}: no task: a scenario says which world it is in `task` (!ArmTask for the arm, "
        "!SliderTask for the one-DOF slider); without it, it is the slider world, where "
        "reference: the slider world follows a !StepReferenceConfig reference"
    )


@pytest.mark.parametrize(
    "old, new, at, expected",
    [
        (  # an untagged config is named at its first field that is not the read tag's
            "  const_500: !ConstantImpedanceConfig",
            "  const_500:",
            "    stiffness_N_per_m: [500.0",
            "const_500: untagged, so read as !HlcmpConfig, which has no fields "
            "'stiffness_N_per_m', 'damping_Ns_per_m': they are !ConstantImpedanceConfig's: "
            "give its tag",
        ),
        (
            "task: !ArmTask",
            "task:",
            "  tool_frame:",
            "task: untagged, so read as !SliderTask, which has no fields 'tool_frame', "
            "'axes', 'tool_direction', ...: they are !ArmTask's: give its tag",
        ),
        (
            "  n_basis: 30 ",
            "  n_basis: 3e1 ",
            "  n_basis:",
            "n_basis: must be an integer in digits, got '3e1'",
        ),
        (
            "  tool_frame: insertion_tool::tip",
            "  tool_frame:",
            "  tool_frame:",
            "tool_frame: must be text, got nothing",
        ),
    ],
)
def test_an_untagged_config_or_a_value_drake_would_not_read_names_field_and_kind(
    tmp_path, old, new, at, expected
):
    """Drake said "The fields [...] were unknown to the schema", "invalid literal for
    int()" or "Expected a <class 'str'> value": the line names the field, what it wants,
    and for an untagged config the tag whose fields it holds."""
    assert old in INSERTION
    path = tmp_path / "bad.yaml"
    path.write_text(INSERTION.replace(old, new))
    with pytest.raises(InputError) as error:
        load_scenario(path)
    assert str(error.value) == f"{path}:{_line_of(INSERTION, at)}: {expected}"


@pytest.mark.parametrize(
    "override, expected",
    [
        ("dmp.n_basis=1e3", "n_basis: must be an integer in digits, got '1e3'"),
        ("task.tool_frame=", "tool_frame: must be text, got nothing"),
        ("name=", "name: must be text, got nothing"),
        ("controllers.hlcmp.q_units=3", "q_units: must be text, got 3"),
    ],
)
def test_an_override_drake_would_not_read_names_field_and_kind(override, expected):
    with pytest.raises(InputError) as error:
        load_scenario("insertion", [override])
    assert str(error.value) == f"override '{override}': {expected}"


def test_a_demonstration_that_is_a_folder_is_called_a_folder(tmp_path):
    (tmp_path / "adir").mkdir()
    with pytest.raises(InputError) as error:
        load_scenario("insertion", [f"reference.file={tmp_path / 'adir'}"])
    assert str(error.value) == (
        f"override 'reference.file={tmp_path / 'adir'}': file: '{tmp_path / 'adir'}' is a "
        "folder, not a demonstration file (a CSV)"
    )


@pytest.mark.parametrize(
    "override, kind",
    [
        ("controllers.const_500={pi: 3}", "ConstantImpedanceConfig"),
        ("controllers.hlcmp={pi: 3}", "HlcmpConfig"),
        ("task={max_contact_force_N: 5}", "ArmTask"),
    ],
)
def test_a_map_given_for_a_config_is_merged_into_it_whatever_its_kind(override, kind):
    """`--set KEY={field: value}` changes that field of the config there, keeping its kind
    and its other fields, as it does for a section: untagged, Drake would read the map as a
    new config of the union's first kind (a constant impedance with the Hl-CMP's default,
    empty gains; a slider's task)."""
    import dataclasses as dc

    before, _ = load_scenario("insertion", [])
    after, _ = load_scenario("insertion", [override])
    key = override.split("=")[0].split(".")
    old, new = (
        (before.controllers[key[1]], after.controllers[key[1]])
        if key[0] == "controllers"
        else (before.task, after.task)
    )
    changed = [
        f.name for f in dc.fields(new) if repr(getattr(new, f.name)) != repr(getattr(old, f.name))
    ]
    assert type(new).__name__ == kind and changed == [override.split("{")[1].split(":")[0]]
