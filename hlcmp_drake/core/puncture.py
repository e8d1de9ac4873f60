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


def over_the_face(
    point: np.ndarray,
    top_point: np.ndarray,
    top_rotation: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> bool:
    """Whether `point` lies over (or under) the object's top face: its coordinates along
    the face's own x and y axes within the face's extent. A tool point beside the object,
    however far below the face's plane, is in no hole and tears nothing.

    Parameters
    ----------
    point : (3,) array
        The tool point, world [m].
    top_point : (3,) array
        The face's frame origin, world [m].
    top_rotation : (3, 3) array
        The face frame's orientation in the world (its z the outward normal).
    lower, upper : (2,) arrays
        The face's extent along its frame's x and y [m].
    """
    xy = (np.asarray(top_rotation).T @ (np.asarray(point) - np.asarray(top_point)))[:2]
    return bool(np.all(xy >= lower) and np.all(xy <= upper))


def deep_enough_to_tear(depth: float, tear_depth: float) -> bool:
    """Whether the tool point is deep enough for the foam to tear (`tears`' first half,
    which needs no velocity).

    Parameters
    ----------
    depth : float
        Tool point below the top face [m].
    tear_depth : float
        The depth at which the foam tears [m].
    """
    return depth >= tear_depth


def tears(depth: float, inward_speed: float, tear_depth: float) -> bool:
    """Whether the foam tears now.

    Parameters
    ----------
    depth : float
        Tool point below the top face [m].
    inward_speed : float
        Its speed into the object [m/s] (positive: going in).
    tear_depth : float
        The depth at which the foam tears [m].
    """
    return deep_enough_to_tear(depth, tear_depth) and inward_speed > 0.0


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
