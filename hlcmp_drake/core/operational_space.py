"""The operational-space algebra of a torque-controlled robot (Khatib): the task-space
terms of Eq. 2 from the joint-space ones Drake gives, the torque below the task, and the
map of a task-space force to saturated joint torques. Pure numpy, `jitable`
(`core.kernels`); `systems.task_space` and `systems.arm` read the plant and call these.

Sizes: M task-space axes, nv joint velocities; J is (M, nv).
"""

import numpy as np

from hlcmp_drake.core.kernels import jitable
from hlcmp_drake.core.quaternion import cross
from hlcmp_drake.core.small_linalg import inverse, matmul, solve
from hlcmp_drake.core.task_inertia import conditioned_task_inertia


@jitable
def operational_space_terms(
    mass: np.ndarray, jacobian: np.ndarray, joint_gravity: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Λ = (J M^-1 J^T)^-1, the dynamically consistent inverse J̄ = M^-1 J^T Λ, the task-space
    gravity G_x = J̄^T G(q), and the null-space projector N^T = I - J^T J̄^T.

    Parameters
    ----------
    mass : (nv, nv) array
        The joint-space mass matrix M(q).
    jacobian : (M, nv) array
        J, the task point's translational Jacobian rows.
    joint_gravity : (nv,) array
        G(q), the joint torque that holds the robot against gravity.

    Returns
    -------
    inertia : (M, M) array
        Λ [kg].
    jbar : (nv, M) array
        J̄.
    gravity : (M,) array
        G_x [N].
    null_space : (nv, nv) array
        N^T [-].
    """
    minv_jt = solve(mass, jacobian.T)
    inertia = inverse(matmul(jacobian, minv_jt))
    jbar, gravity, null_space = dynamically_consistent_terms(
        minv_jt, inertia, jacobian, joint_gravity
    )
    return inertia, jbar, gravity, null_space


@jitable
def dynamically_consistent_terms(
    minv_jt: np.ndarray, inertia: np.ndarray, jacobian: np.ndarray, joint_gravity: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """J̄ = M^-1 J^T Λ, G_x = J̄^T G(q) and N^T = I - J^T J̄^T, from M^-1 J^T and the task's
    Λ (the exact inverse, or `core.task_inertia.conditioned_task_inertia`'s).

    Parameters
    ----------
    minv_jt : (nv, M) array
        M^-1 J^T.
    inertia : (M, M) array
        Λ [kg, or kg m^2 by block for a 6-D task].
    jacobian : (M, nv) array
        J.
    joint_gravity : (nv,) array
        G(q).

    Returns
    -------
    jbar : (nv, M) array
        J̄.
    gravity : (M,) array
        G_x.
    null_space : (nv, nv) array
        N^T [-].
    """
    jbar = matmul(minv_jt, inertia)
    null_space = np.eye(jacobian.shape[1]) - matmul(jacobian.T, jbar.T)
    return jbar, matmul(jbar.T, joint_gravity), null_space


@jitable
def spatial_operational_space_terms(
    mass: np.ndarray, jacobian: np.ndarray, joint_gravity: np.ndarray, floor: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """`operational_space_terms` of a 6-D task ([rotation; translation] rows), its Λ kept
    bounded near a singularity (`core.task_inertia.conditioned_task_inertia`, two blocks).

    Parameters
    ----------
    mass : (nv, nv) array
        M(q).
    jacobian : (6, nv) array
        J, the spatial Jacobian, angular rows first.
    joint_gravity : (nv,) array
        G(q) [N m].
    floor : float
        The eigenvalue floor of the conditioning [-].

    Returns
    -------
    inertia, jbar, gravity, null_space
        As `operational_space_terms` (Λ and p = J̄^T G(q) by block [N m; N]).
    floored : int
        The eigenvalues raised to the floor.
    """
    minv_jt = solve(mass, jacobian.T)
    inertia, floored = conditioned_task_inertia(jacobian @ minv_jt, 2, floor)
    jbar, gravity, null_space = dynamically_consistent_terms(
        minv_jt, inertia, jacobian, joint_gravity
    )
    return inertia, jbar, gravity, null_space, floored


@jitable
def polarized_coriolis(
    jbar: np.ndarray,
    inertia: np.ndarray,
    bias_plus: np.ndarray,
    bias_minus: np.ndarray,
    accel_plus: np.ndarray,
    accel_minus: np.ndarray,
) -> np.ndarray:
    """C_x w = J̄^T C(q, v) u - Λ J' u with u = J̄ w, from the plant's quadratic maps
    b(v) = C(q, v) v and a(v) = J'(q, v) v at v + u and v - u: each symmetric bilinear form is
    (f(v + u) - f(v - u)) / 4 (polarization; see `systems.task_space.TaskSpaceModel`).

    Parameters
    ----------
    jbar : (nv, M) array
        J̄.
    inertia : (M, M) array
        Λ [kg].
    bias_plus, bias_minus : (nv,) arrays
        b(v + u) and b(v - u) [N m].
    accel_plus, accel_minus : (M,) arrays
        a(v + u) and a(v - u) along the task axes [m/s^2].

    Returns
    -------
    (M,) array
        C_x w [N].
    """
    return (
        matmul(jbar.T, bias_plus - bias_minus) - matmul(inertia, accel_plus - accel_minus)
    ) / 4.0


@jitable
def spatial_polarized_coriolis(
    jbar: np.ndarray,
    inertia: np.ndarray,
    jacobian: np.ndarray,
    velocities: np.ndarray,
    joint_velocity: np.ndarray,
    bias_plus: np.ndarray,
    bias_minus: np.ndarray,
    accel_plus: np.ndarray,
    accel_minus: np.ndarray,
) -> np.ndarray:
    """C_x w of a 6-D task (angular rows first), u = J̄ w: `polarized_coriolis` less
    Λ [(J_w v) x (J_w u) / 2; 0], since the polarization gives only the symmetric part of the
    angular rows' J'(v) u (`systems.spatial_task_space.SpatialCoriolisProduct`).

    Parameters
    ----------
    jbar : (nv, 6) array
        J̄.
    inertia : (6, 6) array
        Λ.
    jacobian : (6, nv) array
        J, angular rows first.
    velocities : (nv,) array
        v, the plant's velocities.
    joint_velocity : (nv,) array
        u = J̄ w.
    bias_plus, bias_minus : (nv,) arrays
        b(v + u) and b(v - u) [N m].
    accel_plus, accel_minus : (6,) arrays
        a(v + u) and a(v - u), the spatial bias accelerations [rad/s^2; m/s^2].

    Returns
    -------
    (6,) array
        C_x w [N m; N].
    """
    angular_jacobian = np.ascontiguousarray(jacobian[:3])
    antisymmetric = 0.5 * cross(angular_jacobian @ velocities, angular_jacobian @ joint_velocity)
    return (
        polarized_coriolis(jbar, inertia, bias_plus, bias_minus, accel_plus, accel_minus)
        - np.ascontiguousarray(inertia[:, :3]) @ antisymmetric
    )


def prismatic_task_dynamics(
    inverse: np.ndarray, mass: np.ndarray, joint_gravity: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The task-space dynamics of a robot of prismatic joints whose task axes are its joints,
    J constant and square: Λ = J^-T M J^-1, G_x = J^-T G (C_x = 0).

    Parameters
    ----------
    inverse : (M, M) array
        J^-1.
    mass : (M, M) array
        The joint-space mass matrix [kg].
    joint_gravity : (M,) array
        G, the joint force that holds the robot against gravity [N].

    Returns
    -------
    inertia : (M, M) array
        Λ [kg].
    gravity : (M,) array
        G_x [N].
    """
    return inverse.T @ mass @ inverse, inverse.T @ joint_gravity


@jitable
def rotation_vector(rotation: np.ndarray) -> np.ndarray:
    """The principal rotation vector e of a rotation matrix R = exp([e]x): its axis times its
    angle, |e| <= pi. By way of R's unit quaternion (w, x, y, z), w >= 0, each component
    found from the largest of R's trace and diagonal terms (Shepperd's choice: no division
    by a small number), then e = 2 atan2(|(x, y, z)|, w) (x, y, z) / |(x, y, z)|, accurate
    at every angle (the Log of `core.quaternion.to_rotation_vector`, from a matrix). At an
    angle of exactly pi, either of the two opposite vectors is the rotation.

    Parameters
    ----------
    rotation : (3, 3) array
        A rotation matrix.

    Returns
    -------
    (3,) array
        e [rad].
    """
    r = rotation
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace >= r[0, 0] and trace >= r[1, 1] and trace >= r[2, 2]:
        four_w = 2.0 * np.sqrt(1.0 + trace)
        w, x = 0.25 * four_w, (r[2, 1] - r[1, 2]) / four_w
        y, z = (r[0, 2] - r[2, 0]) / four_w, (r[1, 0] - r[0, 1]) / four_w
    elif r[0, 0] >= r[1, 1] and r[0, 0] >= r[2, 2]:
        four_x = 2.0 * np.sqrt(1.0 + 2.0 * r[0, 0] - trace)
        w, x = (r[2, 1] - r[1, 2]) / four_x, 0.25 * four_x
        y, z = (r[0, 1] + r[1, 0]) / four_x, (r[0, 2] + r[2, 0]) / four_x
    elif r[1, 1] >= r[2, 2]:
        four_y = 2.0 * np.sqrt(1.0 + 2.0 * r[1, 1] - trace)
        w, x = (r[0, 2] - r[2, 0]) / four_y, (r[0, 1] + r[1, 0]) / four_y
        y, z = 0.25 * four_y, (r[1, 2] + r[2, 1]) / four_y
    else:
        four_z = 2.0 * np.sqrt(1.0 + 2.0 * r[2, 2] - trace)
        w, x = (r[1, 0] - r[0, 1]) / four_z, (r[0, 2] + r[2, 0]) / four_z
        y, z = (r[1, 2] + r[2, 1]) / four_z, 0.25 * four_z
    if w < 0.0:  # q and -q are one rotation: the principal vector has w >= 0
        w, x, y, z = -w, -x, -y, -z
    sin_half = np.sqrt(x * x + y * y + z * z)
    if sin_half == 0.0:
        return np.zeros(3)
    scale = 2.0 * np.arctan2(sin_half, w) / sin_half
    return np.array([scale * x, scale * y, scale * z])


@jitable
def below_task_torque(
    projector: np.ndarray,
    joint_gravity: np.ndarray,
    angular_jacobian: np.ndarray,
    rotation: np.ndarray,
    desired_inverse: np.ndarray,
    positions: np.ndarray,
    velocities: np.ndarray,
    nominal_positions: np.ndarray,
    orientation_stiffness: float,
    orientation_damping: float,
    posture_stiffness: float,
    posture_damping: float,
) -> np.ndarray:
    """τ_0 = N^T (G(q) + J_w^T (-K_o e_R - D_o w) - K_p (q - q_0) - D_p q'), w = J_w q',
    e_R = Log(R R_d^T) (`rotation_vector`): the tool's orientation and the arm's posture held
    below the translational task.

    Parameters
    ----------
    projector : (nv, nv) array
        N^T of the translational task.
    joint_gravity : (nv,) array
        G(q) [N m].
    angular_jacobian : (3, nv) array
        J_w, the tool's angular-velocity Jacobian, world.
    rotation : (3, 3) array
        R, the tool's orientation, world.
    desired_inverse : (3, 3) array
        R_d^T, the inverse of the orientation to hold.
    positions, velocities : (nv,) arrays
        q [rad] and q' [rad/s].
    nominal_positions : (nv,) array
        q_0 [rad].
    orientation_stiffness, orientation_damping : float
        K_o [N m/rad] and D_o [N m s/rad].
    posture_stiffness, posture_damping : float
        K_p [N m/rad] and D_p [N m s/rad].

    Returns
    -------
    (nv,) array
        τ_0 [N m].
    """
    moment = -orientation_stiffness * rotation_vector(
        matmul(rotation, desired_inverse)
    ) - orientation_damping * matmul(angular_jacobian, velocities)
    return matmul(
        projector,
        joint_gravity
        + matmul(angular_jacobian.T, moment)
        - posture_stiffness * (positions - nominal_positions)
        - posture_damping * velocities,
    )


@jitable
def saturate(torque: np.ndarray, limits: np.ndarray) -> tuple[np.ndarray, int]:
    """Clip a joint torque element-wise at the actuators' effort limits.

    Parameters
    ----------
    torque : (nv,) array
        The unsaturated torque [N m].
    limits : (nv,) array
        The effort limits [N m], > 0.

    Returns
    -------
    clipped : (nv,) array
        The applied torque [N m].
    saturated : int
        The number of joints at their limit.
    """
    return np.minimum(np.maximum(torque, -limits), limits), int(
        np.count_nonzero(np.abs(torque) >= limits)
    )


@jitable
def task_joint_torque(
    jacobian: np.ndarray, force: np.ndarray, below_task: np.ndarray, limits: np.ndarray
) -> tuple[np.ndarray, int]:
    """τ = sat(J^T f_c + τ_0): the task force in the joints, with what is held below the task,
    clipped at the effort limits (`saturate`).

    Parameters
    ----------
    jacobian : (M, nv) array
        J.
    force : (M,) array
        f_c [N].
    below_task : (nv,) array
        τ_0 [N m] (zeros where nothing is held below the task).
    limits : (nv,) array
        The effort limits [N m].

    Returns
    -------
    torque : (nv,) array
        The applied torque [N m].
    saturated : int
        The number of joints at their limit.
    """
    return saturate(matmul(jacobian.T, force) + below_task, limits)
