"""How far the project's iiwa14 model (Drake's numbers, models/iiwa14.sdf) is from an
identified iiwa 14 R820: gravity torques G(q) of both at random postures.

The identified arm is Stürz, Affolter and Smith, "Parameter identification of the KUKA LBR
iiwa robot including constraints on physical feasibility", IFAC-PapersOnLine 50(1), 2017:
its Table 1 (modified Denavit-Hartenberg parameters, Khalil's convention) and Table 3 (the
links' masses and centres of mass, physically consistent, fitted to the joint torque
sensors). The sign of each joint between the two is found by matching the kinematics.

    python scripts/iiwa_model_vs_identified.py [--poses 200]

Prints the uniform scale that best maps the model's G onto the identified one, the
relative residual, and the same per joint (docs/worlds.md, the real_arm variant's model).
"""

import argparse
import itertools

import numpy as np
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from hlcmp_drake.io.paths import MODELS_DIR

# Stürz et al. 2017, Table 1: alpha_i [rad] and r_i [m] (d_i = 0, theta_i = q_i).
ALPHA = [0.0, np.pi / 2, -np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2]
OFFSET = [0.0, 0.0, 0.42, 0.0, 0.40, 0.0, 0.0]
# Table 3: m_i [kg] and the centre of mass l_Ci in link frame i [m].
MASS = [3.94781, 4.50275, 2.45520, 2.61155, 3.41000, 3.38795, 0.35432]
COM = [
    [-0.00351, 0.00160, -0.03139],
    [-0.00767, 0.16669, -0.00355],
    [-0.00225, -0.03492, -0.02652],
    [0.00020, -0.05268, 0.03818],
    [0.00005, -0.00237, -0.21134],
    [0.00049, 0.02019, -0.02750],
    [-0.03466, -0.02324, 0.07138],
]
SHOULDER_M = 0.36  # frame 0 (at joints 1 and 2) above the base, as in models/iiwa14.sdf
FLANGE_AXIS_M = 0.081  # link 7's origin beyond the wrist centre, along joint 7's axis
GRAVITY = 9.81


def _rotation_x(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _rotation_z_then_up(angle, offset):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, offset], [0, 0, 0, 1.0]])


def link_frames(q):
    """The identified arm's link frames at q, in the base frame at the shoulder."""
    pose, frames = np.eye(4), []
    for alpha, offset, angle in zip(ALPHA, OFFSET, q):
        pose = pose @ _rotation_x(alpha) @ _rotation_z_then_up(angle, offset)
        frames.append(pose)
    return frames


def identified_gravity(q, step=1e-6):
    """G(q) of the identified arm: the gradient of its potential energy [N m]."""

    def potential(angles):
        return sum(
            mass * GRAVITY * (frame @ np.append(com, 1.0))[2]
            for mass, com, frame in zip(MASS, COM, link_frames(angles))
        )

    return np.array(
        [(potential(q + step * e) - potential(q - step * e)) / (2 * step) for e in np.eye(7)]
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=200)
    args = parser.parse_args()
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(MODELS_DIR / "iiwa14.sdf"))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("iiwa_link_0"))
    plant.Finalize()
    context = plant.CreateDefaultContext()
    link_7 = plant.GetFrameByName("iiwa_link_7")

    def model(q):
        plant.SetPositions(context, q)
        origin = plant.CalcPointsPositions(context, link_7, np.zeros(3), plant.world_frame())
        return origin[:, 0], -plant.CalcGravityGeneralizedForces(context)

    rng = np.random.default_rng(0)
    limits = plant.GetPositionUpperLimits() * 0.9
    poses = rng.uniform(-limits, limits, (args.poses, 7))

    def mismatch(signs):
        return max(
            np.linalg.norm(
                (link_frames(signs * q)[6] @ [0, 0, FLANGE_AXIS_M, 1])[:3]
                + [0, 0, SHOULDER_M]
                - model(q)[0]
            )
            for q in poses[:10]
        )

    signs = min((np.array(s) for s in itertools.product([1, -1], repeat=7)), key=mismatch)
    print(f"joint signs {signs.tolist()}: link 7's origin agrees to {mismatch(signs):.1e} m")
    identified = np.array([signs * identified_gravity(signs * q) for q in poses])
    ours = np.array([model(q)[1] for q in poses])
    scale = (identified * ours).sum() / (ours * ours).sum()
    residual = np.linalg.norm(identified - scale * ours) / np.linalg.norm(identified)
    print(f"G_identified = {scale:.4f} G_model, relative residual {residual:.3f}")
    print("| joint | rms G model [N m] | rms G identified [N m] | best scale |")
    print("|---|---|---|---|")
    for j in range(7):
        rms_model = np.sqrt((ours[:, j] ** 2).mean())
        if rms_model < 1e-9:
            continue
        best = (identified[:, j] * ours[:, j]).sum() / (ours[:, j] ** 2).sum()
        rms_identified = np.sqrt((identified[:, j] ** 2).mean())
        print(f"| {j + 1} | {rms_model:.2f} | {rms_identified:.2f} | {best:.3f} |")


if __name__ == "__main__":
    main()
