"""Unit quaternions of rotations, scalar first: q = (w, x, y, z), Drake's `Quaternion(w, x, y,
z)` order; q and -q are one rotation. Pure numpy, every function vectorized over leading axes.
Those a controller tick needs are also `jitable` (`core.kernels`): written in numba's nopython
subset, which compiles them for one quaternion or vector (1-D arrays); `cross`, `to_matrix` and
`skew`, which branch on their argument's ndim, take float arrays only (not lists).

Conventions, each formula once:

- Hamilton product (`multiply`); a vector v rotates as q v q* (`rotate`).
- Exp and Log are written for rotation vectors: `from_rotation_vector(v)` = Exp(v / 2), the
  rotation by |v| rad about v / |v|; `to_rotation_vector(q)` = 2 Log(q), its principal value
  (|v| <= pi). The two rotation vectors v (|v| = theta) and v (theta - 2 pi) / theta, and all
  v (theta + 2 pi k) / theta, are the same rotation; `nearest_rotation_vector` picks the one
  nearest to a reference, which is how a rotation beyond pi keeps its direction.
- Angular velocities are in the world (fixed) frame: R' R^T = [omega]x.
"""

import numpy as np

from hlcmp_drake.core.kernels import jitable

# Below this angle [rad] Exp and Log use their Taylor limits (the axis is undefined at 0).
SMALL_ANGLE = 1e-9


