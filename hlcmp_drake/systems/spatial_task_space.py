"""The 6-D task-space view of a MultibodyPlant, for control of the tool's pose: the tool
frame's pose and spatial velocity, its spatial Jacobian, the 6-D task-space inertia,
Coriolis and gravity terms of Eq. 2 and the null space left to a redundant arm, all from a
control-side plant; and the map from a commanded wrench to saturated joint torques.

Spatial vectors are in Drake's order, angular first: V = [omega; v] (SpatialVelocity), F =
[tau; f] (SpatialForce), world frame (measured and expressed), for the point P fixed on the
tool frame. J is `CalcJacobianSpatialVelocity` with respect to v, so its rows 0-2 are the
angular velocity Jacobian and rows 3-5 P's translational Jacobian (the 3-D
`systems.task_space.TaskSpaceModel`'s J).
"""

from dataclasses import dataclass

import numpy as np
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import Context

from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.core.task_inertia import EIGENVALUE_FLOOR, conditioned_task_inertia
from hlcmp_drake.systems.task_space import saturate


@dataclass
class SpatialTerms:
    """Everything of the 6-D task that depends only on the plant's state.

    Attributes
    ----------
    position : (3,) array
        P, world [m].
    orientation : (4,) array
        The tool frame's orientation in the world, unit quaternion (w, x, y, z), w >= 0.
    spatial_velocity : (6,) array
        V = J v = [omega; P'], world [rad/s; m/s].
    jacobian : (6, nv) array
        J, angular rows first.
    inertia : (6, 6) array
        Lambda = (J M^-1 J^T)^-1 (`core.task_inertia.conditioned_task_inertia`).
    coriolis : (6, 6) array or SpatialCoriolisProduct
        C_x = Jbar^T C(q, v) Jbar - Lambda Jdot Jbar.
    gravity : (6,) array
        p = Jbar^T G(q) [N m; N].
    null_space : (nv, nv) array
        N^T = I - J^T Jbar^T, dynamically consistent (nv - 6 = 1 direction on the iiwa).
    joint_gravity : (nv,) array
        G(q), the joint torque that holds the arm [N m].
    floored : int
        The eigenvalues of the scaled J M^-1 J^T raised to the floor (0 away from
        singularities).
    """

    position: np.ndarray
    orientation: np.ndarray
    spatial_velocity: np.ndarray
    jacobian: np.ndarray
    inertia: np.ndarray
    coriolis: object
    gravity: np.ndarray
    null_space: np.ndarray
    joint_gravity: np.ndarray
    floored: int


