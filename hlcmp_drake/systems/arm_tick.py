"""The arm's translational tick in two compiled calls (`core.arm_tick`), for the laws it
knows: the Hl-CMP (with or without forgetting) and the constant impedance. It gives what
`ControlTick` gives, the same numbers (tests/test_systems_arm_tick.py), at about three
quarters of its cost; `arm_control_tick` picks it where it applies and `ControlTick`
everywhere else."""

from __future__ import annotations

import numpy as np

from hlcmp_drake.core.arm_tick import (
    arm_tick_start,
    hlcmp_arm_tick_finish,
    impedance_arm_tick_finish,
    start_layout,
)
from hlcmp_drake.core.kernels import implementation
from hlcmp_drake.core.laws import ConstantImpedanceLaw, ControlLaw, HlcmpLaw, LawOutput
from hlcmp_drake.systems.arm import BelowTaskImpedance
from hlcmp_drake.systems.control_loop import ControlTick, DeferredTermsResult, TickResult
from hlcmp_drake.systems.task_space import (
    CoriolisProduct,
    PrismaticTaskModel,
    TaskSpaceModel,
    TaskSpaceTerms,
)


def fuses(
    model: TaskSpaceModel | PrismaticTaskModel,
    below_task: BelowTaskImpedance | None,
    law: ControlLaw,
) -> bool:
    """Whether `FusedArmTick` evaluates this combination: a `TaskSpaceModel` whose task
    axes are consecutive, a torque below the task, and an Hl-CMP or a constant impedance.

    Parameters
    ----------
    model : TaskSpaceModel or PrismaticTaskModel
    below_task : BelowTaskImpedance or None
    law : ControlLaw
    """
    return (
        isinstance(model, TaskSpaceModel)
        and model.first_translational_row is not None
        and isinstance(below_task, BelowTaskImpedance)
        and isinstance(law, HlcmpLaw | ConstantImpedanceLaw)
    )


def arm_control_tick(
    model: TaskSpaceModel | PrismaticTaskModel,
    below_task: BelowTaskImpedance | None,
    law: ControlLaw,
    effort_limits: np.ndarray,
) -> ControlTick:
    """The arm's tick: `FusedArmTick` where it `fuses` the law, else `ControlTick`.

    Parameters
    ----------
    model : TaskSpaceModel or PrismaticTaskModel
    below_task : BelowTaskImpedance or None
    law : ControlLaw
    effort_limits : (nv,) array
        As for `ControlTick`.

    Returns
    -------
    ControlTick
    """
    tick_class = FusedArmTick if fuses(model, below_task, law) else ControlTick
    return tick_class(model, below_task, law, effort_limits)