@jitable
def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a . b of (..., 3) arrays over their last axis, kept as (..., 1): np.sum's order of
    the three products, so equal to it (and to np.linalg.norm's square) to the bit, without
    its keepdims, which numba lacks.

    Parameters
    ----------
    a, b : (..., 3) arrays

    Returns
    -------
    (..., 1) array
    """
    return a[..., :1] * b[..., :1] + a[..., 1:2] * b[..., 1:2] + a[..., 2:] * b[..., 2:]


@jitable
def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of (..., 3) arrays (leading axes broadcast): np.cross's products in its order,
    without its axis handling, which costs several µs per call on one 3-vector in a 1 kHz
    tick.

    Parameters
    ----------
    a, b : (..., 3) arrays

    Returns
    -------
    (..., 3) array
    """
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    parts = (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)
    # Two ifs: numba compiles only the branch an argument's ndim takes, not on a compound test.
    if a.ndim == 1:
        if b.ndim == 1:
            return np.array(parts)
    return np.stack(parts, axis=-1)


@jitable
def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Hamilton product a b.

    Parameters
    ----------
    a, b : (..., 4) arrays
        Quaternions (w, x, y, z); leading axes broadcast.

    Returns
    -------
    (..., 4) array
        a b: the rotation b, then a (both in the world frame).
    """
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    w = aw * bw - dot(av, bv)
    v = aw * bv + bw * av + cross(av, bv)
    return np.concatenate((w, v), axis=-1)


@jitable
def conjugate(q: np.ndarray) -> np.ndarray:
    """q* = (w, -x, -y, -z), the inverse rotation of a unit quaternion.

    Parameters
    ----------
    q : (..., 4) array

    Returns
    -------
    (..., 4) array
    """
    q = np.asarray(q, dtype=np.float64)
    return np.concatenate((q[..., :1], -q[..., 1:]), axis=-1)


def from_rotation_vector(v: np.ndarray) -> np.ndarray:
    """Exp(v / 2) = (cos(theta / 2), sin(theta / 2) v / theta), theta = |v|.

    Parameters
    ----------
    v : (..., 3) array
        Rotation vector [rad]: axis times angle, any length.

    Returns
    -------
    (..., 4) array
        The unit quaternion; for |v| > pi its w is negative (the other hemisphere of the
        same rotation as the principal one).
    """
    v = np.asarray(v, dtype=float)
    theta = np.linalg.norm(v, axis=-1, keepdims=True)
    # sin(theta / 2) / theta, which is 1/2 at theta = 0 (np.sinc(x) = sin(pi x) / (pi x)).
    half_sinc = 0.5 * np.sinc(theta / (2.0 * np.pi))
    return np.concatenate([np.cos(theta / 2.0), half_sinc * v], axis=-1)


@jitable
def to_rotation_vector(q: np.ndarray) -> np.ndarray:
    """2 Log(q), the principal rotation vector of a unit quaternion: |v| <= pi.

    q and -q give the same vector. At a rotation of exactly pi the two opposite vectors
    v and -v are one rotation; the one along q's (x, y, z) for w >= 0 is returned.

    Parameters
    ----------
    q : (..., 4) array
        Unit quaternion(s).

    Returns
    -------
    (..., 3) array
        Rotation vector [rad], |v| in [0, pi].
    """
    q = np.asarray(q, dtype=np.float64)
    q = np.where(q[..., :1] < 0.0, -q, q)
    w, u = q[..., :1], q[..., 1:]
    sin_half = np.sqrt(dot(u, u))
    theta = 2.0 * np.arctan2(sin_half, w)
    small = sin_half < SMALL_ANGLE
    scale = np.where(small, 2.0 / np.where(small, w, 1.0), theta / np.where(small, 1.0, sin_half))
    return scale * u


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(q) v = q v q*, a vector rotated by a unit quaternion.

    Parameters
    ----------
    q : (..., 4) array
        Unit quaternion(s).
    v : (..., 3) array
        Vector(s); leading axes broadcast with q's.

    Returns
    -------
    (..., 3) array
    """
    q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * cross(u, v)
    return v + w * t + cross(u, t)


@jitable
def to_matrix(q: np.ndarray) -> np.ndarray:
    """R(q), the rotation matrix of a unit quaternion: R(q) v = `rotate`(q, v).

    .. math:: R = \\begin{pmatrix} 1 - 2(y^2 + z^2) & 2(xy - wz) & 2(xz + wy) \\\\
              2(xy + wz) & 1 - 2(x^2 + z^2) & 2(yz - wx) \\\\
              2(xz - wy) & 2(yz + wx) & 1 - 2(x^2 + y^2) \\end{pmatrix}

    A matrix-vector product is several times cheaper than `rotate` for one vector, so a
    controller that turns several vectors by one orientation forms R once.

    Parameters
    ----------
    q : (..., 4) array
        Unit quaternion(s) (w, x, y, z); either sign.

    Returns
    -------
    (..., 3, 3) array
    """
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rows = [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ]
    if q.ndim == 1:  # one quaternion: no axes to move
        return np.array(rows)
    return np.moveaxis(np.array(rows), (0, 1), (-2, -1))


@jitable
def left_jacobian(v: np.ndarray) -> np.ndarray:
    """The left Jacobian of SO(3): the world-frame angular velocity of Exp(v) is J_l(v) v'.

    .. math:: J_l(v) = I + \\frac{1 - \\cos\\theta}{\\theta^2} [v]_\\times
              + \\frac{\\theta - \\sin\\theta}{\\theta^3} [v]_\\times^2, \\quad \\theta = |v|

    It is invertible except at theta = 2 pi k, k >= 1 (a whole turn: there a change of the
    vector along itself does not move the rotation).

    Parameters
    ----------
    v : (..., 3) array
        Rotation vector [rad].

    Returns
    -------
    (..., 3, 3) array
    """
    v = np.asarray(v, dtype=np.float64)
    theta = np.sqrt(dot(v, v))[..., None]
    small = theta < 1e-4
    safe = np.where(small, 1.0, theta)
    # Taylor series below 1e-4 rad: (1 - cos)/theta^2 -> 1/2 - theta^2/24, (theta - sin)/theta^3
    # -> 1/6 - theta^2/120.
    first = np.where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    second = np.where(small, 1.0 / 6.0 - theta**2 / 120.0, (safe - np.sin(safe)) / safe**3)
    x = skew(v)
    return np.eye(3) + first * x + second * (x @ x)


def left_jacobian_rate(v: np.ndarray, vdot: np.ndarray) -> np.ndarray:
    """(d/dt J_l(v)) v', the part of the world angular acceleration of Exp(v) that comes
    from J_l changing: omega' = J_l(v) v'' + left_jacobian_rate(v, v').

    With J_l = I + a(theta) [v]x + b(theta) [v]x^2 (`left_jacobian`) and theta' = v . v' /
    theta, and since v' x v' = 0:

    .. math:: \\dot J_l \\dot v = \\frac{a'}{\\theta} (v \\cdot \\dot v)\\, v \\times \\dot v
              + \\frac{b'}{\\theta} (v \\cdot \\dot v)\\, v \\times (v \\times \\dot v)
              + b\\, \\dot v \\times (v \\times \\dot v)

    a'/theta and b'/theta by their Taylor series below 0.05 rad (to theta^4).

    Parameters
    ----------
    v : (..., 3) array
        Rotation vector [rad].
    vdot : (..., 3) array
        Its rate [rad/s].

    Returns
    -------
    (..., 3) array [rad/s^2]
    """
    v, vdot = np.asarray(v, dtype=float), np.asarray(vdot, dtype=float)
    theta = np.linalg.norm(v, axis=-1, keepdims=True)
    small = theta < 0.05
    t = np.where(small, 1.0, theta)
    t2 = theta**2
    a_rate = np.where(
        small,
        -1.0 / 12.0 + t2 / 180.0 - t2**2 / 6720.0,
        (t * np.sin(t) - 2.0 * (1.0 - np.cos(t))) / t**4,
    )
    b_rate = np.where(
        small,
        -1.0 / 60.0 + t2 / 1260.0 - t2**2 / 60480.0,
        (1.0 - np.cos(t)) / t**4 - 3.0 * (t - np.sin(t)) / t**5,
    )
    b = np.where(small, 1.0 / 6.0 - t2 / 120.0 + t2**2 / 5040.0, (t - np.sin(t)) / t**3)
    along = np.sum(v * vdot, axis=-1, keepdims=True)
    normal = cross(v, vdot)
    return a_rate * along * normal + b_rate * along * cross(v, normal) + b * cross(vdot, normal)


@jitable
def skew(v: np.ndarray) -> np.ndarray:
    """[v]x, the matrix of the cross product v x (.).

    Parameters
    ----------
    v : (..., 3) array

    Returns
    -------
    (..., 3, 3) array
    """
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    if v.ndim == 1:
        return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    zero = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([zero, -z, y], axis=-1),
            np.stack([z, zero, -x], axis=-1),
            np.stack([-y, x, zero], axis=-1),
        ],
        axis=-2,
    )


