"""The one exception type for bad user input; the CLI turns it into one line and exit 2."""

from __future__ import annotations

from pathlib import Path


class InputError(Exception):
    """Bad input from a user's file or argument. The message names the file, the line or
    field, and what is wrong, e.g. ``demo.csv:12: column 'z' is not a number: 'abc'``."""


def located(path: str | Path, line: int | None, problem: str) -> InputError:
    """`path:line: problem` (line omitted when unknown).

    Parameters
    ----------
    path : str or Path
        The file the problem is in.
    line : int or None
        1-based line number; None or 0 when unknown.
    problem : str
        What is wrong.

    Returns
    -------
    InputError
        The error, not raised: the caller raises it.
    """
    return InputError(f"{path}:{line}: {problem}" if line else f"{path}: {problem}")
