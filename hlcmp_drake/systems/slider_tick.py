"""The slider's tick in one compiled call (`core.slider_tick`), for every law of the 1-DOF
world: the Hl-CMP (with or without forgetting), the constant impedance and the variable
impedance. It gives what `ControlTick` gives, the same numbers
(tests/test_systems_slider_tick.py); `slider_control_tick` picks it where it applies and
`ControlTick` everywhere else."""

from __future__ import annotations

import numpy as np

from hlcmp_drake.core.kernels import implementation
from hlcmp_drake.core.laws import (
    ConstantImpedanceLaw,
    ControlLaw,
    HlcmpLaw,
    LawOutput,
    VariableImpedanceLaw,
)
from hlcmp_drake.core.slider_tick import (
    hlcmp_slider_tick,
    impedance_slider_tick,
    variable_impedance_slider_tick,
)
from hlcmp_drake.systems.control_loop import ControlTick, DeferredTermsResult, TickResult
from hlcmp_drake.systems.task_space import PrismaticTaskModel

FUSED_LAWS = (HlcmpLaw, ConstantImpedanceLaw, VariableImpedanceLaw)


def slider_control_tick(
    model: PrismaticTaskModel, law: ControlLaw, effort_limits: np.ndarray
) -> ControlTick:
    """The slider's tick: `FusedSliderTick` for the laws it knows, else `ControlTick`.

    Parameters
    ----------
    model : PrismaticTaskModel
    law : ControlLaw
    effort_limits : (nv,) array
        As for `ControlTick`.

    Returns
    -------
    ControlTick
    """
    if isinstance(law, FUSED_LAWS):
        return FusedSliderTick(model, law, effort_limits)
    return ControlTick(model, None, law, effort_limits)


class SliderTickResult(DeferredTermsResult):
    """`DeferredTermsResult` that keeps the kernel's output it was sliced from (`kernel_output`:
    the torque, the number of saturated joints, x and the law's output), for the log row."""

    def __init__(self, kernel_output: np.ndarray, *arguments):
        super().__init__(*arguments)
        self.kernel_output = kernel_output


class FusedSliderTick(ControlTick):
    """`ControlTick` for the slider (`PrismaticTaskModel`, nothing below the task): the law's
    `core.slider_tick` function, one compiled call (or numpy, as `core.kernels.kernel_path`
    says when it is made).

    Parameters
    ----------
    model : PrismaticTaskModel
    law : HlcmpLaw, ConstantImpedanceLaw or VariableImpedanceLaw
    effort_limits : (nv,) array
        The actuators' effort limits [N].

    Raises
    ------
    ValueError
        For another law.
    """

    def __init__(self, model: PrismaticTaskModel, law, effort_limits):
        if not isinstance(law, FUSED_LAWS):
            raise ValueError(
                f"FusedSliderTick takes an Hl-CMP, a constant or a variable impedance, not "
                f"{type(law).__name__}"
            )
        super().__init__(model, None, law, effort_limits)
        # What does not change from tick to tick, in the order the kernels take it after
        # the state, the reference, θ and the measured force.
        if isinstance(law, HlcmpLaw):
            self._kind = "hlcmp"
            self._run = implementation(hlcmp_slider_tick, self.kernel)
            g = law.gains
            law_parameters: tuple = (g.pi, g.gain_l, law.centers, law.widths, g.q_k, g.q_d, g.q_v)
        elif isinstance(law, ConstantImpedanceLaw):
            self._kind = "impedance"
            self._run = implementation(impedance_slider_tick, self.kernel)
            law_parameters = (law.pi, law.gain_l, law.k_s, law.k_d)
        else:
            self._kind = "variable"
            self._run = implementation(variable_impedance_slider_tick, self.kernel)
            law_parameters = (
                law.mass,
                law.damping,
                law.free_stiffness,
                law.kp,
                law.kv,
                law.sigma,
                law.sample_period,
            )
        self._parameters = (*model.constants, *law_parameters, self.effort_limits)
        # Where the kernel's output holds the torque and θ' (`core.slider_tick`): the
        # Hl-CMP's θ' after its six series, the variable impedance's after f_c.
        m = self.n_axes
        self._nv = model.nv
        self._rates_from = model.nv + 1 + m + (6 * m if self._kind == "hlcmp" else m)
        # The log row's entries in the kernel's output, sliced as `evaluate` slices it: x,
        # f_c, the number of saturated joints, the law's series (`ControlTick.log_row`'s
        # layout), gathered in one indexing instead of forming the terms and the series.
        where = np.arange(self._rates_from)
        after = where[model.nv + 1 + m :]
        series = law._logs(after) if self._kind == "hlcmp" else {}
        self._log_order = np.concatenate(
            [
                where[model.nv + 1 : model.nv + 1 + m],
                after[:m],
                where[model.nv : model.nv + 1],
                *(series[name] for name in law.log_fields),
            ]
        )

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
            The joints' positions [m] and velocities [m/s].
        reference : tuple of (M,), (M,), (M,), (1,) arrays
            x_d [m], x_d' [m/s], x_d'' [m/s^2] and the phase s.
        theta : (P,) array or None
            The law's integrated state.
        time : float
            The instant [s] (the variable impedance's f_d(t)).
        external_force : (M,) array, optional
            The measured environment force [N] (the variable impedance reads it).

        Returns
        -------
        TickResult
        """
        out = self._output(state, reference, theta, time, external_force)
        law, nv, m = self.law, self.model.nv, self.n_axes
        after = out[nv + 1 + m :]  # the law's output
        if self._kind == "hlcmp":
            law_output = LawOutput(
                after[:m], law._logs(after), law._learning(lambda: after[6 * m :], theta)
            )
        elif self._kind == "impedance":
            law_output = LawOutput(after, {})
        else:
            law_output = LawOutput(after[:m], {}, lambda: after[m:])
        return SliderTickResult(out, self.model.terms, (state,), law_output, out[:nv], int(out[nv]))

    def log_row(self, result: TickResult) -> np.ndarray:
        """As `ControlTick.log_row`, gathered from the kernel's output (the same numbers:
        the kernel's x is x(0) + J q as the terms' is, tests/test_systems_slider_tick.py).

        Parameters
        ----------
        result : SliderTickResult
            From this tick's `evaluate`.

        Returns
        -------
        (log_size,) array
        """
        assert isinstance(result, SliderTickResult), "a result of this tick's `evaluate`"
        return result.kernel_output[self._log_order]

    def _torque_and_rates(self, state, reference, theta, time, external_force):
        """The torque and θ' sliced from the kernel's output, nothing else formed."""
        out = self._output(state, reference, theta, time, external_force)
        torque = out[: self._nv]
        if self._kind == "impedance":
            return torque, None
        rates = out[self._rates_from :]
        if self._kind == "hlcmp":
            return torque, self.law._learning(lambda: rates, theta)()
        return torque, rates

    def _output(self, state, reference, theta, time, external_force) -> np.ndarray:
        """The law's kernel: [the joint force, the number of saturated joints, x, the
        law's output] (`core.slider_tick`)."""
        xd, xd_dot, xd_ddot, phase = reference
        if self._kind == "hlcmp":
            return self._run(state, xd, xd_dot, xd_ddot, phase[0], theta, *self._parameters)
        if self._kind == "impedance":
            return self._run(state, xd, xd_dot, xd_ddot, *self._parameters)
        assert external_force is not None, "the variable impedance reads the force"
        desired = np.asarray(self.law.desired_force(time), float)
        return self._run(
            state, xd, xd_dot, xd_ddot, theta, desired, external_force, *self._parameters
        )
