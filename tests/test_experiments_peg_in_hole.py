"""experiments.peg_in_hole: the claims P1 and P2 judged on given metrics (each can fail)
and the task's 2 mm criterion. A 6-D run's metrics recomputed from the files it writes:
tests/test_run_serve.py (the served and the simulated peg)."""

from types import SimpleNamespace

import numpy as np
import pytest

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import peg_in_hole


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("peg_in_hole")[0]


def _metrics(k_r=(5.0, 40.0, 3.0), force=(10.0, 20.0), torque=(0.1, 0.3), depth=0.0195):
    """Metrics of the 6-D learner and the stiff constant as P1 and P2 read them."""
    done = {"done": True, "evidence": "deep enough"}
    return {
        "hlcmp_6d": {
            "task": done,
            "max_rotational_stiffness_Nm_per_rad": list(k_r),
            "max_force_norm_N": force[0],
            "max_torque_norm_Nm": torque[0],
            "depth_reached_m": depth,
        },
        "const_6d_stiff": {
            "task": done,
            "max_force_norm_N": force[1],
            "max_torque_norm_Nm": torque[1],
            "depth_reached_m": 0.012,
        },
    }


def _claims(scenario, metrics):
    return peg_in_hole.claims(metrics, scenario, None, "hlcmp_6d")


def test_p1_holds_when_the_tilting_stiffness_rose_and_the_own_axis_stayed_small(scenario):
    assert _claims(scenario, _metrics())["P1"]["holds"] is True
    own_large = _claims(scenario, _metrics(k_r=(5.0, 40.0, 10.1)))["P1"]
    assert own_large["holds"] is False and own_large["parts"]["small_about_own_axis"] is False
    unlearned = _claims(scenario, _metrics(k_r=(0.0, 0.0, 0.0)))["P1"]
    assert unlearned["parts"] == {"adapts_on_a_tilting_axis": False, "small_about_own_axis": False}


def test_p2_needs_both_a_lower_peak_force_and_a_lower_peak_torque(scenario):
    assert _claims(scenario, _metrics())["P2"]["holds"] is True
    harder = _claims(scenario, _metrics(torque=(0.4, 0.3)))["P2"]
    assert harder["holds"] is False and harder["parts"]["lower_peak_torque"] is False
    assert harder["peak_torque_Nm"] == {"hlcmp_6d": 0.4, "const_6d_stiff": 0.3}


def test_claims_are_not_judged_when_the_learner_did_not_reach_the_depth(scenario):
    metrics = _metrics()
    metrics["hlcmp_6d"]["task"] = {"done": False, "evidence": "jammed at 11 mm"}
    judged = _claims(scenario, metrics)
    assert {judged["P1"]["holds"], judged["P2"]["holds"]} == {None}
    assert "jammed at 11 mm" in judged["P2"]["evidence"]


def test_a_translational_learner_has_no_rotational_claims(scenario):
    metrics = {"hlcmp": {"task": {"done": True, "evidence": ""}}}
    assert peg_in_hole.claims(metrics, scenario, None, "hlcmp") == {}


def test_the_done_criterion_is_2_mm_of_the_demonstrated_depth(scenario):
    entrance, axis = peg_in_hole.hole_axis(scenario)
    t = np.linspace(0.0, 1.0, 11)
    reference = entrance + np.outer(np.linspace(-0.005, 0.020, 11), axis)
    for short, done in ((0.0019, True), (0.0021, False)):
        reached = reference - short * axis
        run = SimpleNamespace(t=t, series={"x": reached, "xd": reference})
        assert peg_in_hole.inserted(run, scenario)["done"] is done
    stopped = SimpleNamespace(t=t[:3], series={"x": reference[:3], "xd": reference[:3]})
    assert peg_in_hole.inserted(stopped, scenario)["done"] is False  # the reference never got in


def test_the_tables_peak_force_is_the_norms_peak_which_p2_compares():
    """The run's table shows max ‖f‖ (the peak of the force's norm, P2's and the sweeps'),
    not the largest of the per-axis peaks, which may come from different instants."""
    axes = {"x": 30.0, "y": 5.0, "z": 20.0}
    metrics = {
        "hlcmp_6d": {
            "depth_reached_m": 0.0113,
            "depth_demonstrated_m": 0.02,
            "max_force_norm_N": 40.3,
            "max_abs_force_N": axes,
            "max_abs_torque_Nm": [0.05, 0.29, 0.01],
            "mean_abs_orientation_error_rad": [0.001, 0.002, 0.001],
            "mean_abs_position_error_m": axes,
            "mean_abs_force_N": axes,
            "force_smoothness_N": axes,
        }
    }
    table = peg_in_hole.table(metrics)
    assert table.rows[0][table.headers.index("max ‖f‖ [N]")] == "40.3"


def test_a_tip_beside_the_hole_never_entered_it_however_deep(scenario):
    """The task is the tip in the hole: below the entrance's plane but beside the fixture's
    bore (here 20 mm off its axis) is not in it."""
    entrance, axis = peg_in_hole.hole_axis(scenario)
    across = np.cross(axis, [1.0, 0.0, 0.0])
    across /= np.linalg.norm(across)
    path = np.linspace(-0.02, 0.025, 50)[:, None] * axis  # down the axis to 25 mm deep
    reference = entrance + np.linspace(-0.02, 0.02, 50)[:, None] * axis
    on_axis = SimpleNamespace(series={"x": entrance + path, "xd": reference})
    beside = SimpleNamespace(series={"x": entrance + path + 0.02 * across, "xd": reference})
    assert peg_in_hole.inserted(on_axis, scenario)["done"] is True
    task = peg_in_hole.inserted(beside, scenario)
    assert task["done"] is False
    assert task["evidence"].startswith(
        "the tip never entered the hole (at its deepest 25.0 mm below the entrance's plane, "
        "20.0 mm off the axis)"
    )
    assert peg_in_hole.deepest_in_hole(beside.series["x"], entrance, axis)[0] == 0.0
    at_the_rim = entrance + path + (peg_in_hole.ENTRANCE_RADIUS_M - 1e-4) * across
    assert peg_in_hole.deepest_in_hole(at_the_rim, entrance, axis)[0] == pytest.approx(0.025)
