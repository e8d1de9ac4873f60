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


def test_the_tool_point_comes_in_only_through_the_top_face():
    """From above the face's plane, then over the face: in. Started below the plane, or
    gone below it beside the object, it is not in -- not even once it is under the face."""
    from hlcmp_drake.core.puncture import came_in_from_above, came_in_over_time

    assert came_in_from_above(False, -0.01, False)  # above the plane, beside: may come in
    assert came_in_from_above(True, 0.02, True)  # then down over the face
    assert not came_in_from_above(False, 0.02, True)  # started below, under the face
    assert not came_in_from_above(True, 0.02, False)  # went below the plane beside it
    depth = np.array([-0.01, 0.005, 0.02, 0.02, -0.01, 0.02])
    over = np.array([True, False, False, True, True, True])
    # Down beside the object, slid under its face, then back up and in from above.
    assert came_in_over_time(depth, over).tolist() == [True, False, False, False, True, True]
    assert not came_in_over_time(np.array([0.02, 0.03]), np.array([True, True])).any()


def test_beside_by_is_the_distance_across_the_face_from_its_extent():
    from hlcmp_drake.core.puncture import beside_by, over_the_face

    top, rotation = np.array([0.6, 0.0, 0.33]), np.eye(3)
    lower, upper = np.array([-0.15, -0.1]), np.array([0.15, 0.1])
    points = np.array([[0.6, 0.05, 0.2], [0.6, -0.3, 0.3], [1.05, 0.5, 0.5]])
    assert beside_by(points, top, rotation, lower, upper) == pytest.approx([0.0, 0.2, 0.5])
    assert over_the_face(points, top, rotation, lower, upper).tolist() == [True, False, False]
    assert beside_by(points[1], top, rotation, lower, upper) == pytest.approx(0.2)
    assert over_the_face(points[0], top, rotation, lower, upper) is True


def test_a_tool_point_at_the_face_comes_in_through_it():
    """A tool resting on the face, or started just below it by the start posture's 0.1 mm
    of inverse-kinematics tolerance (a reference starting on the face or 0.08 mm above
    it), comes in through the face: it tears once deep enough. Deeper, it has not."""
    from hlcmp_drake.core.puncture import AT_THE_FACE_M, came_in_from_above, came_in_over_time

    assert came_in_from_above(False, 0.0, True)
    assert came_in_from_above(False, 0.0001, True)
    assert came_in_from_above(False, 0.0005, True)
    assert not came_in_from_above(False, AT_THE_FACE_M, True)
    assert came_in_over_time(np.array([0.0001, 0.01, 0.02]), np.ones(3, dtype=bool)).all()