class FusedArmTick(ControlTick):
    """`ControlTick` for an arm, an Hl-CMP or a constant impedance: Drake's position queries
    (`TaskSpaceModel.plant_queries`), `core.arm_tick.arm_tick_start`, Drake's two
    evaluations of the Coriolis product (`TaskSpaceModel.biases`), and the law's finish,
    compiled or numpy as `core.kernels.kernel_path` says when it is made.

    Parameters
    ----------
    As for `ControlTick`, with the combinations of `fuses`.

    Raises
    ------
    ValueError
        For a combination that `fuses` refuses.
    """

    def __init__(self, model: TaskSpaceModel, below_task: BelowTaskImpedance, law, effort_limits):
        if not fuses(model, below_task, law):
            raise ValueError(
                f"FusedArmTick takes an arm's TaskSpaceModel with consecutive axes, a torque "
                f"below the task and an Hl-CMP or a constant impedance, not "
                f"{type(model).__name__}, {type(below_task).__name__}, {type(law).__name__}"
            )
        super().__init__(model, below_task, law, effort_limits)
        self._start = implementation(arm_tick_start, self.kernel)
        self._first_row = model.first_translational_row
        desired_inverse, nominal, gains = below_task.held
        self._held = (desired_inverse, nominal, gains, self.effort_limits)
        self._layout = start_layout(model.nv, model.n_axes)
        self._learns = isinstance(law, HlcmpLaw)
        if self._learns:
            self._finish = implementation(hlcmp_arm_tick_finish, self.kernel)
            g = law.gains
            self._law_parameters: tuple = (
                law.centers,
                law.widths,
                g.gain_l,
                g.q_k,
                g.q_d,
                g.q_v,
            )
            self._pi = g.pi
        else:
            self._finish = implementation(impedance_arm_tick_finish, self.kernel)
            self._law_parameters = (law.gain_l, law.k_s, law.k_d)
            self._pi = law.pi

    def evaluate(
        self,
        state: np.ndarray,
        reference: tuple,
        theta: np.ndarray | None,
        *,
        time: float = 0.0,
        external_force: np.ndarray | None = None,
    ) -> TickResult:
        """As `ControlTick.evaluate`; the result's `terms` are formed when first read.

        Parameters
        ----------
        state : (nq + nv,) array
            The plant's positions [rad] and velocities [rad/s].
        reference : tuple of (M,), (M,), (M,), (1,) arrays
            x_d [m], x_d' [m/s], x_d'' [m/s^2] and the phase s.
        theta : (P,) array or None
            The Hl-CMP's flattened weights; None for the constant impedance.
        time, external_force
            Not read by these laws.

        Returns
        -------
        TickResult
        """
        computed = self._compute(state, reference, theta)
        start, position, spatial, joint_gravity, rotation, v, out = computed
        nv, m, law = self.model.nv, self.n_axes, self.law
        if self._learns:
            after = out[nv + 1 :]  # hlcmp_force's layout, then θ'
            law_output = LawOutput(
                after[:m], law._logs(after), law._learning(lambda: after[6 * m :], theta)
            )
        else:
            law_output = LawOutput(out[nv + 1 :], {})
        return DeferredTermsResult(
            self.terms_of,
            (start, position, spatial, joint_gravity, rotation, v),
            law_output,
            out[:nv],
            int(out[nv]),
            joint_gravity,
        )

    def _torque_and_rates(self, state, reference, theta, time, external_force):
        """The torque and θ' sliced from the finish's output, nothing else formed."""
        out = self._compute(state, reference, theta)[-1]
        nv = self.model.nv
        if not self._learns:
            return out[:nv], None
        paper_rates = out[nv + 1 + 6 * self.n_axes :]
        return out[:nv], self.law._learning(lambda: paper_rates, theta)()

    def _compute(self, state: np.ndarray, reference: tuple, theta: np.ndarray | None) -> tuple:
        """Drake's queries and the two compiled calls: (the start's output, x, the spatial
        Jacobian, G(q), R, v, the finish's output)."""
        model, nv = self.model, self.model.nv
        position, spatial, joint_gravity, mass, rotation = model.plant_queries(state)
        q, v = state[: model.nq], state[model.nq :]
        xd, xd_dot, xd_ddot, phase = reference
        first_row = self._first_row
        start = self._start(
            mass, spatial, first_row, joint_gravity, position, v, xd, xd_dot, xd_ddot, self._pi
        )
        biases = model.biases(v, start[:nv])
        common = (*biases, spatial, first_row, rotation, q, v, joint_gravity)
        if self._learns:
            out = self._finish(start, *common, phase[0], theta, *self._law_parameters, *self._held)
        else:
            out = self._finish(start, *common, *self._law_parameters, *self._held)
        return start, position, spatial, joint_gravity, rotation, v, out

    def terms_of(
        self,
        start: np.ndarray,
        position: np.ndarray,
        spatial: np.ndarray,
        joint_gravity: np.ndarray,
        rotation: np.ndarray,
        v: np.ndarray,
    ) -> TaskSpaceTerms:
        """The tick's `TaskSpaceTerms` as views of what it computed (C_x as the product; J_w
        a contiguous copy, which the compiled torque below the task takes as it is).

        Parameters
        ----------
        start : array
            From `core.arm_tick.arm_tick_start`.
        position, spatial, joint_gravity, rotation
            From `TaskSpaceModel.plant_queries`.
        v : (nv,) array
            The plant's velocities.

        Returns
        -------
        TaskSpaceTerms
        """
        nv, m, at = self.model.nv, self.n_axes, self._layout
        first_row = self._first_row
        inertia = start[at[2] : at[3]].reshape(m, m)
        jbar = start[at[3] : at[4]].reshape(nv, m)
        return TaskSpaceTerms(
            position,
            start[at[1] : at[2]],
            spatial[first_row : first_row + m],
            inertia,
            CoriolisProduct(self.model, v, jbar, inertia),
            start[at[4] : at[5]],
            start[at[5] : at[6]].reshape(nv, nv),
            joint_gravity,
            rotation,
            np.ascontiguousarray(spatial[:3]),  # as TaskSpaceModel.terms gives J_w
        )
