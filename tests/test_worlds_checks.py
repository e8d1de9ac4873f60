"""hlcmp_drake.worlds.checks: a demonstration is checked against the arm before anything
is simulated (directly, and through `hlcmp learn`)."""

import numpy as np
import pytest
from conftest import INSERTION_DEMO, one_line_error, run_cli

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.demos import read_demonstration, write_trajectory
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.worlds.checks import check_demonstration_feasible


@pytest.fixture(scope="module")
def insertion_demo():
    scenario, _ = load_scenario("insertion")
    t, positions, _, lines = read_demonstration(scenario.reference.file, with_lines=True)
    return scenario, t, positions, lines


def test_the_bundled_demonstration_is_feasible(insertion_demo):
    scenario, t, positions, lines = insertion_demo
    check_demonstration_feasible(scenario, t, positions, "demo.csv", lines)


def test_an_unreachable_sample_is_named_by_its_line(insertion_demo):
    scenario, t, positions, lines = insertion_demo
    far = positions + np.array([2.0, 0.0, 0.0])
    with pytest.raises(InputError, match=rf"^demo.csv:{lines[0]}: the tool cannot reach"):
        check_demonstration_feasible(scenario, t, far, "demo.csv", lines)


def test_a_too_fast_demonstration_is_refused(insertion_demo):
    scenario, t, positions, lines = insertion_demo
    with pytest.raises(InputError, match="needs joint .* above its limit"):
        check_demonstration_feasible(scenario, t / 30, positions, "demo.csv")


@pytest.mark.parametrize(
    "change, expected",
    [
        (
            lambda t, p: (t, p + np.array([1.5, 0.0, 0.0])),
            "the tool cannot reach (2.050, -0.050, 0.450)",
        ),
        (lambda t, p: (t / 20, p), "following the demonstration needs joint"),
    ],
)
def test_unfollowable_demonstrations_stop_before_simulating(tmp_path, change, expected):
    t, positions, axes = read_demonstration(INSERTION_DEMO)
    bad = write_trajectory(tmp_path / "bad.csv", *change(t, positions), axes)
    line = one_line_error(run_cli("learn", bad, "--scenario", "insertion", "--out", tmp_path / "o"))
    assert line.startswith(f"hlcmp: error: {bad}:") and expected in line
    assert not (tmp_path / "o").exists()
