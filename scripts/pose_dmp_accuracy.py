"""The orientation DMP on the seeded demonstrations of tests/test_core_orientation_dmp.py
(tests/conftest.py: `tilted_turn`), one line per seed:

    python scripts/pose_dmp_accuracy.py [--seeds 12] [--noise-deg 0.2]

Columns: the demonstrated turn; the rollout's geodesic RMS and largest error against the
noise-free orientation, its error at t = tau against it and against the demonstrated goal
(the last, noisy sample); the largest 2 ms step; the largest difference, at equal phase,
between the rollout and one of twice the duration; and the RMS error of the same DMP with
its weights fitted by Eq. 19's f_target regression instead of on the trajectory (the
alternative `core.orientation_dmp` explains it does not use).
"""

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from conftest import tilted_turn  # noqa: E402

from hlcmp_drake.core import quaternion as quat  # noqa: E402
from hlcmp_drake.core.dmp import (  # noqa: E402
    TAIL_FRACTION,
    basis_centers_and_widths,
    fit_forcing_weights,
    forcing_basis,
    forcing_target,
    phase_at,
    resample_and_differentiate,
)
from hlcmp_drake.core.orientation_dmp import OrientationDmp  # noqa: E402


def degrees(a, b):
    return np.degrees(quat.geodesic_angle(a, b))


def with_acceleration_fit(dmp, t, quaternions):
    """The same DMP with its weights from Eq. 19's targets (the second derivative of e)."""
    settings = dmp.settings
    q = quaternions / np.linalg.norm(quaternions, axis=1, keepdims=True)
    error = quat.unwrap_rotation_vectors(
        quat.to_rotation_vector(quat.multiply(q[-1], quat.conjugate(q)))[::-1], np.zeros(3)
    )[::-1]
    t_u, e, edot, eddot = resample_and_differentiate(t, error, settings.smoothing_s)
    tau, dt = float(t_u[-1]), t_u[1] - t_u[0]
    tail = int(TAIL_FRACTION * tau / dt)
    s = phase_at(np.concatenate([t_u, tau + dt * np.arange(1, tail + 1)]), tau, settings.alpha_s)
    centers, widths = basis_centers_and_widths(settings.n_basis, settings.alpha_s)
    features = forcing_basis(s, centers, widths, np.array([dmp.amplitude]))[:, 0, :]
    theta = np.stack(
        [
            fit_forcing_weights(
                features,
                np.concatenate(
                    [
                        forcing_target(
                            e[:, m],
                            edot[:, m],
                            eddot[:, m],
                            0.0,
                            tau,
                            settings.alpha,
                            settings.beta_value,
                        ),
                        np.zeros(tail),
                    ]
                ),
            )
            for m in range(3)
        ]
    )
    return dataclasses.replace(dmp, theta=theta)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=12)
    parser.add_argument("--noise-deg", type=float, default=0.2)
    args = parser.parse_args()
    print(
        "seed  turn[deg]  rms  max  end(truth)  end(goal)  step(2ms)  2x-tau(phase)  "
        "rms(Eq.19 fit)   [deg]"
    )
    for seed in range(args.seeds):
        t, _, q, truth = tilted_turn(seed, noise_deg=args.noise_deg)
        dmp = OrientationDmp.fit(t, q)
        t_r, q_r, _, _ = dmp.rollout(dt=0.002)
        error = degrees(q_r, truth(t_r))
        _, q_slow, _, _ = dmp.rollout(dt=0.002, tau=2 * dmp.tau)
        _, q_eq19, _, _ = with_acceleration_fit(dmp, t, q).rollout(dt=0.002)
        eq19 = degrees(q_eq19, truth(t_r))
        print(
            f"{seed:4d}  {np.degrees(np.linalg.norm(dmp.demonstrated_rotation)):9.1f}  "
            f"{np.sqrt(np.mean(error**2)):.3f}  {error.max():.3f}  {error[-1]:10.3f}  "
            f"{degrees(q_r[-1], dmp.goal):9.3f}  {degrees(q_r[1:], q_r[:-1]).max():9.3f}  "
            f"{degrees(q_slow[::2], q_r).max():13.1e}  {np.sqrt(np.mean(eq19**2)):14.3f}"
        )


if __name__ == "__main__":
    main()
