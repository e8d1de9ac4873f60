"""The worlds measured alone: the tool on a stiff carriage, no controller under test
(`hlcmp probe`), against the paper's premise of a foam that resists and then gives way,
and without the sideways force that Drake's discrete hydroelastic contact gave the old rod
and blade. Also the puncture model's parts."""

import json

import numpy as np
import pytest

from hlcmp_drake.cli import main
from hlcmp_drake.core.puncture import depth_below, hole_friction, tears
from hlcmp_drake.run.probe import run_probe
from hlcmp_drake.systems.puncture import HoleFriction


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


def test_the_tear_and_the_hole_friction_by_hand():
    assert depth_below(
        np.array([0.0, 0.0, 0.31]), np.array([0.6, 0.0, 0.33]), np.array([0.0, 0.0, 1.0])
    ) == pytest.approx(0.02)
    assert (
        tears(0.016, 0.01, 0.015)
        and not tears(0.016, -0.01, 0.015)
        and not tears(0.014, 0.01, 0.015)
    )
    # 150 N/m over the 30 mm the shaft fills, at full speed: 4.5 N against the motion.
    assert hole_friction(0.045, 0.03, 0.03, 150.0, 0.002) == pytest.approx(-4.5, rel=1e-6)
    assert hole_friction(0.045, 0.03, -0.03, 150.0, 0.002) == pytest.approx(4.5, rel=1e-6)
    assert hole_friction(-0.01, 0.03, 0.03, 150.0, 0.002) == 0.0  # out of the hole


def test_hole_friction_starts_one_step_after_the_tear():
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import PrismaticJoint, SpatialInertia, UnitInertia
    from pydrake.systems.analysis import Simulator

    plant = MultibodyPlant(0.0)  # a tool point on a vertical slide: its state is (z, z')
    tool = plant.AddRigidBody(
        "tool", SpatialInertia(1.0, np.zeros(3), UnitInertia.SolidSphere(0.01))
    )
    plant.AddJoint(PrismaticJoint("slide", plant.world_frame(), tool.body_frame(), [0.0, 0.0, 1.0]))
    plant.Finalize()
    system = HoleFriction(
        plant,
        tool.body_frame(),
        [0, 0, -1],
        [0.6, 0, 0.33],
        [0, 0, 1],
        0.03,
        0.015,
        150.0,
        0.002,
        0.001,
    )
    context = system.CreateDefaultContext()
    system.plant_state.FixValue(
        context, [0.31, -0.03]
    )  # 20 mm below the top face (z = 0.33), going in
    simulator = Simulator(system, context)
    force = system.GetOutputPort("force")
    stages = []
    for k in range(3):  # one update per millisecond, at t = 0, 1, 2 ms
        simulator.AdvanceTo(0.0005 + 0.001 * k)
        stages.append((system.punctured(context), force.Eval(context)[2]))
    assert stages[0] == (True, 0.0)  # torn at once: the contact is to end now, no friction yet
    assert stages[1] == (True, 0.0)  # one step for the contact to end
    assert stages[2][0] and stages[2][1] == pytest.approx(
        3.0, rel=1e-6
    )  # then 150 N/m x 20 mm, upwards
    system.plant_state.FixValue(context, [0.35, 0.03])  # out of the hole, going up: no friction
    simulator.AdvanceTo(0.0035)
    assert force.Eval(context)[2] == 0.0 and system.punctured(context)
