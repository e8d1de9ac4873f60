"""Ctrl-C and SIGTERM as a request to stop: the commands that run for as long as their
client or their user wants (`hlcmp serve`, `hlcmp sim-driver`) stop between two steps and
say what they did up to then, instead of ending wherever the signal fell."""

from __future__ import annotations

import signal
import threading
from typing import Callable

# The signals taken as a request to stop, by the name the commands' messages give them.
STOP_SIGNALS = {signal.SIGINT: "Ctrl-C", signal.SIGTERM: "SIGTERM"}


class StopSignals:
    """Ctrl-C (SIGINT) or SIGTERM (`kill`, `timeout`, a service manager) while a `with`
    block runs, as a request to stop: the handler only records which came (`by`) and tells
    `on_stop`, and the block's loop, looking at `received`, ends between two steps. A
    second one ends the command at once, as a Ctrl-C does (KeyboardInterrupt). Elsewhere
    than in the main thread, where Python takes no signal handler, both act as usual; a
    signal ignored when the process started (SIGINT for one started in the background by a
    script) stays ignored. The handlers in place before are put back afterwards.

    Parameters
    ----------
    on_stop : callable(str), optional
        Told the name of the first signal ("Ctrl-C" or "SIGTERM"), from the handler.
    """

    def __init__(self, on_stop: Callable[[str], None] | None = None) -> None:
        self.by: str | None = None  # "Ctrl-C" or "SIGTERM" once one came
        self._on_stop = on_stop
        self._previous: dict = {}

    @property
    def received(self) -> bool:
        """Whether a signal asked to stop."""
        return self.by is not None

    def stopped_at(self, time_s: float, commanded: bool) -> str:
        """A driver's reason for stopping, e.g. "Ctrl-C at t = 4.277 s" (", before any
        command" where no command had come).

        Parameters
        ----------
        time_s : float
            The simulated time it stopped at [s].
        commanded : bool
            Whether a command had come.

        Returns
        -------
        str
        """
        before = "" if commanded else ", before any command"
        return f"{self.by} at t = {time_s:.3f} s{before}"

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            for number in STOP_SIGNALS:
                if signal.getsignal(number) is not signal.SIG_IGN:  # not ours to take
                    self._previous[number] = signal.signal(number, self._receive)
        return self

    def __exit__(self, *exc_info) -> None:
        for number, previous in self._previous.items():  # None: set outside Python
            signal.signal(number, signal.SIG_DFL if previous is None else previous)
        self._previous = {}

    def _receive(self, signum, frame) -> None:
        if self.by is not None:
            raise KeyboardInterrupt
        self.by = STOP_SIGNALS[signum]
        if self._on_stop is not None:
            self._on_stop(self.by)