def hemisphere_continuous(q: np.ndarray) -> np.ndarray:
    """The same rotations with each quaternion's sign chosen so that neighbours lie in one
    hemisphere (q_k . q_{k-1} >= 0); the first keeps its sign.

    Parameters
    ----------
    q : (T, 4) array
        A sequence of unit quaternions.

    Returns
    -------
    (T, 4) array
    """
    q = np.asarray(q, dtype=float)
    flips = np.sum(q[1:] * q[:-1], axis=-1) < 0.0
    sign = np.concatenate([[1.0], np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)])
    return q * sign[:, None]


def nearest_rotation_vector(v: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Of the rotation vectors of one rotation, v (theta + 2 pi k) / theta for whole k, the
    one nearest to `reference`: the representative that continues a motion through and
    beyond a rotation of pi without turning back.

    The nearest along the line through v is k = round((e . r - theta) / 2 pi), e = v /
    theta. For theta below SMALL_ANGLE the axis is undefined and `reference`'s is used
    (the whole turns 2 pi k r / |r|). Exactly halfway between two representatives the
    rounding (half to even) decides.

    Parameters
    ----------
    v : (3,) array
        A rotation vector [rad] (any representative).
    reference : (3,) array
        The vector to be near [rad].

    Returns
    -------
    (3,) array
        The same rotation [rad].
    """
    theta = float(np.linalg.norm(v))
    if theta < SMALL_ANGLE:
        length = float(np.linalg.norm(reference))
        if length < SMALL_ANGLE:
            return np.asarray(v, dtype=float)
        axis, theta = reference / length, 0.0
    else:
        axis = v / theta
    turns = round((float(axis @ reference) - theta) / (2.0 * np.pi))
    return axis * (theta + 2.0 * np.pi * turns)


def unwrap_rotation_vectors(vectors: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """A continuous sequence of rotation vectors: each the representative nearest to the
    one before it (`nearest_rotation_vector`), the first the one nearest to `reference`.

    Parameters
    ----------
    vectors : (T, 3) array
        Rotation vectors [rad] (any representatives, e.g. principal ones).
    reference : (3,) array
        What the first should be near [rad].

    Returns
    -------
    (T, 3) array
    """
    out = np.empty((len(vectors), 3))
    previous = np.asarray(reference, dtype=float)
    for k, v in enumerate(np.asarray(vectors, dtype=float)):
        previous = out[k] = nearest_rotation_vector(v, previous)
    return out


def geodesic_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The angle [rad] of the rotation from b to a, in [0, pi]: |2 Log(a b*)|.

    Parameters
    ----------
    a, b : (..., 4) arrays
        Unit quaternions; the sign of either does not matter.

    Returns
    -------
    (...) array
    """
    r = multiply(a, conjugate(b))
    return 2.0 * np.arctan2(np.linalg.norm(r[..., 1:], axis=-1), np.abs(r[..., 0]))
