"""The engines a sweep's tasks run on: `local`, a process pool whose workers end with the
sweep's process (each watches it), and `ray`, a Ray task per sweep task. Each hands every
finished task to an `on_done` callback as it comes.

The local workers are forked from a fork server (a fresh interpreter that has imported what
a task needs, `WORKER_IMPORTS`, and started no thread of Drake's), not spawned: a spawned
worker spends about a second a worker importing pydrake, numba and matplotlib before its
first task, a forked one nothing (docs/performance.md, "The test suite"). They are spawned
elsewhere than on Linux, and for a pool made after a variable those imports read has
changed (`IMPORT_TIME_VARIABLES`). Either way no worker is a fork of the sweep's own
process, whose Meshcat, LCM or Ray threads a fork would copy in a broken state."""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import multiprocessing.util
import os
import select
import shutil
import signal
import sys
import tempfile
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Callable, Iterator

from hlcmp_drake.config.sweep import SweepTask
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.run.sweep.tasks import (
    quiet_drake,
    run_task,
    run_task_returning_files,
    store_files,
)

ENGINES = ("local", "ray")
# What every task imports (the tasks of a sweep, a library and a report, and what they
# import lazily: numba for the tick, matplotlib for the figures), imported once in the fork
# server. A module that is not installed is skipped there (numba is an optional extra).
WORKER_IMPORTS = (
    "hlcmp_drake.run.sweep.tasks",
    "hlcmp_drake.run.library",
    "hlcmp_drake.run.report",
    "numba",
    "matplotlib.backends.backend_agg",
    "hlcmp_drake.run.sweep.worker_start",
)


def _local_worker_init(parent: int, environment: dict) -> None:
    """In each local worker: the environment of the sweep's process when it made the pool
    (a forked worker has the fork server's, from when that started); Ctrl-C is the
    parent's to handle (it stops the workers); and the worker ends with the sweep's process
    `parent`, even one killed outright, so no orphan goes on running tasks that a re-run
    would start again."""
    os.environ.clear()
    os.environ.update(environment)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _end_with_parent(parent)
    quiet_drake()


def _end_with_parent(parent: int) -> None:
    """Linux: end this worker when the sweep's process `parent` ends, even killed outright.
    A thread waits on the process's pidfd and exits the worker at once; the kernel's
    parent-death signal (prctl PR_SET_PDEATHSIG) alone would not do, as a forked worker's
    parent is the fork server, which lives as long as any worker does. Elsewhere, nothing:
    an orphan finishes its tasks."""
    if not sys.platform.startswith("linux"):
        return
    try:
        watched: int | None = os.pidfd_open(parent)
    except ProcessLookupError:  # the sweep ended before this worker started
        os._exit(1)
    except (AttributeError, OSError):  # a kernel before 5.3: look twice a second instead
        watched = None

    def exit_when_it_ends() -> None:
        if watched is not None:
            select.select([watched], [], [])
        else:
            while _alive(parent):
                time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=exit_when_it_ends, name="sweep-watch", daemon=True).start()


def _alive(pid: int) -> bool:
    """Whether process `pid` runs (a zombie, ended but not yet collected, does not)."""
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, PermissionError):  # gone, or its number taken by another's
        return False
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:  # no /proc to tell a zombie by
        return True
    return stat.rpartition(")")[2].split()[0] not in ("Z", "X")


# Environment variables the fork server's imports read when imported (numba's, matplotlib's,
# the BLAS thread pools', Drake's; the cache folders matplotlib and the kernels' compiler,
# set up there, take from XDG_CACHE_HOME or HOME): a pool made after one of them changed is
# spawned, so that its workers import under the new value, as they would in a new process.
IMPORT_TIME_VARIABLES = ("NUMBA_", "MPL", "OMP_", "OPENBLAS_", "MKL_", "DRAKE_", "XDG_", "HOME")
_fork_server_environment: list[dict] = []  # those variables when the fork server started


