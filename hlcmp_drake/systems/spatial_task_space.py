"""The 6-D task-space view of a MultibodyPlant, for control of the tool's pose: the tool
frame's pose and spatial velocity, its spatial Jacobian, the 6-D task-space inertia,
Coriolis and gravity terms of Eq. 2 and the null space left to a redundant arm, all from a
control-side plant. The algebra on what Drake returns is `core.operational_space`'s, compiled
or numpy as `core.kernels.kernel_path` says when the model is made.

Spatial vectors are in Drake's order, angular first: V = [omega; v] (SpatialVelocity), F =
[tau; f] (SpatialForce), world frame (measured and expressed), for the point P fixed on the
tool frame. J is `CalcJacobianSpatialVelocity` with respect to v, so its rows 0-2 are the
angular velocity Jacobian and rows 3-5 P's translational Jacobian (the 3-D
`systems.task_space.TaskSpaceModel`'s J).
"""

from dataclasses import dataclass

import numpy as np
from pydrake.multibody.tree import Frame, JacobianWrtVariable
from pydrake.systems.framework import Context

from hlcmp_drake.core.kernels import implementation, kernel_path
from hlcmp_drake.core.operational_space import (
    spatial_operational_space_terms,
    spatial_polarized_coriolis,
)
from hlcmp_drake.core.task_inertia import EIGENVALUE_FLOOR


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
    rotation : (3, 3) array
        R, the tool frame's orientation, world.
    angular_jacobian : (3, nv) array
        J_w, J's angular rows (contiguous), what `systems.arm.BelowTaskImpedance.torque_at`
        reads.
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
    rotation: np.ndarray
    angular_jacobian: np.ndarray


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
        path = kernel_path()
        self._operational_space_terms = implementation(spatial_operational_space_terms, path)
        self._polarized_coriolis = implementation(spatial_polarized_coriolis, path)

    @property
    def context(self) -> Context:
        """The control-side plant context, holding the positions of the last `terms` call
        (its velocities are changed by a `SpatialCoriolisProduct`)."""
        return self._context

    @property
    def frame(self) -> Frame:
        """The tool frame."""
        return self._frame

    def coriolis_product(
        self,
        v: np.ndarray,
        jacobian: np.ndarray,
        jbar: np.ndarray,
        inertia: np.ndarray,
        w: np.ndarray,
    ) -> np.ndarray:
        """C_x w at velocity v, from the quadratic maps v -> C(q, v) v (CalcBiasTerm) and
        v -> Jdot v (CalcBiasSpatialAcceleration) at v + u and v - u, u = Jbar w, at the
        positions of the last `terms` call (`core.operational_space.
        spatial_polarized_coriolis`): the polarization (f(v + u) - f(v - u)) / 4 gives
        C(q, v) u (Christoffel symbols are symmetric) and Jdot(v) u for the translational
        rows (a Hessian), but only the symmetric part of the angular rows' (see
        `SpatialCoriolisProduct`).

        Parameters
        ----------
        v : (nv,) array
            The plant's velocities.
        jacobian, jbar, inertia
            J, Jbar and Lambda at this state.
        w : (6,) array
            A spatial velocity [rad/s; m/s].

        Returns
        -------
        (6,) array
            C_x w [N m; N].
        """
        plant, ctx, world = self.plant, self._context, self._world
        u = jbar @ w
        values = []
        for sign in (1.0, -1.0):
            plant.SetVelocities(ctx, v + sign * u)
            values.append(plant.CalcBiasTerm(ctx))
            values.append(
                plant.CalcBiasSpatialAcceleration(
                    ctx, JacobianWrtVariable.kV, self._frame, self._point, world, world
                ).get_coeffs()
            )
        bias_plus, accel_plus, bias_minus, accel_minus = values
        return self._polarized_coriolis(
            jbar, inertia, jacobian, v, u, bias_plus, bias_minus, accel_plus, accel_minus
        )

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
        joint_gravity = -plant.CalcGravityGeneralizedForces(ctx)
        inertia, jbar, gravity, null_space, floored = self._operational_space_terms(
            plant.CalcMassMatrix(ctx), jac, joint_gravity, self._floor
        )
        coriolis = SpatialCoriolisProduct(self, v, jac, jbar, inertia)
        return SpatialTerms(
            position=pose @ self._point[:, 0],
            orientation=quaternion,
            spatial_velocity=jac @ v,
            jacobian=jac,
            inertia=inertia,
            coriolis=coriolis @ np.eye(6) if coriolis_matrix else coriolis,
            gravity=gravity,
            null_space=null_space,
            joint_gravity=joint_gravity,
            floored=floored,
            rotation=pose.rotation().matrix(),
            angular_jacobian=np.ascontiguousarray(jac[:3]),
        )


class SpatialCoriolisProduct:
    """C_x = Jbar^T C(q, v) Jbar - Lambda Jdot Jbar at one state, as an operator: `C_x @ w`
    for a spatial vector w (6,) or the columns of a (6, K) matrix, each from two plant
    evaluations at v + Jbar w and v - Jbar w (`SpatialTaskSpaceModel.coriolis_product`).

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

    def __matmul__(self, w: np.ndarray) -> np.ndarray:
        product = self._model.coriolis_product
        if np.ndim(w) == 1:
            return product(self._v, self._jac, self._jbar, self._inertia, w)
        return np.column_stack(
            [product(self._v, self._jac, self._jbar, self._inertia, column) for column in w.T]
        )
