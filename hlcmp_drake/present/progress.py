"""Progress lines on stderr for runs longer than a few seconds: the controller, the
simulated time and the real-time factor. Off with --quiet and when stderr is not a
terminal (a log file or a pipe gets the results, not a ticker).

Library code reports through a reporter object with `step` and `say`; `Progress` writes
to a terminal, `SILENT` (the default everywhere) says nothing."""

from __future__ import annotations

import sys


class Progress:
    """A reporter that writes to a terminal stream (stderr by default).

    Parameters
    ----------
    quiet : bool
        Say nothing at all.
    stream : text stream, optional
        Where to write; lines appear only when it is a terminal.
    """

    def __init__(self, quiet: bool = False, stream=None):
        self._stream = stream or sys.stderr
        try:
            terminal = self._stream.isatty()
        except (ValueError, AttributeError):  # a closed or file-less stream is no terminal
            terminal = False
        self.enabled = not quiet and terminal

    def step(self, controller: str, t: float, duration: float, wall_s: float) -> None:
        """Called about once a wall-clock second while a run simulates.

        Parameters
        ----------
        controller : str
            The run's label.
        t, duration : float
            Simulated time so far and the run's duration [s].
        wall_s : float
            Wall-clock time so far [s].
        """
        if self.enabled:
            rate = t / wall_s if wall_s > 0 else 0.0
            self._stream.write(
                f"\r{controller}: {t:5.1f} / {duration:.1f} s simulated ({rate:.2f}x real time)   "
            )
            self._stream.flush()

    def say(self, message: str) -> None:
        """One line of news (a run finished, a scenario starts).

        Parameters
        ----------
        message : str
        """
        if self.enabled:
            self._stream.write(f"\r{message}\033[K\n")
            self._stream.flush()


SILENT = Progress(quiet=True)
