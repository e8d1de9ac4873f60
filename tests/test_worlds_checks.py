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


def wiggle(amplitude_m, period_s, duration_s=30.0, drift_m_per_s=0.0):
    """The tool wiggling along x about a point the insertion arm reaches pointing down."""
    t = np.arange(0.0, duration_s + 1e-9, 0.01)
    x = 0.55 + amplitude_m * np.sin(2 * np.pi * t / period_s) + drift_m_per_s * t
    return t, np.column_stack([x, np.full_like(t, -0.05), np.full_like(t, 0.45)])


# A user's slow wiggles (at most 0.13 m/s) that the seeded IK along the path refused: it
# jumped to another branch at t = 10.76 s (joint 1 "at 3.31 rad/s"), or failed at t = 2.30 s.
@pytest.mark.parametrize("amplitude_m, period_s", [(0.02, 1.7), (0.05, 2.4)])
def test_a_slow_reachable_wiggle_is_feasible(insertion_demo, amplitude_m, period_s):
    scenario = insertion_demo[0]
    check_demonstration_feasible(scenario, *wiggle(amplitude_m, period_s), "wiggle.csv")


def test_the_same_wiggle_thirty_times_faster_is_refused(insertion_demo):
    scenario = insertion_demo[0]
    t, positions = wiggle(0.02, 1.7)
    with pytest.raises(InputError, match=r"^wiggle.csv \(t = .*needs joint .* above its limit"):
        check_demonstration_feasible(scenario, t / 30, positions, "wiggle.csv")


def test_a_wiggle_that_drifts_out_of_reach_is_refused_where_it_leaves(insertion_demo):
    scenario = insertion_demo[0]
    t, positions = wiggle(0.02, 1.7, drift_m_per_s=0.02)
    lines = list(range(2, len(t) + 2))
    with pytest.raises(InputError, match=r"^wiggle.csv:(\d+): the tool cannot reach") as refused:
        check_demonstration_feasible(scenario, t, positions, "wiggle.csv", lines)
    line = int(str(refused.value).split(":")[1])
    x = positions[line - 2, 0]
    # Pointing down at y = -0.05 m, z = 0.45 m the arm reaches x = 0.68 m at most.
    assert x > 0.68 and f"({x:.3f}, -0.050, 0.450)" in str(refused.value)


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