def _import_time_environment() -> dict:
    return {k: v for k, v in os.environ.items() if k.startswith(IMPORT_TIME_VARIABLES)}


def _worker_context() -> multiprocessing.context.BaseContext:
    """On Linux the fork server's context, with `WORKER_IMPORTS` to import when it starts
    (once a process); spawn where the variables its imports read have changed since it
    started (`IMPORT_TIME_VARIABLES`), and elsewhere than on Linux, as macOS's system
    libraries are not safe to use in a fork of a process that has loaded them, and Windows
    has no fork server."""
    if not sys.platform.startswith("linux"):
        return multiprocessing.get_context("spawn")
    if not _fork_server_environment:
        _fork_server_environment.append(_import_time_environment())
        multiprocessing.get_context("forkserver").set_forkserver_preload(list(WORKER_IMPORTS))
        _start_fork_server()
    elif _import_time_environment() != _fork_server_environment[0]:
        return multiprocessing.get_context("spawn")
    return multiprocessing.get_context("forkserver")


def _start_fork_server() -> None:
    """Start the fork server with Ctrl-C ignored from its first instruction (inherited
    through exec, which Python keeps): while it imports `WORKER_IMPORTS` it would
    otherwise print a KeyboardInterrupt's traceback of its own under the sweep's one-line
    message. Only the main thread may set a signal's handler; elsewhere it starts as it
    is."""
    from multiprocessing import forkserver

    if threading.current_thread() is not threading.main_thread():
        forkserver.ensure_running()
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)


Done = Callable[[SweepTask, "dict | None", "str | None"], None]


def run_in_processes(
    function: Callable,
    items: list,
    workers: int,
    on_done: Callable[[object, object, str | None], None],
) -> None:
    """`function(item)` for each item in a pool of `workers` local processes (the local
    engine, forked from the fork server: `_worker_context`), each result handed to
    `on_done(item, result, error)` as it finishes, with error None or the task's failure in
    one line. The workers end with this process; an interrupt cancels the queue and
    terminates them.

    A worker that dies (killed, out of memory, a crash in C++) breaks its pool, and the
    pool fails every task it had not finished. Those that had not started go on in a new
    pool; each that had started runs again alone, so that the one that kills its worker
    again fails by itself ("its worker process died (killed by SIGKILL)") and a task that
    only shared the pool is not lost. A pool whose workers die before any task runs fails
    every task left (`NO_TASK_RAN`): a new pool would die the same way.

    Parameters
    ----------
    function : callable
        A module-level function (the workers import it).
    items : list
        Its arguments, one per task, picklable.
    workers : int
        The number of processes.
    on_done : callable(item, result, error)
    """
    # In multiprocessing's own temporary folder, which it removes when this process ends.
    marks = Path(tempfile.mkdtemp(prefix="workers-", dir=multiprocessing.util.get_temp_dir()))
    try:
        queue = list(range(len(items)))
        while queue:
            broken = _pool_round(function, items, queue, workers, on_done, marks)
            if broken is None:
                return
            started, unstarted = broken
            if not started and len(unstarted) == len(queue):  # none ran: nor would they again
                for index in unstarted:
                    on_done(items[index], None, NO_TASK_RAN)
                return
            queue = unstarted
            for index in started:
                alone = _pool_round(function, items, [index], 1, on_done, marks)
                if alone is not None:
                    on_done(items[index], None, f"its worker process died ({alone[1]})")
    finally:
        shutil.rmtree(marks, ignore_errors=True)


# Why every task of a pool failed whose workers all died before any task ran.
NO_TASK_RAN = (
    "the pool's workers died before any task ran (one cause: a script that starts them at "
    "its top level, not under if __name__ == '__main__':, which each worker imports again)"
)


