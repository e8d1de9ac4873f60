"""Direct tests of the demonstration checks against the arm and of the offline recording."""

import numpy as np
import pytest
from pydrake.geometry import Meshcat

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.demos import read_demonstration
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.present.recording import record_runs
from hlcmp_drake.worlds.checks import check_demonstration_feasible


@pytest.fixture(scope="module")
def insertion():
    scenario, _ = load_scenario("insertion")
    t, positions, _, lines = read_demonstration(scenario.reference.file, with_lines=True)
    return scenario, t, positions, lines


def test_the_bundled_demonstration_is_feasible(insertion):
    scenario, t, positions, lines = insertion
    check_demonstration_feasible(scenario, t, positions, "demo.csv", lines)


def test_an_unreachable_sample_is_named_by_its_line(insertion):
    scenario, t, positions, lines = insertion
    far = positions + np.array([2.0, 0.0, 0.0])
    with pytest.raises(InputError, match=rf"^demo.csv:{lines[0]}: the tool cannot reach"):
        check_demonstration_feasible(scenario, t, far, "demo.csv", lines)


def test_a_too_fast_demonstration_is_refused(insertion):
    scenario, t, positions, lines = insertion
    with pytest.raises(InputError, match="needs joint .* above its limit"):
        check_demonstration_feasible(scenario, t / 30, positions, "demo.csv")


def test_a_recording_replays_each_run_under_its_label():
    scenario, _ = load_scenario("one_dof")
    t = np.linspace(0.0, 0.5, 51)
    state = np.column_stack([-0.1 * t, -0.1 * np.ones_like(t)])  # q, v of the slider
    runs = {label: RunResult(label, t, {"plant_state": state}) for label in ("learner", "baseline")}
    meshcat = Meshcat()
    html = record_runs(scenario, runs, meshcat)
    assert html.startswith("<!DOCTYPE html>") and "embedded-json" in html
    for label in runs:
        assert meshcat.HasPath(f"/drake/runs/{label}")
    assert not meshcat.HasPath("/drake/runs/nobody")


def test_a_live_meshcat_shows_each_run_while_it_simulates(tmp_path):
    from hlcmp_drake.run.runner import run_scenario

    meshcat = Meshcat()
    run_scenario("one_dof", tmp_path, overrides=["duration_s=0.3"], meshcat=meshcat)
    for label in ("hlcmp", "hlcmp_per_step", "vic_fd_0.5"):
        assert meshcat.HasPath(f"/drake/runs/{label}")
    assert (tmp_path / "recording.html").exists()  # the offline recording is still written
