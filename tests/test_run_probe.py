"""The worlds measured alone: the tool on a stiff carriage, no controller under test
(`hlcmp probe`), against the paper's premise of a foam that resists and then gives way,
without the sideways force that Drake's discrete hydroelastic contact gave the old rod
and blade, and against the peg world's premise: a peg free to turn aligns with the tilted
hole, one held stiffly jams (hlcmp_drake.run.probe)."""

import json
import math

import numpy as np
import pytest
from conftest import assert_output_names, one_line_error, run_cli

from hlcmp_drake.cli import main
from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.probe import run_probe


@pytest.mark.parametrize(
    "tilt",
    [0.0, pytest.param(1e-3, marks=pytest.mark.slow), pytest.param(-1e-3, marks=pytest.mark.slow)],
)
def test_insertion_foam_resists_then_gives_way_without_sideways_force(tmp_path, tilt):
    readings = run_probe("insertion", tmp_path, overrides=[f"probe.tilt_rad={tilt}"]).readings
    assert readings["status"] == "ok"
    assert readings["max_lateral_force_N"] < 0.5
    assert 10.0 <= readings["peak_force_N"] <= 20.0
    assert 0.0 < readings["residual_force_N"] <= 0.5 * readings["peak_force_N"]
    assert readings["min_resisting_force_N"] > -0.05  # a torn foam never pulls the tool in
    assert 0.005 < readings["depth_at_peak_m"] < 0.03  # inside the 30 mm plank


@pytest.mark.slow
@pytest.mark.parametrize("tilt", [0.0, 1e-3, -1e-3])
def test_cutting_blade_is_not_pushed_out_of_its_plane(tmp_path, tilt):
    readings = run_probe("cutting", tmp_path, overrides=[f"probe.tilt_rad={tilt}"]).readings
    assert readings["status"] == "ok" and readings["max_lateral_force_N"] < 0.5
    assert readings["residual_force_N"] > 1.0  # the block does resist the cut


def test_without_the_puncture_the_elastic_foam_pulls_the_tool_through(tmp_path):
    """Why the world needs the puncture: hydroelastic contact has no memory of the hole."""
    readings = run_probe(
        "insertion", tmp_path, overrides=["task.puncture.object_frame=''"]
    ).readings
    assert readings["min_resisting_force_N"] < -1.0


def test_probe_command_writes_its_files(tmp_path):
    assert main(["probe", "insertion", "--out", str(tmp_path), "--speed", "0.05"]) == 0
    result = json.loads((tmp_path / "probe.json").read_text())
    assert set(result) >= {
        "scenario",
        "speed_m_per_s",
        "peak_force_N",
        "depth_at_peak_m",
        "residual_force_N",
        "max_lateral_force_N",
        "status",
    }
    assert result["speed_m_per_s"] == pytest.approx(0.05)
    assert (tmp_path / "probe.png").read_bytes()[:4] == b"\x89PNG"
    assert_output_names(tmp_path)


def test_a_probe_that_touches_nothing_says_so(tmp_path, capsys):
    above = "probe.start_m=[0.6, 0.0, 0.6]"  # 265 mm above the plank, pushed 50 mm down
    assert main(["probe", "insertion", "--out", str(tmp_path), "--set", above]) == 0
    warning = "hlcmp: warning: the tool touched nothing: no force along the whole path"
    assert warning in capsys.readouterr().err
    assert main(["probe", "insertion", "--out", str(tmp_path), "--speed", "0.3"]) == 0
    assert "warning" not in capsys.readouterr().err


def test_a_probe_started_in_the_plank_is_refused(tmp_path, capsys):
    """10 mm into the foam the tool never comes in through its face, so the foam never
    tears: the probe would read the memoryless field pulling it in (residual 0 N, a
    negative resisting force) as the plank's. Refused, as a run's reference is."""
    inside = "probe.start_m=[0.6, 0.0, 0.32]"
    assert main(["probe", "insertion", "--out", str(tmp_path), "--set", inside]) == 2
    err = capsys.readouterr().err
    assert (
        "insertion: probe.start_m puts the tool point at (0.600, 0.000, 0.320) m, 10.0 mm " in err
    )
    assert "start it above the face" in err
    assert not any(tmp_path.iterdir())


def test_a_scenario_without_a_probe_is_one_clear_line(capsys):
    assert main(["probe", "one_dof"]) == 2
    assert "has no probe" in capsys.readouterr().err
    # An arm world without a probe section: its missing probe, not its speed, is named.
    unprobed = ["--set", "probe.start_m=[]", "--set", "probe.push_m=[]"]
    assert main(["probe", "insertion", *unprobed]) == 2
    assert "scenario 'insertion' has no probe: it needs" in capsys.readouterr().err


