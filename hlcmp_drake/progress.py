"""Progress lines on stderr for runs longer than a few seconds: the controller, the
simulated time and the real-time factor. Off with --quiet and when stderr is not a
terminal (a log file or a pipe gets the results, not a ticker)."""

import sys


class Progress:
    def __init__(self, quiet=False, stream=None):
        self._stream = stream or sys.stderr
        try:
            terminal = self._stream.isatty()
        except (ValueError, AttributeError):   # a closed or file-less stream is no terminal
            terminal = False
        self.enabled = not quiet and terminal

    def step(self, controller, t, duration, wall_s):
        """Called about once a wall-clock second while a run simulates."""
        if self.enabled:
            rate = t / wall_s if wall_s > 0 else 0.0
            self._stream.write(f"\r{controller}: {t:5.1f} / {duration:.1f} s simulated "
                               f"({rate:.2f}x real time)   ")
            self._stream.flush()

    def say(self, message):
        if self.enabled:
            self._stream.write(f"\r{message}\033[K\n")
            self._stream.flush()
