"""The one exception type for bad user input; the CLI turns it into one line and exit 2."""


class InputError(Exception):
    """Bad input from a user's file or argument. The message names the file, the line or
    field, and what is wrong, e.g. ``demo.csv:12: column 'z' is not a number: 'abc'``."""


def located(path, line, problem):
    """`path:line: problem` (line omitted when unknown)."""
    return InputError(f"{path}:{line}: {problem}" if line else f"{path}: {problem}")
