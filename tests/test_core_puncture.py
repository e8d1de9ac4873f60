"""hlcmp_drake.core.puncture: the tear and the hole's friction, by hand."""

import numpy as np
import pytest

from hlcmp_drake.core.puncture import deep_enough_to_tear, depth_below, hole_friction, tears


def test_the_tear_and_the_hole_friction_by_hand():
    assert depth_below(
        np.array([0.0, 0.0, 0.31]), np.array([0.6, 0.0, 0.33]), np.array([0.0, 0.0, 1.0])
    ) == pytest.approx(0.02)
    assert (
        tears(0.016, 0.01, 0.015)
        and not tears(0.016, -0.01, 0.015)
        and not tears(0.014, 0.01, 0.015)
    )
    # The depth alone (what the foam's update asks before it reads the velocity): at or
    # below the tear depth, at any speed; above it, never a tear.
    assert deep_enough_to_tear(0.015, 0.015) and deep_enough_to_tear(0.016, 0.015)
    assert not deep_enough_to_tear(0.0149, 0.015) and not tears(0.0149, 1.0, 0.015)
    # 150 N/m over the 30 mm the shaft fills, at full speed: 4.5 N against the motion.
    assert hole_friction(0.045, 0.03, 0.03, 150.0, 0.002) == pytest.approx(-4.5, rel=1e-6)
    assert hole_friction(0.045, 0.03, -0.03, 150.0, 0.002) == pytest.approx(4.5, rel=1e-6)
    assert hole_friction(-0.01, 0.03, 0.03, 150.0, 0.002) == 0.0  # out of the hole
