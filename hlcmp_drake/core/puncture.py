"""A foam that gives way: the tear and the torn hole's friction (the scenario's
`task.puncture`). Not one of the paper's equations: the world model the paper's insertion
premise needs ("after the tool piercing the foam plank ... the external resistance
becomes smaller"), which elastic hydroelastic contact alone cannot give. Pure numpy."""

import numpy as np


def depth_below(
    point: np.ndarray, top_point: np.ndarray, top_normal: np.ndarray
) -> float | np.ndarray:
    """How far `point` lies below an object's top face [m] (negative above it).

    Parameters
    ----------
    point : (3,) or (T, 3) array
        The tool point, world [m]; or its samples over time.
    top_point : (3,) array
        A point of the top face, world [m].
    top_normal : (3,) array
        The face's unit normal, out of the object.

    Returns
    -------
    float, or (T,) array for (T, 3) points
    """
    if np.ndim(point) == 2:
        return np.dot(np.asarray(top_point) - np.asarray(point), top_normal)
    return float(np.dot(np.asarray(top_point) - point, top_normal))


def _face_xy(point: np.ndarray, top_point: np.ndarray, top_rotation: np.ndarray) -> np.ndarray:
    """`point`'s coordinates along the face frame's x and y [m]: (2,), or (T, 2) for (T, 3)
    points."""
    return ((np.asarray(point) - np.asarray(top_point)) @ np.asarray(top_rotation))[..., :2]


def over_the_face(
    point: np.ndarray,
    top_point: np.ndarray,
    top_rotation: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> bool | np.ndarray:
    """Whether `point` lies over (or under) the object's top face: its coordinates along
    the face's own x and y axes within the face's extent. A tool point beside the object,
    however far below the face's plane, is in no hole and tears nothing.

    Parameters
    ----------
    point : (3,) or (T, 3) array
        The tool point, world [m]; or its samples over time.
    top_point : (3,) array
        The face's frame origin, world [m].
    top_rotation : (3, 3) array
        The face frame's orientation in the world (its z the outward normal).
    lower, upper : (2,) arrays
        The face's extent along its frame's x and y [m].

    Returns
    -------
    bool, or (T,) bool array for (T, 3) points
    """
    # Run by the foam's update at every plant step in contact: two comparisons, no more.
    xy = _face_xy(point, top_point, top_rotation)
    within = np.all((xy >= lower) & (xy <= upper), axis=-1)
    return bool(within) if np.ndim(point) == 1 else within


def beside_by(
    point: np.ndarray,
    top_point: np.ndarray,
    top_rotation: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> float | np.ndarray:
    """How far `point` lies beside the object's top face [m]: the distance across the
    face's plane (along its frame's x and y) from the face's extent; 0 over (or under) it.

    Parameters
    ----------
    point : (3,) or (T, 3) array
        The tool point, world [m]; or its samples over time.
    top_point : (3,) array
        The face's frame origin, world [m].
    top_rotation : (3, 3) array
        The face frame's orientation in the world (its z the outward normal).
    lower, upper : (2,) arrays
        The face's extent along its frame's x and y [m].

    Returns
    -------
    float, or (T,) array for (T, 3) points
    """
    xy = _face_xy(point, top_point, top_rotation)
    beyond = np.maximum(np.asarray(lower) - xy, 0.0) + np.maximum(xy - np.asarray(upper), 0.0)
    distance = np.linalg.norm(beyond, axis=-1)
    return float(distance) if np.ndim(point) == 1 else distance


# How far below the top face's plane a tool point still counts as at the face [m]: a tool
# resting on the foam presses it in a little, and the start posture's inverse kinematics
# puts the tool point up to 0.1 mm (per axis) off the reference's start, below it as often
# as not. A reference starting at the face, or just above it, starts the tool there.
AT_THE_FACE_M = 0.001


def came_in_from_above(came_in: bool, depth: float, over: bool) -> bool:
    """Whether the tool point has come into the object through its top face, the only way
    a tear begins: it may once it is above the face's plane or at it (less than
    AT_THE_FACE_M below: nothing is in its way down, over the face or beside it), it stays
    in while over the face, and it has not once it is deeper below the plane beside the
    object -- what it meets from there it meets from the side. A tool point that starts
    deeper below the plane has not come in from above.

    Parameters
    ----------
    came_in : bool
        Whether it had, at the step before (False at the start).
    depth : float
        Tool point below the top face [m] (negative above it).
    over : bool
        Whether it is over the face (`over_the_face`); read only deeper than
        AT_THE_FACE_M below the plane.
    """
    return depth < AT_THE_FACE_M or (came_in and over)


def came_in_over_time(depth: np.ndarray, over: np.ndarray) -> np.ndarray:
    """`came_in_from_above` at each sample of a tool point's path, from the first.

    Parameters
    ----------
    depth : (T,) array
        Tool point below the top face at each sample [m].
    over : (T,) bool array
        Whether it is over the face at each sample.

    Returns
    -------
    (T,) bool array
    """
    came_in, result = False, np.zeros(len(depth), dtype=bool)
    for k, (below, above_the_face) in enumerate(zip(depth, over)):
        came_in = came_in_from_above(came_in, float(below), bool(above_the_face))
        result[k] = came_in
    return result


def deep_enough_to_tear(depth: float | np.ndarray, tear_depth: float) -> bool | np.ndarray:
    """Whether the tool point is deep enough for the foam to tear (`tears`' first half,
    which needs no velocity).

    Parameters
    ----------
    depth : float or (T,) array
        Tool point below the top face [m]; or its samples over time.
    tear_depth : float
        The depth at which the foam tears [m].
    """
    return depth >= tear_depth


def tears(depth: float, inward_speed: float, tear_depth: float) -> bool:
    """Whether the foam tears now, under a tool point that came in through its top face
    (`came_in_from_above`): at the tear depth, moving in.

    Parameters
    ----------
    depth : float
        Tool point below the top face [m].
    inward_speed : float
        Its speed into the object [m/s] (positive: going in).
    tear_depth : float
        The depth at which the foam tears [m].
    """
    return bool(deep_enough_to_tear(depth, tear_depth)) and inward_speed > 0.0


def hole_friction(
    depth: float, thickness: float, axial_speed: float, friction_per_m: float, sliding_speed: float
) -> float:
    """The torn hole's friction on the tool along its axis [N]:

        F = -c * clip(depth, 0, thickness) * tanh(v / v_s)

    a Coulomb force per unit length of tool inside the object, opposing the axial motion,
    smoothed near v = 0 (an explicit force in a 1 kHz loop must not chatter).

    Parameters
    ----------
    depth : float
        Tool point below the top face [m]; the length inside is capped by the thickness.
    thickness : float
        The object's thickness [m].
    axial_speed : float
        Tool velocity along its axis (positive: going in) [m/s].
    friction_per_m : float
        c [N/m].
    sliding_speed : float
        v_s [m/s], the speed at which the friction reaches tanh(1) = 76 % of its full value.
    """
    engaged = min(max(depth, 0.0), thickness)
    return -friction_per_m * engaged * float(np.tanh(axial_speed / sliding_speed))
