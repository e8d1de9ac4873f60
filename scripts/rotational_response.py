"""How fast a 6-D controller lets the tool turn under a steady torque, against what its
stiffness alone would allow: the peg-in-hole world's iiwa (no contact: the fixture is
far below), held at its start by a constant 6-D impedance of each rotational stiffness
listed, a constant torque about a tool axis applied to the tool's body from t = 0.

The paper's law has no inertia shaping: in 6-D its closed loop is Λ ε' + (C + L) ε + u =
F_ext with ε = V - V_e, so the rotation about the tool point is damped by Λ_ωω π_r besides
D_r + L_r, and held by K_r + L_r π_r. The script prints Λ_ωω (tool axes) at the start
posture, the static tilt τ / (K_r + L_r π_r), and the tilt reached at each listed time.

    python scripts/rotational_response.py [--torque 0.2] [--axis 1] [--stiffness 0 10 100]
        [--times 0.5 2 5]
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import AddMultibodyPlant, ExternallyAppliedSpatialForce
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.core.rotation_law import rotation_errors
from hlcmp_drake.systems.pose_control import PoseReference
from hlcmp_drake.worlds.arm import prepare
from hlcmp_drake.worlds.models import load_models, scoped_frame
from hlcmp_drake.worlds.pose import pose_tick

SCENARIO = "peg_in_hole"


def tilt_over_time(stiffness: float, damping: float, torque: np.ndarray, times: list[float]):
    """The tool's turn |e_r| [rad] at each of `times` [s] under the tool-frame `torque`
    [N m], held by const_6d_soft's gains with K_r = stiffness, D_r = damping; and the 6-D
    terms at the start posture (`SpatialTerms`)."""
    scenario, _ = load_scenario(
        SCENARIO,
        [
            f"controllers.const_6d_soft.rotational_stiffness_Nm_per_rad={[stiffness] * 3}",
            f"controllers.const_6d_soft.rotational_damping_Nms_per_rad={[damping] * 3}",
        ],
    )
    setup = prepare(scenario)
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(scenario.plant_config, builder)
    load_models(plant, scenario)
    diagram = builder.Build()
    tick = pose_tick(scenario, "const_6d_soft", plant=plant, setup=setup)
    simulator = Simulator(diagram)
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetPositions(context, setup.q0)
    start = tick.model.terms(np.concatenate([setup.q0, np.zeros(plant.num_velocities())]))
    push = ExternallyAppliedSpatialForce()
    push.body_index = scoped_frame(plant, scenario.task.tool_frame).body().index()
    push.F_Bq_W = SpatialForce(quat.rotate(start.orientation, torque), np.zeros(3))
    plant.get_applied_spatial_force_input_port().FixValue(context, [push])
    zero, step = np.zeros(3), plant.time_step()
    reference = PoseReference(start.position, zero, zero, start.orientation, zero, zero, 1.0)
    tilts, k = [], 0
    for until in times:
        while k * step < until - 1e-12:
            result = tick.evaluate(plant.GetPositionsAndVelocities(context), reference, None)
            plant.get_actuation_input_port().FixValue(context, result.torque)
            k += 1
            simulator.AdvanceTo(k * step)
        terms = tick.model.terms(plant.GetPositionsAndVelocities(context))
        e_r, _ = rotation_errors(terms.orientation, zero, start.orientation, zero)
        tilts.append(float(np.linalg.norm(e_r)))
    return tilts, start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--torque", type=float, default=0.2, help="[N m] (default 0.2)")
    parser.add_argument("--axis", type=int, default=1, help="tool axis 0/1/2 (default 1: y)")
    parser.add_argument("--stiffness", type=float, nargs="+", default=[0.0, 10.0, 100.0])
    parser.add_argument("--times", type=float, nargs="+", default=[0.5, 2.0, 5.0])
    args = parser.parse_args()
    torque = np.zeros(3)
    torque[args.axis] = args.torque
    scenario, _ = load_scenario(SCENARIO)
    soft = scenario.controllers["const_6d_soft"]
    gain_l_r, pi_r = soft.gain_l_r[args.axis], soft.pi_r
    print(
        f"{args.torque} N m about tool {'xyz'[args.axis]}; L_r = {gain_l_r}, pi_r = {pi_r}; "
        "D_r scaled as const_6d_soft's (10 sqrt(K_r / 100), at least 0.5)"
    )
    header = "K_r [N m/rad] | static tilt [deg] | " + " | ".join(
        f"tilt at {t:g} s [deg]" for t in args.times
    )
    rows = []
    for stiffness in args.stiffness:
        damping = max(10.0 * math.sqrt(stiffness / 100.0), 0.5)
        tilts, start = tilt_over_time(stiffness, damping, torque, args.times)
        static = args.torque / (stiffness + gain_l_r * pi_r)
        rows.append(
            f"{stiffness:g} | {math.degrees(static):.2f} | "
            + " | ".join(f"{math.degrees(t):.2f}" for t in tilts)
        )
    rotation = quat.to_matrix(start.orientation)
    inertia = rotation.T @ start.inertia[:3, :3] @ rotation
    print(
        "Λ_ωω at the start posture, tool axes (diagonal) [kg m^2]: "
        + "/".join(f"{v:.2f}" for v in np.diag(inertia))
        + f"; its damping Λ_ωω π_r about tool {'xyz'[args.axis]}: "
        f"{inertia[args.axis, args.axis] * pi_r:.1f} N m s/rad"
    )
    print(header)
    for row in rows:
        print(row)


if __name__ == "__main__":
    main()