def _marked_call(function: Callable, marks: str, index: int, item):
    """In a worker: `function(item)`, with a file named by the worker's pid holding `index`
    while it runs, so that the pool's owner knows which tasks had started if it breaks."""
    mark = Path(marks) / str(os.getpid())
    mark.write_text(str(index))
    try:
        return function(item)
    finally:
        mark.unlink()


def _pool_round(function, items, indices, workers, on_done, marks):
    """The tasks `indices` in one pool of `workers` (`run_in_processes`): None when the pool
    held to the end; else, when a worker died, (the indices that had started and not
    finished, those that had not started) -- or, for a pool of one, (the index, how its
    worker ended)."""
    executor = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=_worker_context(),
        initializer=_local_worker_init,
        initargs=(os.getpid(), dict(os.environ)),
    )
    failed: list[int] = []
    try:
        futures = {}
        for index in indices:
            try:
                futures[
                    executor.submit(_marked_call, function, str(marks), index, items[index])
                ] = index
            except BrokenProcessPool:  # a worker died while the tasks were handed out
                failed.append(index)
        processes = list((getattr(executor, "_processes", None) or {}).values())
        for future in as_completed(futures):
            index = futures[future]
            try:
                result, error = future.result(), None
            except BrokenProcessPool:  # a worker died: the pool fails what it had not done
                failed.append(index)
                continue
            except Exception as failure:  # the task's own error: record it, go on
                result, error = None, " ".join(f"{type(failure).__name__}: {failure}".split())
            on_done(items[index], result, error)
    except BaseException:
        _stop_pool(executor)
        raise
    executor.shutdown()
    if not failed:
        return None
    running = set()
    for mark in marks.iterdir():  # the dead worker's, and those the broken pool ended
        with contextlib.suppress(ValueError):  # one ended while it wrote its mark
            running.add(int(mark.read_text()))
        mark.unlink()
    if workers == 1 and len(indices) == 1:
        return indices, _how_it_ended(processes)
    ordered = sorted(failed)
    return [i for i in ordered if i in running], [i for i in ordered if i not in running]


def _how_it_ended(processes: list) -> str:
    """How a pool's dead worker ended, e.g. "killed by SIGKILL" or "exit code 3"."""
    codes = [p.exitcode for p in processes if p.exitcode not in (None, 0)]
    if not codes:
        return "ended"
    if codes[0] < 0:
        with contextlib.suppress(ValueError):
            return f"killed by {signal.Signals(-codes[0]).name}"
    return f"exit code {codes[0]}"


def _run_local(tasks: list, workers: int, on_done: Done) -> None:
    """The sweep's tasks on the local engine (`run_in_processes`)."""
    run_in_processes(run_task, tasks, workers, on_done)


def _stop_pool(executor: ProcessPoolExecutor) -> None:
    processes = list((getattr(executor, "_processes", None) or {}).values())
    executor.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
    for process in processes:
        process.join(timeout=5)


def check_engine(engine: str, workers: int | None, address: str | None) -> None:
    """Refuse, in one line, an unknown engine, an address without Ray, fewer than one
    worker, or Ray when it is not installed -- before anything is written.

    Parameters
    ----------
    engine : str
        "local" or "ray".
    workers : int or None
    address : str or None

    Raises
    ------
    InputError
    """
    if engine not in ENGINES:
        raise InputError(f"--engine: must be one of {', '.join(ENGINES)}, got '{engine}'")
    if address and engine != "ray":
        raise InputError("--address: joins a Ray cluster, so it needs --engine ray")
    if workers is not None and workers < 1:
        raise InputError(f"--workers: must be at least 1, got {workers}")
    if engine == "ray":
        _import_ray()


def _import_ray():
    try:
        import ray
    except ImportError:
        raise InputError(
            "--engine ray needs Ray, which is not installed: pip install -e '.[ray]'"
        ) from None
    return ray


