"""Running a sweep (`hlcmp sweep`): plan its tasks, skip the finished ones, run the rest on
an engine, and keep sweep.csv, sweep.json and one plot per swept parameter current.

A task is finished when its run folder OUT/tasks/ID holds a metrics.json (written last and
atomically by the runner) beside a scenario.yaml equal to the task's scenario, and the
files its metrics read (metrics.json, timeseries.npz) can be read; a folder whose
scenario.yaml differs (the sweep or its scenario was edited since), or whose files are
missing or unreadable, runs again.
sweep.csv and sweep.json are rewritten atomically after every finished task, so an
interrupted sweep loses none, and the same command again runs only what is missing.

Engines. `local` (the default, nothing extra needed): a `concurrent.futures`
ProcessPoolExecutor whose workers are forked from a fork server that has imported what a
task needs, never from the sweep's own process (whose threads a fork would copy broken).
`ray` (``pip install -e '.[ray]'``): a Ray task per sweep task, on a local Ray instance or
on the cluster at `address`; the worker returns the run folder's files and this process
writes them, so the nodes need the package installed but no shared file system. Either
way a task travels as plain text (its scenario's YAML and its overrides) and each worker
builds its own diagram.

Modules: `planning` (the tasks from the sweep file, which are finished), `tasks` (one task,
in whatever process runs it), `engines` (local, ray), `results` (a task's metric values,
sweep.json and sweep.csv) and `orchestrate` (`run_sweep`, which ties them together). The
names used elsewhere are imported from here.
"""

from hlcmp_drake.run.sweep.engines import ENGINES, check_engine
from hlcmp_drake.run.sweep.orchestrate import run_sweep
from hlcmp_drake.run.sweep.planning import SweepPlan, default_out_dir, plan_sweep, task_state
from hlcmp_drake.run.sweep.results import SweepResult
from hlcmp_drake.run.sweep.task_results import FINISHED, TaskResults, read_task_results
from hlcmp_drake.run.sweep.tasks import run_task, run_task_returning_files, store_files

__all__ = [
    "ENGINES",
    "FINISHED",
    "SweepPlan",
    "SweepResult",
    "TaskResults",
    "check_engine",
    "default_out_dir",
    "plan_sweep",
    "read_task_results",
    "run_sweep",
    "run_task",
    "run_task_returning_files",
    "store_files",
    "task_state",
]
