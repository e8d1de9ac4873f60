"""Writing results so that nothing already in the output folder is lost or half-written:
every file goes to a temporary name in the same folder and is moved into place.

`check_output_folder` and `check_output_file` say before any work whether a command's
output path can be written at all (a file where a folder is needed, a folder where a
file is needed, a folder that cannot be created or written in), as one InputError.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hlcmp_drake.io.errors import InputError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

_UMASK = os.umask(0)
os.umask(_UMASK)
WRITTEN: list[Path] = []  # every path written in this process, in order (for the interrupt message)


def _existing_ancestor(path: Path) -> Path:
    """`path` itself or its nearest ancestor that exists, as the user wrote it."""
    for candidate in (path, *path.parents):
        if os.path.lexists(candidate):
            return candidate
    return Path(".")


def _check_folder(folder: Path, shown: str, given: Path) -> None:
    """InputError unless files can be written in `folder` (or in its nearest existing
    ancestor, where it would be made): creating one is tried, so read-only file systems
    and root count as they really are."""
    found = _existing_ancestor(folder)
    if not found.is_dir():
        where = "" if found == given else f"{found} "
        raise InputError(f"{shown}: {where}is a file, not a folder")
    try:
        handle, temp = tempfile.mkstemp(prefix=".hlcmp-check.", dir=found)
    except OSError as error:
        raise InputError(f"{shown}: cannot write in {found} ({error.strerror or error})") from None
    os.close(handle)
    os.unlink(temp)


def check_output_folder(path: str | Path, option: str = "--out") -> Path:
    """Check, before any work, that results can be written into the folder `path`.

    The folder may exist (its files are replaced one by one, atomically) or not (it is
    made when the first file is written; nothing is created here).

    Parameters
    ----------
    path : str or Path
        The output folder.
    option : str
        How the user gave it, for the message (e.g. "--out").

    Returns
    -------
    Path
        `path` as a Path.

    Raises
    ------
    InputError
        ``--out PATH: is a file, not a folder`` when it or one of its parents is a file,
        ``--out PATH: cannot write in FOLDER (...)`` when the folder (or the nearest one
        that exists) does not let us create files.
    """
    path = Path(path)
    _check_folder(path, f"{option} {path}", path)
    return path


def check_output_file(path: str | Path, option: str = "--out") -> Path:
    """Check, before any work, that the file `path` can be written (created or replaced).

    Parameters
    ----------
    path : str or Path
        The output file; an existing file is replaced atomically at the end.
    option : str
        As for `check_output_folder`.

    Returns
    -------
    Path
        The file's path (nothing is written yet).

    Raises
    ------
    InputError
        ``--out PATH: is a folder, not a file`` (also for a path ending in a separator),
        or as `check_output_folder` for the folder it goes in.
    """
    shown = f"{option} {path}"
    if str(path).endswith(("/", os.sep)) or Path(path).is_dir():
        raise InputError(f"{shown}: is a folder, not a file")
    path = Path(path)
    _check_folder(path.parent, shown, path)
    return path


def atomic_write(path: str | Path, write: Callable[[str], object]) -> Path:
    """Write `path` through a temporary file in its folder, then move it into place.

    The folder is created when missing; the file gets the permissions the umask allows
    (not mkstemp's 0600), and its path is appended to `WRITTEN`. If `write` fails, the
    temporary file is removed, any existing file at `path` is left as it was, and the
    error propagates.

    Parameters
    ----------
    path : str or Path
        The file to write.
    write : callable
        Called with the temporary file's name (str); writes the whole content there.

    Returns
    -------
    Path
        The path written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(handle)
    try:
        write(temp)
        os.chmod(temp, 0o666 & ~_UMASK)  # mkstemp makes 0600; results are for sharing
        os.replace(temp, path)
        WRITTEN.append(path)
    except BaseException:
        Path(temp).unlink(missing_ok=True)
        raise
    return path


def write_json(path: str | Path, data: object) -> Path:
    """Write `data` as indented JSON (keys in their given order) and a final newline, atomically.

    Parameters
    ----------
    path : str or Path
        The file to write.
    data : object
        Anything `json.dump` accepts.

    Returns
    -------
    Path
        The path written.
    """

    def write(temp):
        with open(temp, "w") as stream:
            json.dump(data, stream, indent=2, sort_keys=False)
            stream.write("\n")

    return atomic_write(path, write)


def write_npz(path: str | Path, arrays: Mapping[str, Any]) -> Path:
    """Write arrays to a compressed NumPy .npz, atomically.

    Parameters
    ----------
    path : str or Path
        The file to write.
    arrays : mapping of str to array
        The arrays by name (any shapes and units).

    Returns
    -------
    Path
        The path written.
    """

    def write(temp):
        with open(temp, "wb") as stream:
            np.savez_compressed(stream, **arrays)

    return atomic_write(path, write)


def save_figure(path: str | Path, figure: Figure) -> Path:
    """Save a matplotlib Figure (PNG unless the suffix says otherwise), atomically.

    Parameters
    ----------
    path : str or Path
        The file to write; its suffix names the format (110 dpi).
    figure : matplotlib.figure.Figure
        The figure.

    Returns
    -------
    Path
        The path written.
    """

    def write(temp):
        figure.savefig(temp, format=Path(path).suffix.lstrip(".") or "png", dpi=110)

    return atomic_write(path, write)


def write_text(path: str | Path, text: str) -> Path:
    """Write a text file, atomically.

    Parameters
    ----------
    path : str or Path
        Where; missing folders are made.
    text : str
        Its whole content.

    Returns
    -------
    Path
        The path written.
    """

    def write(temp):
        Path(temp).write_text(text)

    return atomic_write(path, write)


def write_diagram_graph(out_dir: str | Path, diagram: Any) -> Path:
    """The wired diagram as Drake draws it (GetGraphvizString): diagram.svg where Graphviz's
    `dot` is installed, else diagram.dot. Returns the path written.

    Parameters
    ----------
    out_dir : str or Path
        The folder to write into.
    diagram : pydrake.systems.framework.Diagram
        The built diagram, drawn to depth 1.

    Returns
    -------
    Path
        The path written.
    """
    import shutil
    import subprocess

    dot = diagram.GetGraphvizString(max_depth=1)
    if shutil.which("dot"):
        svg = subprocess.run(
            ["dot", "-Tsvg"], input=dot, capture_output=True, text=True, check=True
        )
        return write_text(Path(out_dir) / "diagram.svg", svg.stdout)
    return write_text(Path(out_dir) / "diagram.dot", dot)