def _init_ray(ray, workers: int | None, address: str | None) -> None:
    """Join the Ray cluster at `address`, else start a local one of `workers` CPUs (default
    one per CPU); InputError when there is no cluster at `address`."""
    options = (
        {"address": address}
        if address
        else {"num_cpus": workers or os.cpu_count() or 1, "include_dashboard": False}
    )
    try:
        ray.init(logging_level=logging.WARNING, **options)
    except (ConnectionError, ValueError) as error:  # ValueError: not an address at all
        raise InputError(
            f"--address {address}: cannot join a Ray cluster there "
            f"({' '.join(str(error).split())[:200]})"
        ) from None


@contextlib.contextmanager
def cluster_joined(engine: str, address: str | None) -> Iterator[None]:
    """For a Ray engine with an `address`: the cluster joined for the length of the block
    (so that an address with no cluster is refused before anything is run or written),
    and left at its end; otherwise nothing (a local Ray starts when there are tasks).

    Parameters
    ----------
    engine : str
        "local" or "ray".
    address : str or None
        The Ray cluster to join.

    Raises
    ------
    InputError
        There is no cluster at `address`.
    """
    if engine != "ray" or not address:
        yield
        return
    ray = _import_ray()
    if ray.is_initialized():
        yield
        return
    _init_ray(ray, None, address)
    try:
        yield
    finally:
        ray.shutdown()


def run_on_ray(
    function: Callable,
    items: list,
    workers: int | None,
    on_done: Callable[[object, object, str | None], None],
    address: str | None = None,
) -> None:
    """`function(item)` for each item as a Ray task (one CPU each), at most `workers` in
    flight, each result handed to `on_done(item, result, error)` as it finishes, with
    error None or the task's failure in one line (the Ray engine). Joins the Ray instance
    already initialized in this process, else the cluster at `address`, else starts a
    local one (`workers` CPUs, default one per CPU) and shuts it down at the end; an
    interrupt cancels the tasks in flight.

    Parameters
    ----------
    function : callable
        A module-level function (the workers import it).
    items : list
        Its arguments, one per task, picklable.
    workers : int, optional
        Tasks in flight at once (default: all of them; Ray schedules them on its CPUs).
    on_done : callable(item, result, error)
    address : str, optional
        The Ray cluster to join (e.g. "ray://head:10001" or "auto").

    Raises
    ------
    InputError
        Ray is not installed, or there is no cluster at `address`.
    """
    ray = _import_ray()
    started = not ray.is_initialized()
    if started:
        _init_ray(ray, workers, address)
    remote = ray.remote(num_cpus=1)(function)
    queue, in_flight = list(items), {}
    limit = workers or len(items)
    try:
        while queue or in_flight:
            while queue and len(in_flight) < limit:
                item = queue.pop(0)
                in_flight[remote.remote(item)] = item
            (ref,), _ = ray.wait(list(in_flight), num_returns=1)
            item = in_flight.pop(ref)
            try:
                result = ray.get(ref)
            except Exception as failure:  # RayTaskError wraps the task's own error
                on_done(item, None, " ".join(str(failure).split())[-400:])
                continue
            on_done(item, result, None)
    except BaseException:
        for ref in in_flight:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started:
            ray.shutdown()


def _run_ray(
    tasks: list,
    workers: int | None,
    address: str | None,
    on_done: Done,
    returning_files: Callable = run_task_returning_files,
) -> None:
    """One Ray task per sweep task (`run_on_ray`); each runs `returning_files(task)` ->
    (info, files), whose files are stored in the task's run_dir."""

    def store_then_report(task, returned, error):
        if error is not None:
            on_done(task, None, error)
            return
        info, files = returned
        store_files(task.run_dir, files)
        on_done(task, info, None)

    run_on_ray(returning_files, tasks, workers, store_then_report, address)


@contextlib.contextmanager
def _terminate_is_interrupt():
    """While the sweep runs, SIGTERM (`kill`) stops it like Ctrl-C: the workers are
    stopped and every finished task is kept."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