@pytest.mark.parametrize(
    "speed, expected",
    [
        ("30", "--speed: must be at most 0.5 m/s, got 30: the 50 mm push needs 100 or more"),
        (
            "1e-9",
            "--speed: must be at least 0.0001 m/s, got 1e-09: the 100 mm path (approach_m's 0 "
            "mm, then push_m's 50 mm in and out) would take",
        ),
    ],
)
def test_a_probe_too_fast_to_resolve_its_push_or_too_slow_to_end_is_refused(
    tmp_path, capsys, speed, expected
):
    assert main(["probe", "insertion", "--out", str(tmp_path), "--speed", speed]) == 2
    assert capsys.readouterr().err.startswith(f"hlcmp: error: {expected}")
    assert not any(tmp_path.iterdir())
    over = "probe.speed_m_per_s=0.6"
    assert main(["probe", "insertion", "--out", str(tmp_path), "--set", over]) == 2
    assert "insertion: probe.speed_m_per_s: must be at most 0.5" in capsys.readouterr().err
    # a push typed in mm: the path's parts are named, not the speed alone
    pushed = ["probe", "insertion", "--out", str(tmp_path), "--set", "probe.push_m=[0,0,-50]"]
    assert main(pushed) == 2
    assert "(approach_m's 0 mm, then push_m's 50000 mm in and out)" in capsys.readouterr().err
    # a run, which moves no carriage, takes a time step at which the probe could not run
    load_scenario("insertion", ["plant_config.time_step=0.02"])


# The peg world's premise, written before it was first probed (docs/worlds.md, "The peg in
# a tilted hole"): its tip driven along the 3-degree hole's axis, 20 mm into the bore.
HOLE_TILT_RAD = math.radians(3.0)
FULL_TRAVEL_M = 0.025  # 5 mm above the entrance to 20 mm into the bore
JAM_FORCE_N = 50.0


def _travel_where_axial_force_first_exceeds(out_dir, threshold):
    """The travel along the push [m] where the force against it first exceeds `threshold`
    [N], from probe.npz; inf when it never does."""
    scenario, _ = load_scenario("peg_in_hole")
    direction = np.asarray(scenario.probe.push_m) / np.linalg.norm(scenario.probe.push_m)
    series = np.load(out_dir / "probe.npz")
    travel = (series["tool_position"] - series["tool_position"][0]) @ direction
    above = np.flatnonzero(-(series["force"] @ direction) > threshold)
    return travel[above[0]] if above.size else math.inf


@pytest.mark.slow  # the peg pushed the whole depth of the hole (about 2.3 s)
def test_a_peg_free_to_turn_about_its_tip_aligns_with_the_tilted_hole(tmp_path):
    readings = run_probe("peg_in_hole", tmp_path).readings
    assert readings["status"] == "ok"
    assert readings["start_tilt_rad"] == pytest.approx(HOLE_TILT_RAD, abs=1e-3)
    assert readings["max_travel_m"] > FULL_TRAVEL_M - 1e-4  # the full depth
    assert readings["final_tilt_rad"] < math.radians(0.5)  # turned to the hole's axis
    assert _travel_where_axial_force_first_exceeds(tmp_path, JAM_FORCE_N) == math.inf


@pytest.mark.slow  # the peg pushed the whole depth of the hole (about 2.8 s)
def test_a_peg_held_stiffly_in_rotation_jams_in_the_tilted_hole(tmp_path):
    overrides = ["probe.wrist_stiffness_Nm_per_rad=[100,100,100]"]  # the arm's hold today
    readings = run_probe("peg_in_hole", tmp_path, overrides=overrides).readings
    assert readings["status"] == "ok"
    assert readings["peak_force_N"] > JAM_FORCE_N
    assert _travel_where_axial_force_first_exceeds(tmp_path, JAM_FORCE_N) < FULL_TRAVEL_M
    assert readings["final_tilt_rad"] > math.radians(0.5)  # still off the hole's axis


def test_settings_the_probe_never_reads_are_named():
    from hlcmp_drake.run.probe import unused_by_the_probe

    given = ["duration_s=1", "probe.tilt_rad=0.001", "controllers.hlcmp.q_k=[1,1,1]",
             "task.puncture.depth_m=0.01", "recording.frames_per_second=30"]  # fmt: skip
    assert unused_by_the_probe(given) == [given[0], given[2], given[4]]


def test_a_setting_the_probe_never_reads_is_refused_when_bad_and_only_then_warned_of(tmp_path):
    """probe --set controllers.hlcmp.pi=-1 warned that the probe does not use it, then
    refused it: a bad value is refused alone (the scenario with every --set must load, as
    for any command), and a good one the probe never reads is warned of."""
    bad = ["probe", "insertion", "--set", "controllers.hlcmp.pi=-1", "--out", tmp_path / "p"]
    assert "pi must be > 0" in one_line_error(run_cli(*bad))
    warnings = []
    run_probe("insertion", tmp_path / "p", overrides=["duration_s=1"], warn=warnings.append)
    assert warnings == ["--set duration_s=1: the probe does not use it (it pushes the tool alone)"]
