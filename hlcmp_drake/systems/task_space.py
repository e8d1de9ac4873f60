"""The task-space view of a MultibodyPlant: measured x, x' and the dynamics terms
M, C, G of paper Eq. 2 in the task space, all computed by Drake from a control-side
plant; and the map from a task-space force back to joint torques."""

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.tree import Frame, JacobianWrtVariable
from pydrake.systems.framework import BasicVector, Context, LeafSystem, ValueProducer

from hlcmp_drake.core.kernels import implementation, kernel_path
from hlcmp_drake.core.operational_space import (
    operational_space_terms,
    polarized_coriolis,
    prismatic_task_dynamics,
    saturate,
)


@dataclass
class TaskSpaceTerms:
    """Everything that depends only on the plant's state, evaluated once per state."""

    position: np.ndarray
    velocity: np.ndarray
    jacobian: np.ndarray  # J (M x nv), rows of the point's translational Jacobian
    inertia: np.ndarray  # Lambda = (J M^-1 J^T)^-1
    coriolis: np.ndarray  # C_x = Jbar^T C(q, v) Jbar - Lambda Jdot Jbar (or its CoriolisProduct)
    gravity: np.ndarray  # G_x = Jbar^T G(q)
    null_space: np.ndarray  # N^T = I - J^T Jbar^T (nv x nv), dynamically consistent
    joint_gravity: np.ndarray  # G(q) (nv,)
    # The frame's orientation R_WF and angular-velocity Jacobian J_w (3 x nv), world, which
    # the torque below the task reads (`systems.arm.BelowTaskImpedance.torque_at`); None
    # where the model has no rotation (`PrismaticTaskModel`).
    rotation: np.ndarray | None = None
    angular_jacobian: np.ndarray | None = None


def axis_rows(axes: Sequence[int], offset: int = 0) -> slice | np.ndarray:
    """The index that picks the task `axes` out of a 3-vector's rows (from row `offset`): a
    slice where they are consecutive and ascending, as the arm's x, y, z are (a view;
    numpy's indexing by a list costs about 4 µs at these sizes, several times per tick),
    else an index array.

    Parameters
    ----------
    axes : sequence of int
        Distinct world axes, 0 = x, 1 = y, 2 = z.
    offset : int
        The row of x (3 for the translational rows of a spatial Jacobian).

    Returns
    -------
    slice or (M,) int array
    """
    axes = list(axes)
    if axes == list(range(axes[0], axes[0] + len(axes))):
        return slice(offset + axes[0], offset + axes[0] + len(axes))
    return offset + np.array(axes)


