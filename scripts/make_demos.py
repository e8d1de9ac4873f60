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

    python scripts/make_demos.py [--task insertion|cutting|peg_in_hole|all] [--out-dir ...]
"""

import argparse
from pathlib import Path

import numpy as np

from hlcmp_drake.io.demos import write_trajectory

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


def tremor(t, rng, amplitude=2e-4):
    """A small band-limited tremor: a few random sines between 8 and 12 Hz per axis."""
    out = np.zeros((len(t), 3))
    for axis in range(3):
        for _ in range(4):
            f, phase = rng.uniform(8, 12), rng.uniform(0, 2 * np.pi)
            out[:, axis] += np.sin(2 * np.pi * f * t + phase)
    return amplitude * out / 4


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", choices=[*WAYPOINTS, "all"], default="all")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "diagrams" / "demos")
    parser.add_argument("--seed", type=int, default=2022)
    args = parser.parse_args()
    for task in WAYPOINTS if args.task == "all" else [args.task]:
        waypoints = WAYPOINTS[task]
        t = np.arange(0.0, waypoints[-1][0] + 1e-9, 0.01)
        positions = minimum_jerk_through(waypoints, t) + tremor(t, np.random.default_rng(args.seed))
        out = args.out_dir / f"{task}_demo.csv"
        quaternions = None
        if task in HELD_ORIENTATION:
            quaternions = np.tile(HELD_ORIENTATION[task], (len(t), 1))
        write_trajectory(out, t, positions, ("x", "y", "z"), quaternions=quaternions)
        print(f"wrote {len(t)} samples over {t[-1]:.2f} s to {out}")


if __name__ == "__main__":
    main()
