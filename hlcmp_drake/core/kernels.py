"""The controller tick's numeric kernels, compiled by numba where it is installed (the
``fast`` extra), plain numpy otherwise.

The equations stay where they are (`control_law`, `adaptation`, `dmp`, `duan2018`,
`task_space`, `laws`), each one plain function over arrays, written in the subset of numpy
that numba compiles in nopython mode. `jitable` marks such a function: called from Python
it is the function itself, unchanged (the numpy path); called from a compiled function,
numba compiles it inline. `implementation` gives a composed function (a law's command, the
task-space terms) as the one or the other, so both paths run the same source and a tick
makes a handful of compiled calls instead of about 80 numpy operations on 3- and
7-vectors. A few operations, not equations, have a second implementation for the compiled
path (`compiled_by`): `small_linalg`'s products and solves as plain loops, where numba's
BLAS and LAPACK calls cost more than the arithmetic of a 7x7 system.

Which path: `kernel_path` -- the one asked for, else the environment variable
``HLCMP_KERNEL`` (``compiled`` or ``numpy``), else compiled when numba imports. numba is
imported only when a path is chosen (its import takes about a second): a command that
makes no tick does not pay for it.

Where the machine code is kept: `kernel_cache_folder`, one folder per version of `core`'s
sources as the process imported them. numba's own cache checks only the file of the
function it compiles, not the files of the jitable functions inlined into it, so an
equation edited in `control_law` would otherwise still run its old machine code inside
`laws`' kernels.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Callable, TypeVar

KERNEL_VARIABLE = "HLCMP_KERNEL"
PATHS = ("compiled", "numpy")
# Every jitable function is defined in this package (`core`), so its sources are all a
# kernel's machine code depends on (tests/test_core_kernels.py checks it).
CORE_DIR = Path(__file__).parent

F = TypeVar("F", bound=Callable)
_log = logging.getLogger(__name__)
_compiled: dict[Callable, Callable] = {}
_jitable: list[Callable] = []  # marked, not yet registered with numba
_compiled_by: list[tuple[Callable, Callable]] = []  # (function, numba typing), not yet registered
_numba: list[Any] = []  # the numba module once imported, or None where it cannot be


def jitable(func: F) -> F:
    """Mark an equation's function as compilable inside a kernel; it stays the same Python
    function for Python callers.

    Parameters
    ----------
    func : callable
        A plain function over floats and float arrays, in numba's nopython subset.

    Returns
    -------
    callable
        `func` itself.
    """
    _jitable.append(func)
    if _numba and _numba[0] is not None:
        _register_marked()
    return func


def compiled_by(typing: Callable) -> Callable[[F], F]:
    """Mark a numpy helper whose compiled path is another implementation of the same
    operation (not an equation: a dense solve, say), for where numba's own compilation of
    the numpy call is slow; Python callers get the function itself, unchanged.

    Parameters
    ----------
    typing : callable
        Called by numba with the arguments' numba types (same parameters as the marked
        function); returns the plain-loop function numba compiles in its place.

    Returns
    -------
    callable
        The decorator.
    """

    def mark(func: F) -> F:
        _compiled_by.append((func, typing))
        if _numba and _numba[0] is not None:
            _register_marked()
        return func

    return mark


def _register_marked() -> None:
    from numba.extending import overload, register_jitable

    while _jitable:
        register_jitable(_jitable.pop())
    while _compiled_by:
        func, typing = _compiled_by.pop()
        overload(func)(typing)


def numba_available() -> bool:
    """Whether numba imports (the compiled path can run); imports it the first time."""
    if not _numba:
        try:
            import numba
        except ImportError:  # numba is optional: the numpy path
            _numba.append(None)
        else:
            # The environment's now, not numba's config, which numba read when imported
            # (perhaps in a sweep's fork server, before the variable changed).
            user_folder = os.environ.get("NUMBA_CACHE_DIR") or None
            # numba's config module sets its attributes at run time (no stub knows them)
            setattr(numba.config, "CACHE_DIR", str(kernel_cache_folder(user_folder)))  # noqa: B010
            _numba.append(numba)
            _register_marked()
    return _numba[0] is not None


def prepare_compiler() -> None:
    """Set numba's compiler up now (its target's registries, about a quarter of a second a
    process), as a process's first compiled call would: in the local engine's fork server,
    so that the workers forked from it start with it done. Nothing without numba or with
    ``HLCMP_KERNEL=numpy``; and it never raises: a fork server that raised while it imports
    would take every task with it, where a worker that meets the same problem fails its
    task in one line."""
    if os.environ.get(KERNEL_VARIABLE) == "numpy":
        return
    try:
        if numba_available():
            _numba[0].njit(_next_float)(0.0)  # a function of its own: no kernel's cache read
    except Exception as problem:  # e.g. no home folder for the kernels' cache
        _log.debug("numba's compiler not set up in advance: %s", problem)


def _next_float(x: float) -> float:
    return x + 1.0


def sources_digest(sources: Path = CORE_DIR) -> str:
    """A hash of every Python file of `sources` (name and bytes).

    Parameters
    ----------
    sources : Path
        The package of the jitable functions.

    Returns
    -------
    str
        Hex digits.
    """
    digest = hashlib.sha256()
    for path in sorted(sources.glob("*.py")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


# core's sources as this process imports them: core's modules are imported together, and a
# process that outlives an edit (a notebook, a sweep's fork server) keeps compiling the
# equations it imported, whose machine code must not be filed under the edited sources.
IMPORTED_SOURCES_DIGEST = sources_digest()


def kernel_cache_folder(base: str | Path | None = None, digest: str | None = None) -> Path:
    """The folder numba keeps the kernels' machine code in: under `base` (default the
    user's cache, ``$XDG_CACHE_HOME`` or ~/.cache, then hlcmp_drake), named by the hash of
    core's sources as this process imported them (`IMPORTED_SOURCES_DIGEST`), so that an
    edit of any equation gets newly compiled kernels (older folders stay until removed;
    each is a few MB).

    Parameters
    ----------
    base : str or Path, optional
        Where the folders go (``NUMBA_CACHE_DIR`` when the user set it).
    digest : str, optional
        Another `sources_digest` (default the imported sources').

    Returns
    -------
    Path
    """
    if base is None:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "hlcmp_drake"
    return Path(base) / f"numba-{(digest or IMPORTED_SOURCES_DIGEST)[:16]}"


def kernel_path(requested: str | None = None) -> str:
    """The path a tick built now runs: ``compiled`` or ``numpy``.

    Parameters
    ----------
    requested : str, optional
        ``compiled``, ``numpy`` or None (then ``HLCMP_KERNEL``, then compiled when numba
        is installed).

    Returns
    -------
    str

    Raises
    ------
    ValueError
        For a path not in `PATHS`, or ``compiled`` without numba.
    """
    path = requested or os.environ.get(KERNEL_VARIABLE) or None
    if path is None:
        return "compiled" if numba_available() else "numpy"
    if path not in PATHS:
        raise ValueError(f"{KERNEL_VARIABLE}={path!r}: expected one of {', '.join(PATHS)}")
    if path == "compiled" and not numba_available():
        raise ValueError(
            f"{KERNEL_VARIABLE}=compiled needs numba (pip install 'hlcmp_drake[fast]')"
        )
    return path


@contextlib.contextmanager
def kernel_chosen(path: str) -> Iterator[None]:
    """Within the block, what is made runs `path` (``HLCMP_KERNEL`` set, then restored): to
    build both paths in one process.

    Parameters
    ----------
    path : str
        ``compiled`` or ``numpy``.
    """
    kernel_path(path)  # refuses an unknown path, or compiled without numba
    before = os.environ.get(KERNEL_VARIABLE)
    os.environ[KERNEL_VARIABLE] = path
    try:
        yield
    finally:
        if before is None:
            del os.environ[KERNEL_VARIABLE]
        else:
            os.environ[KERNEL_VARIABLE] = before


def implementation(func: F, path: str) -> F:
    """A composed function on the given path: itself (numpy), or compiled by numba in
    nopython mode (once per process, its machine code cached in `kernel_cache_folder`).

    Parameters
    ----------
    func : callable
        A module-level function that calls only `jitable` functions and numba's numpy.
    path : str
        ``compiled`` or ``numpy`` (see `kernel_path`).

    Returns
    -------
    callable
    """
    if path == "numpy":
        return func
    if func not in _compiled:
        assert numba_available(), "kernel_path refuses 'compiled' without numba"
        folder = Path(_numba[0].config.CACHE_DIR)
        if not _compiled and not folder.exists():  # said once a process, before the wait
            _log.info(
                "hlcmp: compiling the controller's kernels with numba, once for this version of "
                "hlcmp_drake/core (kept in %s): this run takes longer, by tens of seconds",
                folder,
            )
        _compiled[func] = _numba[0].njit(cache=True)(func)
    return _compiled[func]  # type: ignore[return-value]
