"""The task-space view of a MultibodyPlant: measured x, x' and the dynamics terms
M, C, G of paper Eq. 2 in the task space, all computed by Drake from a control-side
plant; and the map from a task-space force back to joint torques."""

from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import BasicVector, Context, LeafSystem, ValueProducer


@dataclass
class TaskSpaceTerms:
    """Everything that depends only on the plant's state, evaluated once per state."""

    position: np.ndarray
    velocity: np.ndarray
    jacobian: np.ndarray   # J (M x nv), rows of the point's translational Jacobian
    inertia: np.ndarray    # Lambda = (J M^-1 J^T)^-1
    coriolis: np.ndarray   # C_x = Jbar^T C(q, v) Jbar - Lambda Jdot Jbar
    gravity: np.ndarray    # G_x = Jbar^T G(q)
    null_space: np.ndarray  # N^T = I - J^T Jbar^T (nv x nv), dynamically consistent
    joint_gravity: np.ndarray  # G(q) (nv,)


class TaskSpaceDynamics(LeafSystem):
    """Reads the plant state; outputs the task-space position, velocity, Jacobian and the
    task-space inertia, Coriolis matrix and gravity of a point P fixed on `frame`.

    Task space = the `axes` (0 = x, 1 = y, 2 = z of the world) of P's translation.
    Lambda, C_x and G_x are the operational-space terms (Khatib) with the dynamically
    consistent inverse Jbar = M^-1 J^T Lambda. C(q, v) and Jdot are not exposed by Drake
    as matrices, only as the products C(q, v) v (CalcBiasTerm) and Jdot v
    (CalcBiasTranslationalAcceleration); both products are quadratic forms whose
    symmetric bilinear form is the matrix-vector product we need (Christoffel symbols,
    resp. mixed second derivatives of P's position), so the products with the M columns
    w of Jbar are recovered exactly by polarization: C(q, v) w = [b(v + w) - b(v - w)] / 4.

    All outputs come from one cache entry that depends on the plant-state input only,
    so integrator stages that do not change the plant's state reuse it.
    """

    def __init__(self, plant, frame, point_in_frame=(0.0, 0.0, 0.0), axes=(0, 1, 2)):
        super().__init__()
        self._plant = plant
        self._frame = frame
        self._point = np.asarray(point_in_frame, dtype=float).reshape(3, 1)
        self._axes = list(axes)
        self._context = plant.CreateDefaultContext()
        self._scratch = plant.CreateDefaultContext()
        nq, nv, m = plant.num_positions(), plant.num_velocities(), len(self._axes)
        self._nq, self._nv, self._m = nq, nv, m
        self.plant_state = self.DeclareVectorInputPort("plant_state", BasicVector(nq + nv))
        self._terms = self.DeclareCacheEntry(
            "task_space_terms",
            ValueProducer(allocate=lambda: AbstractValue.Make(None), calc=self._calc_terms),
            {self.input_port_ticket(self.plant_state.get_index())})
        prereq = {self._terms.ticket()}
        for name, size, field in [("position", m, "position"), ("velocity", m, "velocity"),
                                  ("jacobian", m * nv, "jacobian"),
                                  ("task_inertia", m * m, "inertia"),
                                  ("task_coriolis", m * m, "coriolis"),
                                  ("task_gravity", m, "gravity"),
                                  ("null_space_projector", nv * nv, "null_space"),
                                  ("joint_gravity", nv, "joint_gravity")]:
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
            Position [m] and velocity [m/s] (M,), Jacobian (M, nv), inertia [kg] and
            Coriolis [kg/s] (M, M), gravity [N] (M,), null-space projector (nv, nv) and
            joint gravity G(q) (nv,) in the joints' units.
        """
        return self._terms.Eval(context)

    def _output_from(self, field):
        def calc(context, output):
            output.SetFromVector(np.ravel(getattr(self._terms.Eval(context), field)))
        return calc

    def _polarized(self, v, directions, evaluate):
        """[bilinear(v, w) for each column w of `directions`] by polarization of the
        quadratic map `evaluate` of the velocity: (evaluate(v + w) - evaluate(v - w)) / 4."""
        columns = []
        for w in directions.T:
            self._plant.SetVelocities(self._scratch, v + w)
            plus = evaluate(self._scratch)
            self._plant.SetVelocities(self._scratch, v - w)
            columns.append((plus - evaluate(self._scratch)) / 4.0)
        return np.column_stack(columns)

    def _calc_terms(self, context, abstract_value):
        plant, ctx, world = self._plant, self._context, self._plant.world_frame()
        state = self.plant_state.Eval(context)
        plant.SetPositionsAndVelocities(ctx, state)
        q, v = state[: self._nq], state[self._nq :]
        position = plant.CalcPointsPositions(ctx, self._frame, self._point, world)[self._axes, 0]
        jac = plant.CalcJacobianTranslationalVelocity(
            ctx, JacobianWrtVariable.kV, self._frame, self._point, world, world)[self._axes]
        mass = plant.CalcMassMatrix(ctx)
        minv_jt = np.linalg.solve(mass, jac.T)
        inertia = np.linalg.inv(jac @ minv_jt)
        jbar = minv_jt @ inertia
        joint_gravity = -plant.CalcGravityGeneralizedForces(ctx)
        gravity = jbar.T @ joint_gravity
        plant.SetPositions(self._scratch, q)
        # Only C(q, v) Jbar and Jdot Jbar are needed: M polarizations each, not nv.
        coriolis_jbar = self._polarized(v, jbar, plant.CalcBiasTerm)
        jdot_jbar = self._polarized(v, jbar, lambda c: plant.CalcBiasTranslationalAcceleration(
            c, JacobianWrtVariable.kV, self._frame, self._point, world, world)[self._axes, 0])
        coriolis = jbar.T @ coriolis_jbar - inertia @ jdot_jbar
        null_space = np.eye(self._nv) - jac.T @ jbar.T
        abstract_value.set_value(TaskSpaceTerms(position, jac @ v, jac, inertia, coriolis, gravity,
                                                null_space, joint_gravity))


class TaskForceToJointTorque(LeafSystem):
    """tau = J^T f_c (+ a joint torque from below the task, e.g. the null-space terms),
    saturated element-wise at the actuators' effort limits.

    Inputs: `force` (M), `jacobian` (M x nv row-major) and, with `extra_torque=True`,
    `extra_torque` (nv). Outputs: `joint_torque` (nv), and `saturated` (1): the number
    of joints at their limit, for the run monitor.
    """

    def __init__(self, n_axes, effort_limits, extra_torque=False):
        super().__init__()
        self._limits = np.asarray(effort_limits, dtype=float)
        nv = len(self._limits)
        self._m, self._nv = n_axes, nv
        self.force = self.DeclareVectorInputPort("force", BasicVector(n_axes))
        self.jacobian = self.DeclareVectorInputPort("jacobian", BasicVector(n_axes * nv))
        self.extra = self.DeclareVectorInputPort("extra_torque", BasicVector(nv)) if extra_torque else None
        # Both outputs come from one evaluation of the unsaturated torque.
        self._raw = self.DeclareCacheEntry(
            "unsaturated_torque", ValueProducer(allocate=lambda: AbstractValue.Make(None),
                                                calc=self._calc_raw), {self.all_input_ports_ticket()})
        prereq = {self._raw.ticket()}
        self.DeclareVectorOutputPort("joint_torque", nv, self._calc_torque, prereq)
        self.DeclareVectorOutputPort("saturated", 1, self._calc_saturated, prereq)

    def _calc_raw(self, context, abstract_value):
        torque = self.jacobian.Eval(context).reshape(self._m, self._nv).T @ self.force.Eval(context)
        abstract_value.set_value(torque + self.extra.Eval(context) if self.extra is not None else torque)

    def _calc_torque(self, context, output):
        output.SetFromVector(np.clip(self._raw.Eval(context), -self._limits, self._limits))

    def _calc_saturated(self, context, output):
        output.SetFromVector([np.count_nonzero(np.abs(self._raw.Eval(context)) >= self._limits)])
