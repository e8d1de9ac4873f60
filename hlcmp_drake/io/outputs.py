"""Writing results so that nothing already in the output folder is lost or half-written:
every file goes to a temporary name in the same folder and is moved into place.

`check_output_folder` and `check_output_file` say before any work whether a command's
output path can be written at all (a file where a folder is needed, a folder where a
file is needed, a folder that cannot be created or written in), as one InputError.

`replacing_outputs` makes a reused output folder hold only what the last command wrote
there: each command lists the files it wrote in the folder's manifest (MANIFEST), and the
next one removes the files of that list it did not write again. A file is removed only
when this tool's own manifest names it, so a user's files in the folder are never
touched, whatever their names.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hlcmp_drake.io.errors import InputError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

_UMASK = os.umask(0)
os.umask(_UMASK)
WRITTEN: list[Path] = []  # every path written in this process, in order (for the interrupt message)
# The list of the files the last command wrote in an output folder (relative POSIX paths).
MANIFEST = ".hlcmp-outputs.json"
# The names the commands that write a folder give their files, wherever in it (a report's
# per-scenario folders too), besides everything under a figures/ folder: what an input of
# the command must not be called inside its --out (tests/test_cli.py checks each command's
# files against it).
OUTPUT_NAMES = frozenset(
    {
        MANIFEST,
        "scenario.yaml",
        "metrics.json",
        "timeseries.npz",
        "recording.html",
        "diagram.svg",
        "diagram.dot",
        "skill.npz",
        "serve.json",
        "probe.json",
        "probe.npz",
        "probe.png",
        "index.html",
    }
)

# The suffixes of the files this tool writes. A new output folder whose name ends in one is
# a file's name given where a command writes a folder (`learn --out skill.npz` after `fit
# --out skill.npz`): it would become a folder of that name, which later reads as a file.
FILE_SUFFIXES = frozenset({".npz", ".csv", ".json", ".yaml", ".html", ".png", ".svg", ".dot"})


def is_output_name(relative: str | Path) -> bool:
    """Whether a path inside an output folder is one the folder commands may write there.

    Parameters
    ----------
    relative : str or Path
        Relative to the output folder.

    Returns
    -------
    bool
    """
    parts = Path(relative).parts
    return bool(parts) and (parts[-1] in OUTPUT_NAMES or "figures" in parts[:-1])


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


def _inside(folder: Path, path: str | Path) -> str | None:
    """`path` relative to `folder` as a POSIX string, or None when it is not inside it."""
    relative = os.path.relpath(os.path.abspath(path), os.path.abspath(folder))
    if relative == os.curdir or relative.split(os.sep)[0] == os.pardir:
        return None
    return Path(relative).as_posix()


def listed_outputs(out_dir: str | Path) -> set[str]:
    """The files the folder's manifest says this tool wrote there (relative POSIX paths).

    Anything doubtful counts as not listed: no manifest, one that cannot be read or is not
    this tool's list, entries that are absolute or climb out of the folder.

    Parameters
    ----------
    out_dir : str or Path
        An output folder.

    Returns
    -------
    set of str
    """
    try:
        data = json.loads((Path(out_dir) / MANIFEST).read_text())
    except (OSError, ValueError):
        return set()
    files = data.get("files") if isinstance(data, dict) and data.get("tool") == "hlcmp" else None
    if not isinstance(files, list):
        return set()
    return {
        name
        for name in files
        if isinstance(name, str)
        and name
        and not Path(name).is_absolute()
        and os.pardir not in Path(name).parts
        and name != MANIFEST
    }


def _remove_listed(out_dir: Path, name: str) -> bool:
    """Remove out_dir/name if it is a regular file whose folders inside out_dir are real
    folders (no symbolic link is followed or removed), then the folders it leaves empty."""
    path = out_dir / name
    real_dir = os.path.realpath(out_dir)
    if (
        path.is_symlink()
        or not path.is_file()
        or os.path.dirname(os.path.realpath(path)) != os.path.join(real_dir, *Path(name).parts[:-1])
    ):
        return False
    path.unlink()
    for folder in path.parents:
        if folder == out_dir or _inside(out_dir, folder) is None:
            break
        try:
            folder.rmdir()  # only when empty
        except OSError:
            break
    return True


def _write_manifest(out_dir: Path, files: Iterable[str]) -> None:
    write_json(out_dir / MANIFEST, {"tool": "hlcmp", "files": sorted(set(files) - {MANIFEST})})


@contextlib.contextmanager
def folder_locked(out_dir: str | Path) -> Iterator[None]:
    """Around a whole command that writes into `out_dir`: no other command of this tool
    writes there meanwhile (two runs into one folder at once left one's files mixed with
    the other's). The lock is an flock on a file of its own outside the folder (in the
    system's temporary folder, named by the folder's resolved path), so the folder itself
    holds nothing of it; the file goes when the command ends, and the system releases the
    lock if the process dies.

    Parameters
    ----------
    out_dir : str or Path
        The output folder (it need not exist yet).

    Yields
    ------
    None

    Raises
    ------
    InputError
        When another process holds the folder, with its process id.
    """
    key = hashlib.sha256(str(Path(out_dir).resolve()).encode()).hexdigest()[:24]
    locks = Path(tempfile.gettempdir()) / "hlcmp-locks"
    locks.mkdir(exist_ok=True)
    path = locks / f"{key}.lock"
    while True:
        handle = open(path, "a+")  # held for the whole command, closed below
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "?"
            handle.close()
            raise InputError(
                f"--out {out_dir}: another hlcmp command (process {holder}) is writing there "
                "now: wait for it to end, or give another --out"
            ) from None
        try:  # the file locked must still be the one named: its last holder removes it
            if os.stat(path).st_ino == os.fstat(handle.fileno()).st_ino:
                break
        except FileNotFoundError:
            pass
        handle.close()
    try:
        handle.seek(0)
        handle.truncate()
        handle.write(str(os.getpid()))
        handle.flush()
        yield
    finally:
        path.unlink(missing_ok=True)  # before the lock goes: a waiting opener then retries
        fcntl.flock(handle, fcntl.LOCK_UN)
        handle.close()


@contextlib.contextmanager
def replacing_outputs(out_dir: str | Path, keep: Iterable[str | Path] = ()) -> Iterator[None]:
    """Around a command's writes into `out_dir`: when they all succeed, remove the files
    the previous command listed in the folder's manifest that this one did not write
    again, and list this command's files (those written through this module under
    `out_dir`, also in subfolders) in a new manifest.

    Only files the manifest lists are ever removed, and only regular files (not symbolic
    links); folders they leave empty go too. If the writes fail or are interrupted,
    nothing is removed and the manifest lists the old files and the new ones.

    Parameters
    ----------
    out_dir : str or Path
        The output folder.
    keep : iterable of str or Path, optional
        Files never removed, e.g. the command's own input (a skill replayed from the
        folder it writes to).

    Yields
    ------
    None
    """
    out_dir = Path(out_dir)
    previous = listed_outputs(out_dir)
    start = len(WRITTEN)

    def written() -> set[str]:
        names = {_inside(out_dir, path) for path in WRITTEN[start:]}
        return {name for name in names if name is not None} - {MANIFEST}

    try:
        yield
    except BaseException:
        if written():
            _write_manifest(out_dir, previous | written())
        raise
    new = written()
    if not new:  # a command that wrote nothing here leaves the folder as it was
        return
    kept = {_inside(out_dir, path) for path in keep}
    _replace_listed(out_dir, previous, new, kept)


def _replace_listed(out_dir: Path, previous: set[str], new: set[str], kept: set) -> None:
    """Remove the files of `previous` not in `new` or `kept`, then list `new` alone."""
    for name in sorted(previous - new - kept):
        _remove_listed(out_dir, name)
    _write_manifest(out_dir, new)


def list_outputs(out_dir: str | Path, files: Iterable[str | Path]) -> None:
    """List `files` as the folder's outputs, for a command that writes some of its files
    there as its own and leaves others to theirs (a sweep: its tables and plots, not its
    tasks' run folders): the files the previous list names and `files` do not are removed
    (as `replacing_outputs` removes them), and the new list names `files` alone.

    Parameters
    ----------
    out_dir : str or Path
        The output folder.
    files : iterable of str or Path
        The files the command wrote there (paths outside it are ignored).
    """
    out_dir = Path(out_dir)
    names = {_inside(out_dir, path) for path in files}
    _replace_listed(out_dir, listed_outputs(out_dir), {n for n in names if n is not None}, set())
