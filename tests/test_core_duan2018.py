"""hlcmp_drake.core.duan2018: the force-tracking baseline's adaptation and admittance."""

import numpy as np

from hlcmp_drake.core.duan2018 import duan_adaptation_step, duan_admittance_acceleration


def test_duan_law_presses_harder_when_force_is_too_low():
    # Reaction below the desired force: Phi grows, and the admittance accelerates the
    # commanded position against the reaction (negative along the axis).
    phi = duan_adaptation_step(np.array([0.0]), np.array([1.0]), sigma=0.01, b=10.0)
    np.testing.assert_allclose(phi, [0.001])
    acc = duan_admittance_acceleration(
        np.zeros(1), np.zeros(1), phi, np.array([1.0]), np.ones(1), np.array([10.0]), np.zeros(1)
    )
    assert acc[0] < 0