class TaskSpaceModel:
    """The task-space terms of a point P fixed on `frame`, computed by Drake from a
    control-side plant context: position, velocity, Jacobian, and the task-space inertia,
    Coriolis matrix and gravity (the operational-space terms of Eq. 2, Khatib).

    Task space = the `axes` (0 = x, 1 = y, 2 = z of the world) of P's translation.
    Lambda, C_x and G_x use the dynamically consistent inverse Jbar = M^-1 J^T Lambda.
    C(q, v) and Jdot are not exposed by Drake as matrices, only as the products C(q, v) v
    (CalcBiasTerm) and Jdot v (CalcBiasTranslationalAcceleration); both products are
    quadratic forms whose symmetric bilinear form is the matrix-vector product we need
    (Christoffel symbols, resp. mixed second derivatives of P's position), so their
    products with a vector u are recovered exactly by polarization:
    C(q, v) u = [b(v + u) - b(v - u)] / 4 (see `CoriolisProduct`). The algebra on what Drake
    returns is `core.operational_space`'s, compiled or numpy as `core.kernels.kernel_path`
    says when the model is made.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized; its own contexts are made here.
    frame : Frame
        The frame P is fixed on.
    point_in_frame : (3,) array
        P in `frame` [m].
    axes : sequence of int
        The world axes of the task space.
    """

    def __init__(self, plant, frame, point_in_frame=(0.0, 0.0, 0.0), axes=(0, 1, 2)):
        self.plant, self._frame = plant, frame
        self._point = np.asarray(point_in_frame, dtype=float).reshape(3, 1)
        self._axes = list(axes)
        self._context = plant.CreateDefaultContext()
        self.nq, self.nv, self.n_axes = (
            plant.num_positions(),
            plant.num_velocities(),
            len(self._axes),
        )
        self._world = plant.world_frame()  # looked up once: every tick uses it several times
        self._rows = axis_rows(self._axes)
        self._translational_rows = axis_rows(self._axes, offset=3)
        path = kernel_path()
        self._operational_space_terms = implementation(operational_space_terms, path)
        self._polarized_coriolis = implementation(polarized_coriolis, path)

    @property
    def context(self) -> Context:
        """The control-side plant context, holding the positions of the last `terms` call
        (`terms` does not set its velocities; a `CoriolisProduct` changes them)."""
        return self._context

    @property
    def frame(self) -> Frame:
        """The frame P is fixed on."""
        return self._frame

    @property
    def first_translational_row(self) -> int | None:
        """The row of the first task axis in a spatial-velocity Jacobian (angular rows
        first), where the axes are consecutive and ascending; None otherwise."""
        rows = self._translational_rows
        return rows.start if isinstance(rows, slice) else None

    def plant_queries(
        self, state: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """What the tick reads from Drake at `state`'s positions, which it sets in the
        context (its velocities are left to `biases`): every query depends on the positions
        alone, so Drake computes their kinematics once.

        Parameters
        ----------
        state : (nq + nv,) array
            The plant's positions [rad, m] and velocities.

        Returns
        -------
        position : (M,) array
            x [m].
        spatial_jacobian : (6, nv) array
            P's spatial-velocity Jacobian, world: J_w's rows, then the translational ones.
        joint_gravity : (nv,) array
            G(q).
        mass : (nv, nv) array
            M(q).
        rotation : (3, 3) array
            The frame's orientation R_WF.
        """
        plant, ctx, world, frame = self.plant, self._context, self._world, self._frame
        plant.SetPositions(ctx, state[: self.nq])
        position = plant.CalcPointsPositions(ctx, frame, self._point, world)[self._rows, 0]
        spatial = plant.CalcJacobianSpatialVelocity(
            ctx, JacobianWrtVariable.kV, frame, self._point, world, world
        )
        joint_gravity = -plant.CalcGravityGeneralizedForces(ctx)
        mass = plant.CalcMassMatrix(ctx)
        return position, spatial, joint_gravity, mass, frame.CalcRotationMatrixInWorld(ctx).matrix()

    def biases(
        self, v: np.ndarray, u: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """b(v ± u) = C(q, v ± u)(v ± u) and a(v ± u) = J'(v ± u)(v ± u) (task rows), the
        two evaluations of the polarization (`polarized_coriolis`), at the positions of the
        last `terms` or `plant_queries` call, which stay (and so their kinematics); only
        the velocities change. Two velocities are the fewest: b(v + t u) = b(v) +
        2 t C(q, v) u + t^2 b(u) has the unknowns b(v) and b(u) besides the product, and
        the tick reads neither.

        Parameters
        ----------
        v, u : (nv,) arrays
            The plant's velocities and the offset J̄ w.

        Returns
        -------
        bias_plus, bias_minus : (nv,) arrays
        accel_plus, accel_minus : (M,) arrays
        """
        plant, ctx, world, frame, point = (
            self.plant,
            self._context,
            self._world,
            self._frame,
            self._point,
        )
        plant.SetVelocities(ctx, v + u)
        bias_plus = plant.CalcBiasTerm(ctx)
        accel_plus = plant.CalcBiasTranslationalAcceleration(
            ctx, JacobianWrtVariable.kV, frame, point, world, world
        )[self._rows, 0]
        plant.SetVelocities(ctx, v - u)
        bias_minus = plant.CalcBiasTerm(ctx)
        accel_minus = plant.CalcBiasTranslationalAcceleration(
            ctx, JacobianWrtVariable.kV, frame, point, world, world
        )[self._rows, 0]
        return bias_plus, bias_minus, accel_plus, accel_minus

    def _polarized_product(self, v, jbar, inertia, w):
        """C_x w at velocity v, from `biases` at u = Jbar w."""
        return self._polarized_coriolis(jbar, inertia, *self.biases(v, jbar @ w))

    def terms(self, state: np.ndarray, coriolis_matrix: bool = True) -> TaskSpaceTerms:
        """All task-space terms at the plant state `state`.

        Only the positions are set in the context: every query here depends on them alone,
        so Drake computes their kinematics once, and the Coriolis product sets the
        velocities it reads.

        Parameters
        ----------
        state : (nq + nv,) array
            The plant's positions [rad, m] and velocities.
        coriolis_matrix : bool
            True: C_x as an (M, M) matrix (2 M polarizations). False: as a `CoriolisProduct`,
            which gives C_x w for the one w a law needs (Eq. 34's C x_e') with 2.

        Returns
        -------
        TaskSpaceTerms
            Position [m] and velocity [m/s] (M,), Jacobian (M, nv), inertia [kg] and
            Coriolis [kg/s] (M, M), gravity [N] (M,), null-space projector (nv, nv) and
            joint gravity G(q) (nv,) in the joints' units; the frame's orientation (3, 3)
            and its angular-velocity Jacobian (3, nv), world.
        """
        position, spatial, joint_gravity, mass, rotation = self.plant_queries(state)
        v = state[self.nq :]
        # One Jacobian for both: its angular rows are J_w, its translational rows J (each
        # copied contiguous: the kernels' matrix products need it).
        jac = np.ascontiguousarray(spatial[self._translational_rows])
        inertia, jbar, gravity, null_space = self._operational_space_terms(mass, jac, joint_gravity)
        coriolis = CoriolisProduct(self, v, jbar, inertia)
        if coriolis_matrix:
            coriolis = coriolis @ np.eye(self.n_axes)
        return TaskSpaceTerms(
            position,
            jac @ v,
            jac,
            inertia,
            coriolis,
            gravity,
            null_space,
            joint_gravity,
            rotation,
            np.ascontiguousarray(spatial[:3]),
        )


class CoriolisProduct:
    """C_x = Jbar^T C(q, v) Jbar - Lambda Jdot Jbar at one state, as an operator:
    `C_x @ w` for a vector w (M,) or the columns of a matrix (M, K). Only C(q, v) u and
    Jdot u with u = Jbar w are needed: for each column, both from the plant evaluated at
    the two velocities v + u and v - u (see `TaskSpaceModel` for the polarization).

    Parameters
    ----------
    model : TaskSpaceModel
        Its context holds the state's positions.
    v : (nv,) array
        The plant's velocities.
    jbar : (nv, M) array
        The dynamically consistent inverse Jbar.
    inertia : (M, M) array
        Lambda.
    """

    def __init__(self, model: TaskSpaceModel, v: np.ndarray, jbar: np.ndarray, inertia: np.ndarray):
        self._model, self._v, self._jbar, self._inertia = model, v, jbar, inertia

    def __matmul__(self, w: np.ndarray) -> np.ndarray:
        product = self._model._polarized_product
        w = np.asarray(w, dtype=float)
        if w.ndim == 1:
            return product(self._v, self._jbar, self._inertia, w)
        return np.column_stack(
            [product(self._v, self._jbar, self._inertia, column) for column in w.T]
        )


class PrismaticTaskModel:
    """`TaskSpaceModel`'s terms for a plant made only of prismatic joints whose task axes
    are its joints, at a fraction of its cost (the slider world's one-call loop). With no
    rotation the mass matrix is constant, so C(q, v) = 0, and J is constant and square
    (Jdot = 0); so is gravity's generalized force: Lambda = J^-T M J^-1, G_x = J^-T G,
    C_x = 0, no null space. The position is affine in q: x = x(0) + J q. J, x(0), M and G
    are read from the plant once, and checked at a second configuration: M and G equal, x
    equal to rounding; C(q, v) v = 0 against Drake's bias term. A tick makes no plant query.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized, every joint prismatic, as many velocities as task axes.
    frame : Frame
        The frame whose origin's translation is the task position.
    axes : sequence of int
        The world axes of the task space, as many as the plant's velocities.

    Raises
    ------
    ValueError
        When the plant has another joint type, or not one velocity per task axis.
    """

    def __init__(self, plant, frame, axes=(0,)):
        self.plant, self._frame, self._axes = plant, frame, list(axes)
        self._context = plant.CreateDefaultContext()
        self._world = plant.world_frame()
        self.nq, self.nv, self.n_axes = (
            plant.num_positions(),
            plant.num_velocities(),
            len(self._axes),
        )
        kinds = {plant.get_joint(j).type_name() for j in plant.GetJointIndices()}
        if not kinds <= {"prismatic", "weld"} or self.nv != self.n_axes:
            raise ValueError(
                f"PrismaticTaskModel needs prismatic joints only, one per task axis; "
                f"the plant has {sorted(kinds)} joints, {self.nv} velocities, "
                f"{self.n_axes} axes"
            )
        self._origin = np.zeros((3, 1))  # the frame's origin, the task point
        self._jacobian = plant.CalcJacobianTranslationalVelocity(
            self._context, JacobianWrtVariable.kV, frame, self._origin, self._world, self._world
        )[self._axes]
        plant.SetPositions(self._context, np.zeros(self.nq))
        self._position_at_zero = self._position()
        mass, gravity = self._mass_and_gravity()
        q = np.ones(self.nq)
        plant.SetPositions(self._context, q)
        assert all(map(np.array_equal, (mass, gravity), self._mass_and_gravity())), (
            "prismatic joints: M and G do not depend on q"
        )
        assert np.allclose(
            self._position(), self._position_at_zero + self._jacobian @ q, rtol=1e-12, atol=1e-12
        ), "prismatic joints: x = x(0) + J q"
        plant.SetVelocities(self._context, np.ones(self.nv))
        assert not np.any(plant.CalcBiasTerm(self._context)), "prismatic joints: C(q, v) = 0"
        self._joint_gravity = -gravity
        self._inertia, self._gravity = prismatic_task_dynamics(
            np.linalg.inv(self._jacobian), mass, self._joint_gravity
        )
        self._coriolis = np.zeros((self.n_axes, self.n_axes))
        self._null_space = np.zeros((self.nv, self.nv))

    @property
    def constants(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """What every tick reads: x(0) (M,) [m], J (M, nv), Λ (M, M) [kg], C_x = 0 (M, M)
        and G_x (M,) [N], as a compiled tick takes them (`core.slider_tick`)."""
        return self._position_at_zero, self._jacobian, self._inertia, self._coriolis, self._gravity

    def _position(self) -> np.ndarray:
        return self.plant.CalcPointsPositions(
            self._context, self._frame, self._origin, self._world
        )[self._axes, 0]

    def _mass_and_gravity(self) -> tuple[np.ndarray, np.ndarray]:
        return self.plant.CalcMassMatrix(self._context), self.plant.CalcGravityGeneralizedForces(
            self._context
        )

    @property
    def context(self) -> Context:
        """The control-side plant context the constant terms were read from (`terms` does
        not set it)."""
        return self._context

    def terms(self, state: np.ndarray, coriolis_matrix: bool = True) -> TaskSpaceTerms:
        """All task-space terms at the plant state `state`, as `TaskSpaceModel.terms`.

        Parameters
        ----------
        state : (nq + nv,) array
            The joints' positions [m] and velocities [m/s].
        coriolis_matrix : bool
            Unused: C_x = 0 is a matrix either way.

        Returns
        -------
        TaskSpaceTerms
        """
        return TaskSpaceTerms(
            self._position_at_zero + self._jacobian @ state[: self.nq],
            self._jacobian @ state[self.nq :],
            self._jacobian,
            self._inertia,
            self._coriolis,
            self._gravity,
            self._null_space,
            self._joint_gravity,
        )


class TaskSpaceDynamics(LeafSystem):
    """Reads the plant state; outputs the task-space position, velocity, Jacobian and the
    task-space inertia, Coriolis matrix and gravity of a point P fixed on `frame`, as
    `TaskSpaceModel` computes them, plus the null-space projector and G(q).

    All outputs come from one cache entry that depends on the plant-state input only,
    so integrator stages that do not change the plant's state reuse it.

    Sizes: M task-space axes (`axes`), nq positions and nv velocities of the plant.
    Matrices are flattened row-major. Joint units are those of the plant's joints: [rad],
    [rad/s], [N m] for a revolute joint, [m], [m/s], [N] for a prismatic one.

    Input ports:

    - ``plant_state`` (nq + nv): the plant's positions q and velocities v (its state
      output).

    Output ports:

    - ``position`` (M): P's position x along `axes`, world [m].
    - ``velocity`` (M): its velocity x' = J v [m/s].
    - ``jacobian`` (M * nv, row-major M x nv): J, the rows of P's translational Jacobian
      with respect to v [m/rad for a revolute joint, - for a prismatic one].
    - ``task_inertia`` (M * M, row-major): Lambda = (J M^-1 J^T)^-1 [kg].
    - ``task_coriolis`` (M * M, row-major): C_x [kg/s] (see `TaskSpaceModel`).
    - ``task_gravity`` (M): G_x = Jbar^T G(q) [N].
    - ``null_space_projector`` (nv * nv, row-major): N^T = I - J^T Jbar^T [-].
    - ``joint_gravity`` (nv): G(q), the joint torque that holds the arm against gravity
      (minus Drake's gravity generalized force) [N m or N per joint].

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized; a control-side context of it is made here.
    frame : Frame
        The frame P is fixed on (e.g. the tool tip's).
    point_in_frame : (3,) array_like
        P in `frame` [m]; default its origin.
    axes : sequence of int
        The world axes of the task space (0 = x, 1 = y, 2 = z), distinct; default all
        three. M = len(axes).
    """

    def __init__(self, plant, frame, point_in_frame=(0.0, 0.0, 0.0), axes=(0, 1, 2)):
        super().__init__()
        self._model = TaskSpaceModel(plant, frame, point_in_frame, axes)
        nq, nv, m = self._model.nq, self._model.nv, self._model.n_axes
        self.plant_state = self.DeclareVectorInputPort("plant_state", BasicVector(nq + nv))
        self._terms = self.DeclareCacheEntry(
            "task_space_terms",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(None),
                calc=lambda context, value: value.set_value(
                    self._model.terms(self.plant_state.Eval(context))
                ),
            ),
            {self.input_port_ticket(self.plant_state.get_index())},
        )
        prereq = {self._terms.ticket()}
        for name, size, field in [
            ("position", m, "position"),
            ("velocity", m, "velocity"),
            ("jacobian", m * nv, "jacobian"),
            ("task_inertia", m * m, "inertia"),
            ("task_coriolis", m * m, "coriolis"),
            ("task_gravity", m, "gravity"),
            ("null_space_projector", nv * nv, "null_space"),
            ("joint_gravity", nv, "joint_gravity"),
        ]:
            self.DeclareVectorOutputPort(name, size, self._output_from(field), prereq)

    def terms(self, context: Context) -> TaskSpaceTerms:
        """All task-space terms at this context, from the cache entry.

        Parameters
        ----------
        context : Context
            This system's context; the terms are computed once per plant state and cached.

        Returns
        -------
        TaskSpaceTerms
            As `TaskSpaceModel.terms` gives them.
        """
        return self._terms.Eval(context)

    def _output_from(self, field):
        def calc(context, output):
            output.SetFromVector(np.ravel(getattr(self._terms.Eval(context), field)))

        return calc


class TaskForceToJointTorque(LeafSystem):
    """tau = J^T f_c (+ a joint torque from below the task, e.g. the null-space terms),
    saturated element-wise at the actuators' effort limits.

    Sizes: M task-space axes, nv the plant's velocities (one actuator per velocity).
    Joint torques are in the joints' units: [N m] for a revolute joint, [N] for a
    prismatic one.

    Input ports:

    - ``force`` (M): the commanded task-space force f_c [N].
    - ``jacobian`` (M * nv, row-major M x nv): J, as `TaskSpaceDynamics` outputs it.
    - ``extra_torque`` (nv), only with `extra_torque=True`: a joint torque added before
      the saturation (e.g. `NullSpaceImpedance`'s) [N m].

    Output ports:

    - ``joint_torque`` (nv): sat(J^T f_c + extra_torque), for the plant's actuation [N m].
    - ``saturated`` (1): the number of joints at their effort limit [-], for the run
      monitor.

    Parameters
    ----------
    n_axes : int
        M, the number of task-space axes.
    effort_limits : (nv,) array_like
        The actuators' effort limits [N m], > 0; their length sets nv.
    extra_torque : bool
        Whether to declare the ``extra_torque`` input (default False).
    """

    def __init__(self, n_axes, effort_limits, extra_torque=False):
        super().__init__()
        self._limits = np.asarray(effort_limits, dtype=float)
        nv = len(self._limits)
        self._m, self._nv = n_axes, nv
        self.force = self.DeclareVectorInputPort("force", BasicVector(n_axes))
        self.jacobian = self.DeclareVectorInputPort("jacobian", BasicVector(n_axes * nv))
        self.extra = (
            self.DeclareVectorInputPort("extra_torque", BasicVector(nv)) if extra_torque else None
        )
        # Both outputs come from one evaluation of the unsaturated torque.
        self._raw = self.DeclareCacheEntry(
            "unsaturated_torque",
            ValueProducer(allocate=lambda: AbstractValue.Make(None), calc=self._calc_raw),
            {self.all_input_ports_ticket()},
        )
        prereq = {self._raw.ticket()}
        self.DeclareVectorOutputPort("joint_torque", nv, self._calc_torque, prereq)
        self.DeclareVectorOutputPort("saturated", 1, self._calc_saturated, prereq)

    def _calc_raw(self, context, abstract_value):
        torque = self.jacobian.Eval(context).reshape(self._m, self._nv).T @ self.force.Eval(context)
        abstract_value.set_value(
            torque + self.extra.Eval(context) if self.extra is not None else torque
        )

    def _calc_torque(self, context, output):
        output.SetFromVector(saturate(self._raw.Eval(context), self._limits)[0])

    def _calc_saturated(self, context, output):
        output.SetFromVector([saturate(self._raw.Eval(context), self._limits)[1]])
