"""Safety checks as a periodic event that stops the simulation, off the per-step path."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from pydrake.systems.framework import BasicVector, Context, EventStatus, LeafSystem

# How often a run's safety checks look [s]: 100 Hz, a tenth of the plant's steps.
CHECK_PERIOD_S = 0.01


class SafetyMonitor(LeafSystem):
    """Reads its inputs every `period` and stops the simulation (EventStatus
    ReachedTermination, whose message the Simulator returns) at the first problem `check`
    reports.

    Input ports: one vector port per entry of `inputs`, named and sized as given, in the
    units of the port it is connected to. The worlds declare ``plant_state`` (nq + nv,
    the plant's state), ``saturated`` (1, the number of joints at their effort limit) and,
    for an arm, ``contact_force`` (3, `ToolContactForce`'s ``force``, world [N]).

    Output ports: none (a periodic publish event).

    Parameters
    ----------
    inputs : dict of str to int
        The vector input ports to declare, by name and size.
    check : callable(t, values) -> str or None
        Given the time [s] and {input name: (size,) array}, a problem's description or
        None. It may keep state between calls (e.g. since when a limit has been held):
        use one monitor per simulation.
    period : float
        How often to check [s].
    """

    def __init__(
        self,
        inputs: dict,
        check: Callable[[float, dict], str | None],
        period: float = CHECK_PERIOD_S,
    ):
        super().__init__()
        self._ports = {
            name: self.DeclareVectorInputPort(name, BasicVector(size))
            for name, size in inputs.items()
        }
        self._check = check
        self.DeclarePeriodicPublishEvent(period, 0.0, self._look)

    def problem_at(self, context: Context) -> str | None:
        """The check's verdict at this system's `context`.

        Parameters
        ----------
        context : Context
            This system's context.

        Returns
        -------
        str or None
            The problem's description, or None when all is well.
        """
        return self._check(
            context.get_time(), {name: port.Eval(context) for name, port in self._ports.items()}
        )

    def _look(self, context):
        problem = self.problem_at(context)
        return (
            EventStatus.ReachedTermination(self, problem) if problem else EventStatus.DidNothing()
        )


def plant_state_check(
    n_positions: int, max_abs_position: float
) -> Callable[[np.ndarray], str | None]:
    """The checks every world shares: a finite plant state and positions within a bound.

    Parameters
    ----------
    n_positions : int
        nq: the state's first nq entries are positions.
    max_abs_position : float
        The bound on |q| [m or rad].

    Returns
    -------
    callable(state) -> str or None
        A problem's description, or None.
    """

    def check(state):
        # As Python floats: two numpy reductions over a few entries cost ten times as much,
        # and the check runs at 100 Hz in every run (docs/performance.md).
        values = state.tolist()
        if not all(map(math.isfinite, values)):
            return "plant state is not finite"
        if max(map(abs, values[:n_positions]), default=0.0) > max_abs_position:
            return f"a joint position beyond {max_abs_position} m/rad"
        return None

    return check


def saturation_check(
    max_saturation_s: float, efforts: str = "joint torques"
) -> Callable[[float, float], str | None]:
    """The saturation watchdog every world shares: some joint's effort at its limit at
    every check for longer than `max_saturation_s`.

    Parameters
    ----------
    max_saturation_s : float
        How long [s] the saturation may last (a task's `max_saturation_s`).
    efforts : str
        What saturates, for the message: "joint torques" (an arm's revolute joints) or
        "joint forces" (the slider's prismatic one).

    Returns
    -------
    callable(t, saturated) -> str or None
        Given the time [s] and the number of joints at their effort limit, a problem's
        description or None. It keeps the time saturation began, so use one per
        simulation, called in time order.
    """
    saturated_since: list[float | None] = [None]

    def check(t, saturated):
        if saturated > 0:
            saturated_since[0] = t if saturated_since[0] is None else saturated_since[0]
            if t - saturated_since[0] > max_saturation_s:
                return f"{efforts} saturated for more than max_saturation_s = {max_saturation_s} s"
        else:
            saturated_since[0] = None
        return None

    return check
