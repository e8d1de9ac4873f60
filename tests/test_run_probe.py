"""The worlds measured alone: the tool on a stiff carriage, no controller under test
(`hlcmp probe`), against the paper's premise of a foam that resists and then gives way,
and without the sideways force that Drake's discrete hydroelastic contact gave the old rod
and blade (hlcmp_drake.run.probe)."""

import json

import pytest

from hlcmp_drake.cli import main
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


def test_a_scenario_without_a_probe_is_one_clear_line(capsys):
    assert main(["probe", "one_dof"]) == 2
    assert "has no probe" in capsys.readouterr().err
