"""Make the bundled demonstrations diagrams/demos/{insertion,cutting,peg_in_hole}_demo.csv:
stand-ins for kinesthetic demonstrations (paper Table I, step I), as a person guiding the
tool would make them.

The tool point (world frame, metres) moves by minimum-jerk segments through waypoints, plus
a physiological tremor (0.2 mm, 8-12 Hz, seeded), sampled at 100 Hz as a recording would be.

- insertion: approach from the side to 3 cm above the foam plank (top face z = 0.33 m, centred
  at x = 0.6, y = 0; diagrams/insertion.yaml), push down through the 3 cm plank at about
  3 cm/s to 4 cm below it, hold, and retreat back up.
- cutting: from above the block (top face z = 0.27 m, centred at x = 0.6, y = 0;
  diagrams/cutting.yaml) reach down 1.5 cm into it, cut 18 cm along y (drifting 2 cm in x)
  while pressing, and lift back to the start height -- so the z goal equals the z start,
  the DMP's g ~ p0 case.
- peg_in_hole: a pose demonstration (t,x,y,z,qw,qx,qy,qz), the peg held vertical (tool +z
  straight down) throughout: approach to 2 cm above where the hole is meant to be (entrance
  at x = 0.6, y = 0, z = 0.30; diagrams/peg_in_hole.yaml places the real one 0.5 mm off and
  tilted 3 degrees), insert straight down 2 cm into it, hold, and withdraw.

The insertion's and the cutting's demonstrations (FORCE_RECORDED) also carry the force
their wrist sensor read (`fx,fy,fz`, the force the environment exerts on the tool, world
frame, as a run's `f_ext`), recorded in the task's own world (diagrams/{task}.yaml): the
iiwa, its dynamics compensated as a gravity-compensated backdrivable arm's are, is moved
along the demonstrated path (the DMP the scenario fits to it, the tremor smoothed away) by
a stiff impedance -- the teacher's hand, TEACHER_STIFFNESS_N_PER_M, critically damped --
and the tool's contact force (with the torn foam's friction) is read every 10 ms at the samples'
times. The hand is stiffer than any controller the scenarios compare, so the tool stays
within a few millimetres of the path it is written with (the script prints how far).
`--no-force` writes the positions only; they are the same either way.

    python scripts/make_demos.py [--task insertion|cutting|peg_in_hole|all]
                                 [--out-dir diagrams/demos] [--no-force]
"""

import argparse
import dataclasses as dc
import tempfile
from pathlib import Path

import numpy as np

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import ConstantImpedanceConfig
from hlcmp_drake.io.demos import write_trajectory
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.worlds.build import diagram_factory

ROOT = Path(__file__).resolve().parent.parent

# (time at which the waypoint is reached [s], tool point [m]) per task
WAYPOINTS = {
    "insertion": [
        (0.0, (0.55, -0.05, 0.45)),  # start: above and beside the plank
        (2.0, (0.60, 0.00, 0.36)),  # approach: 3 cm above the top face
        (5.5, (0.60, 0.00, 0.26)),  # push through: 4 cm below the bottom face
        (6.0, (0.60, 0.00, 0.26)),  # hold
        (8.5, (0.60, 0.00, 0.42)),  # retreat: back up out of the plank
    ],
    "peg_in_hole": [
        (0.0, (0.55, -0.05, 0.42)),  # start: above and beside the fixture
        (2.0, (0.60, 0.00, 0.32)),  # approach: 2 cm above the hole's entrance, peg vertical
        (4.5, (0.60, 0.00, 0.28)),  # insert straight down, 2 cm into the hole
        (5.5, (0.60, 0.00, 0.28)),  # hold
        (7.5, (0.60, 0.00, 0.36)),  # withdraw: back up out of the hole
    ],
    "cutting": [
        (0.0, (0.60, -0.10, 0.34)),  # start: 7 cm above the block
        (2.0, (0.60, -0.10, 0.255)),  # reach down: the edge 1.5 cm into the block
        (6.0, (0.62, 0.08, 0.255)),  # cut along y, drifting in x, pressing lightly
        (8.0, (0.62, 0.08, 0.34)),  # lift back to the start height
    ],
}

# The tasks demonstrated as a pose: the tool's orientation (w, x, y, z), held throughout.
HELD_ORIENTATION = {"peg_in_hole": (0.0, 1.0, 0.0, 0.0)}  # half a turn about x: +z down
# The tasks whose demonstration carries the wrist force recorded in its world.
FORCE_RECORDED = ("insertion", "cutting")