class SpatialTaskSpaceModel:
    """The 6-D task-space terms of the point P fixed on `frame`, with the frame's
    orientation, computed by Drake from a control-side plant context (Khatib's operational
    space, Eq. 2 in 6-D): Lambda V' + mu + p = F + F_ext, with

    - Lambda = (J M^-1 J^T)^-1, conditioned near singularities by an eigenvalue floor on
      the Jacobi-scaled J M^-1 J^T (`core.task_inertia.conditioned_task_inertia`: floor
      1e-3, the exact inverse when nothing is floored);
    - Jbar = M^-1 J^T Lambda, the dynamically consistent inverse;
    - C_x = Jbar^T C(q, v) Jbar - Lambda Jdot Jbar, Jdot = d/dt J along v, so that mu =
      C_x V when v = Jbar V; C(q, v) u and Jdot u from Drake's bias terms by polarization,
      as the 3-D model does, plus the angular rows' antisymmetric part, which the
      polarization cannot see (`SpatialCoriolisProduct`);
    - p = Jbar^T G(q);
    - N^T = I - J^T Jbar^T: a joint torque N^T tau_0 gives no task acceleration (J M^-1
      N^T = 0), the redundancy's (the iiwa's 7th joint's) room for a posture term.

    The translational rows reduce to the 3-D model's where the two tasks share a meaning:
    J's rows 3-5 are its J, the translational block of Lambda^-1 is its Lambda^-1 (the
    6-D Lambda's own block is not its Lambda: rotation couples), and Lambda^-1 p's rows 3-5
    (the acceleration gravity gives P) are its Lambda^-1 G_x (tested).

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized; its own context is made here.
    frame : Frame
        The tool frame, whose orientation is the task's and on which P is fixed.
    point_in_frame : (3,) array
        P in `frame` [m].
    floor : float
        The eigenvalue floor of the conditioning [-].
    """

    n_axes = 6

    def __init__(self, plant, frame, point_in_frame=(0.0, 0.0, 0.0), floor=EIGENVALUE_FLOOR):
        self.plant, self._frame = plant, frame
        self._point = np.asarray(point_in_frame, dtype=float).reshape(3, 1)
        self._floor = float(floor)
        self._context = plant.CreateDefaultContext()
        self.nq, self.nv = plant.num_positions(), plant.num_velocities()
        self._world = plant.world_frame()
        self._identity = np.eye(self.nv)

    @property
    def context(self) -> Context:
        """The control-side plant context, holding the positions of the last `terms` call
        (its velocities are changed by a `SpatialCoriolisProduct`)."""
        return self._context

    def bias_pair(self, v: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The symmetric bilinear forms of the quadratic maps v -> C(q, v) v (CalcBiasTerm)
        and v -> Jdot v (CalcBiasSpatialAcceleration), by polarization: (f(v + u) -
        f(v - u)) / 4, at the positions of the last `terms` call. The first is C(q, v) u
        (Christoffel symbols are symmetric); the second is Jdot(v) u for the translational
        rows (a Hessian) but only the symmetric part of the angular rows' (see
        `SpatialCoriolisProduct`).

        Parameters
        ----------
        v, u : (nv,) arrays
            The plant's velocities and the joint velocity to apply the forms to.

        Returns
        -------
        (nv,) array, (6,) array
            C(q, v) u [N m], sym(Jdot)(v, u) [rad/s^2; m/s^2] (angular first).
        """
        plant, ctx, world = self.plant, self._context, self._world
        values = []
        for sign in (1.0, -1.0):
            plant.SetVelocities(ctx, v + sign * u)
            values.append(
                (
                    plant.CalcBiasTerm(ctx),
                    plant.CalcBiasSpatialAcceleration(
                        ctx, JacobianWrtVariable.kV, self._frame, self._point, world, world
                    ).get_coeffs(),
                )
            )
        (bias_plus, accel_plus), (bias_minus, accel_minus) = values
        return (bias_plus - bias_minus) / 4.0, (accel_plus - accel_minus) / 4.0

    def terms(self, state: np.ndarray, coriolis_matrix: bool = True) -> SpatialTerms:
        """All 6-D task-space terms at the plant state `state`.

        Parameters
        ----------
        state : (nq + nv,) array
            The plant's positions [rad] and velocities [rad/s].
        coriolis_matrix : bool
            True: C_x as a (6, 6) matrix (12 plant evaluations). False: as a
            `SpatialCoriolisProduct`, which forms C_x w for the one w a law needs with 4.

        Returns
        -------
        SpatialTerms
        """
        plant, ctx, world = self.plant, self._context, self._world
        plant.SetPositionsAndVelocities(ctx, state)
        v = state[self.nq :]
        pose = self._frame.CalcPoseInWorld(ctx)
        quaternion = pose.rotation().ToQuaternion().wxyz()
        if quaternion[0] < 0.0:
            quaternion = -quaternion
        jac = plant.CalcJacobianSpatialVelocity(
            ctx, JacobianWrtVariable.kV, self._frame, self._point, world, world
        )
        minv_jt = np.linalg.solve(plant.CalcMassMatrix(ctx), jac.T)
        inertia, floored = conditioned_task_inertia(jac @ minv_jt, floor=self._floor)
        jbar = minv_jt @ inertia
        joint_gravity = -plant.CalcGravityGeneralizedForces(ctx)
        coriolis = SpatialCoriolisProduct(self, v, jac, jbar, inertia)
        return SpatialTerms(
            position=pose @ self._point[:, 0],
            orientation=quaternion,
            spatial_velocity=jac @ v,
            jacobian=jac,
            inertia=inertia,
            coriolis=coriolis @ np.eye(6) if coriolis_matrix else coriolis,
            gravity=jbar.T @ joint_gravity,
            null_space=self._identity - jac.T @ jbar.T,
            joint_gravity=joint_gravity,
            floored=floored,
        )


class SpatialCoriolisProduct:
    """C_x = Jbar^T C(q, v) Jbar - Lambda Jdot Jbar at one state, as an operator: `C_x @ w`
    for a spatial vector w (6,) or the columns of a (6, K) matrix, each from two plant
    evaluations at v + Jbar w and v - Jbar w (`SpatialTaskSpaceModel.bias_pair`).

    With u = Jbar w, the angular rows of Jdot(v) u are the polarization's symmetric form
    plus (J_w v) x (J_w u) / 2: the angular velocity Jacobian's columns are joint axes
    z_k(q) with dz_k/dq_j = z_j x z_k for the joints j before k, so Jdot_w(v) u -
    Jdot_w(u) v = (J_w v) x (J_w u). Tested against Christoffel symbols and finite
    differences of J on the iiwa (tests/test_systems_spatial_task_space.py).

    Parameters
    ----------
    model : SpatialTaskSpaceModel
        Its context holds the state's positions.
    v : (nv,) array
        The plant's velocities.
    jacobian : (6, nv) array
        J.
    jbar : (nv, 6) array
        Jbar.
    inertia : (6, 6) array
        Lambda.
    """

    def __init__(
        self,
        model: SpatialTaskSpaceModel,
        v: np.ndarray,
        jacobian: np.ndarray,
        jbar: np.ndarray,
        inertia: np.ndarray,
    ):
        self._model, self._v, self._jac = model, v, jacobian
        self._jbar, self._inertia = jbar, inertia
        self._omega = jacobian[:3] @ v

    def __matmul__(self, w: np.ndarray) -> np.ndarray:
        columns = np.asarray(w, dtype=float).reshape(6, -1)
        products = []
        for column in columns.T:
            u = self._jbar @ column
            joint_coriolis, jdot_u = self._model.bias_pair(self._v, u)
            # The angular rows of Jdot are not symmetric in (v, u) as the polarization's
            # form is: Jdot_w(v) u = sym(v, u) + (J_w v) x (J_w u) / 2.
            jdot_u[:3] += 0.5 * quat.cross(self._omega, self._jac[:3] @ u)
            products.append(self._jbar.T @ joint_coriolis - self._inertia @ jdot_u)
        product = np.column_stack(products)
        return product if np.ndim(w) == 2 else product[:, 0]


def wrench_to_joint_torque(
    terms: SpatialTerms,
    wrench: np.ndarray,
    below_task: np.ndarray,
    effort_limits: np.ndarray,
) -> tuple[np.ndarray, int]:
    """tau = sat(J^T F + tau_0): the commanded wrench through the spatial Jacobian plus the
    torque below the task, saturated at the effort limits (`systems.task_space.saturate`).

    tau_0 must lie in the task's null space and carry the null-space share N^T G(q) of the
    gravity compensation (the task's share J^T Jbar^T G is in F's p): e.g.
    `systems.arm.BelowTaskImpedance.torque` with N^T = `terms.null_space` and its
    orientation gains 0 (the orientation is the task's now), which holds the posture.

    Parameters
    ----------
    terms : SpatialTerms
        At the tick's state.
    wrench : (6,) array
        F = [tau_c; f_c] [N m; N], world.
    below_task : (nv,) array
        tau_0 [N m].
    effort_limits : (nv,) array
        [N m], > 0.

    Returns
    -------
    torque : (nv,) array
        The applied joint torque [N m].
    saturated : int
        The number of joints at their limit.
    """
    return saturate(terms.jacobian.T @ wrench + below_task, effort_limits)