def minimum_jerk_through(waypoints, t):
    """Piecewise minimum-jerk interpolation, at rest at every waypoint."""
    times = np.array([w[0] for w in waypoints])
    points = np.array([w[1] for w in waypoints])
    out = np.empty((len(t), points.shape[1]))
    for k, tk in enumerate(t):
        i = min(np.searchsorted(times, tk, side="right") - 1, len(times) - 2)
        u = np.clip((tk - times[i]) / (times[i + 1] - times[i]), 0.0, 1.0)
        out[k] = points[i] + (points[i + 1] - points[i]) * (10 * u**3 - 15 * u**4 + 6 * u**5)
    return out


# The teacher's hand about the demonstrated path [N/m]: 5x the stiffest constant impedance
# the scenarios compare (2000 N/m), so the 14 N the foam resists with moves the tool about
# 1.4 mm off the path; damped critically with the tip's apparent mass of about 4 kg.
TEACHER_STIFFNESS_N_PER_M = 10000.0
TEACHER = ConstantImpedanceConfig(
    stiffness_N_per_m=[TEACHER_STIFFNESS_N_PER_M] * 3,
    damping_Ns_per_m=[2.0 * np.sqrt(TEACHER_STIFFNESS_N_PER_M * 4.0)] * 3,
    pi=5.0,
    gain_l=[10.0] * 3,
)


def recorded_force(task, t, positions):
    """The wrist force (T, 3) [N] at the times `t` while the teacher moves the tool along
    `positions` in the task's world, and the largest distance [m] of the tool from them."""
    with tempfile.TemporaryDirectory() as folder:
        path = write_trajectory(Path(folder) / "path.csv", t, positions, ("x", "y", "z"))
        scenario, _ = load_scenario(task)
        scenario = dc.replace(
            scenario,
            controllers={"teacher": TEACHER},
            reference=dc.replace(scenario.reference, file=str(path)),
            duration_s=float(t[-1]) + scenario.log_period_s,
        )
        run = simulate(diagram_factory(scenario)("teacher"), scenario, "teacher")
    if run.status != "ok":
        raise SystemExit(f"{task}: the teacher's run stopped: {run.reason}")

    def at_samples(series):
        return np.column_stack([np.interp(t, run.t, series[:, m]) for m in range(3)])

    off_path = np.linalg.norm(at_samples(run.series["x"]) - positions, axis=1).max()
    return at_samples(run.series["f_ext"]), off_path


def tremor(t, rng, amplitude=2e-4):
    """A small band-limited tremor: a few random sines between 8 and 12 Hz per axis."""
    out = np.zeros((len(t), 3))
    for axis in range(3):
        for _ in range(4):
            f, phase = rng.uniform(8, 12), rng.uniform(0, 2 * np.pi)
            out[:, axis] += np.sin(2 * np.pi * f * t + phase)
    return amplitude * out / 4


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", choices=[*WAYPOINTS, "all"], default="all")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "diagrams" / "demos")
    parser.add_argument("--seed", type=int, default=2022)
    parser.add_argument("--no-force", action="store_true", help="write the positions only")
    args = parser.parse_args()
    for task in WAYPOINTS if args.task == "all" else [args.task]:
        waypoints = WAYPOINTS[task]
        t = np.arange(0.0, waypoints[-1][0] + 1e-9, 0.01)
        positions = minimum_jerk_through(waypoints, t) + tremor(t, np.random.default_rng(args.seed))
        out = args.out_dir / f"{task}_demo.csv"
        force, note = None, ""
        if task in FORCE_RECORDED and not args.no_force:
            force, off_path = recorded_force(task, t, positions)
            note = (
                f", force recorded in its world (peak |f| {np.abs(force).max():.2f} N; the "
                f"tool at most {1000 * off_path:.1f} mm off the path)"
            )
        quaternions = None
        if task in HELD_ORIENTATION:
            quaternions = np.tile(HELD_ORIENTATION[task], (len(t), 1))
        write_trajectory(out, t, positions, ("x", "y", "z"), quaternions=quaternions, force=force)
        print(f"wrote {len(t)} samples over {t[-1]:.2f} s to {out}{note}")


if __name__ == "__main__":
    main()
