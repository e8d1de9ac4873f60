"""hlcmp_drake.run.sweep (`hlcmp sweep`): a task's state and values, the local engine runs a
tiny sweep and writes its table and plots, a re-run does only what is missing (after a
deleted result or a kill), the Ray engine, and the command line."""

import contextlib
import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import one_line_error, run_cli, tiny, write_sweep

from hlcmp_drake.config.loading import load_scenario_text
from hlcmp_drake.config.sweep import load_sweep, plan_tasks
from hlcmp_drake.core.kernels import numba_available
from hlcmp_drake.run.sweep import plan_sweep, read_task_results, run_sweep, task_state
from hlcmp_drake.run.sweep.engines import run_in_processes

# --- loading -------------------------------------------------------------------------


# --- tasks ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, count",
    [
        ("tiny", 2),
        ("one_dof_sensitivity", 18),
        ("insertion_learning_rate", 4),
        ("peg_rotational_q", 3),
    ],
)
def test_every_bundled_sweep_plans(tmp_path, name, count):
    plan = plan_sweep(name, tmp_path / name)
    assert len(plan.tasks) == count == len({t.id for t in plan.tasks})
    assert set(plan.states.values()) == {"pending"}
    assert plan.sweep.config.metrics
    if name == "insertion_learning_rate":
        rates = [
            load_scenario_text(t.scenario_yaml, t.scenario_path).controllers["hlcmp"]
            for t in plan.tasks
        ]
        assert [r.q_k[2] for r in rates] == [3000.0, 30000.0, 300000.0, 3000000.0]
        assert [r.q_v[0] / r.q_d[0] for r in rates] == [0.1] * 4
        assert all(t.claims and len(t.controllers) == 4 for t in plan.tasks)
    if name == "peg_rotational_q":
        learners = [
            load_scenario_text(t.scenario_yaml, t.scenario_path).controllers["hlcmp_6d"]
            for t in plan.tasks
        ]
        assert [c.q_kr for c in learners] == [[0.3] * 3, [3.0] * 3, [30.0] * 3]
        assert {c.q_dr[0] for c in learners} == {0.009}  # the rest as bundled
        assert all(not t.claims and t.controllers == ["hlcmp_6d"] for t in plan.tasks)


def test_the_bundled_rotational_q_sweep_reads_only_what_its_tasks_write(tmp_path):
    """Its per-axis paths name elements of the peg_in_hole metrics' 3-lists (a short run)."""
    from hlcmp_drake.run.sweep.planning import check_metrics

    check_metrics(plan_sweep("peg_rotational_q", tmp_path / "out"))
    assert not (tmp_path / "out").exists()


def test_a_task_is_done_only_beside_its_own_scenario(tmp_path):
    task = plan_tasks(load_sweep(tiny(tmp_path)), tmp_path / "out")[0]
    run_dir = Path(task.run_dir)
    run_dir.mkdir(parents=True)
    assert task_state(task, []) == "pending"
    (run_dir / "scenario.yaml").write_text(task.scenario_yaml)
    assert task_state(task, []) == "pending"  # started, never finished
    (run_dir / "metrics.json").write_text('{"status": "ok"}')
    assert task_state(task, []) == "done"
    (run_dir / "scenario.yaml").write_text(
        task.scenario_yaml.replace("duration_s: 0.1", "duration_s: 0.2")
    )
    assert task_state(task, []) == "stale"


def _finished_task_folder(tmp_path):
    """The tiny sweep's first task, its folder as the runner leaves it (the files its
    metrics read, made up), and the sweep's metrics."""
    sweep = load_sweep(tiny(tmp_path))
    task = plan_tasks(sweep, tmp_path / "out")[0]
    run_dir = Path(task.run_dir)
    run_dir.mkdir(parents=True)
    (run_dir / "scenario.yaml").write_text(task.scenario_yaml)
    metrics = {"status": "ok", "controllers": {"hlcmp": {"final_position_m": 0.03}}}
    (run_dir / "metrics.json").write_text(json.dumps(metrics))
    t = np.linspace(0.0, 0.1, 5)
    np.savez_compressed(run_dir / "timeseries.npz", t=t, **{"hlcmp/x": t, "hlcmp/Ks": t})
    return task, sweep.config.metrics


@pytest.mark.parametrize(
    "file, damage",
    [
        ("timeseries.npz", None),
        ("timeseries.npz", lambda data: data[: len(data) // 2]),
        ("timeseries.npz", lambda data: b"t,x\n0,1\n"),
        ("metrics.json", lambda data: data[: len(data) // 2]),
        ("metrics.json", lambda data: b"[1, 2]"),
        ("metrics.json", lambda data: b'{"controllers": {}}'),
        ("metrics.json", lambda data: b"\xff\xfe"),
    ],
    ids=["npz gone", "npz cut", "npz text", "json cut", "json list", "no status", "not utf-8"],
)
def test_a_task_whose_outputs_are_missing_or_unreadable_runs_again(tmp_path, file, damage):
    task, metrics = _finished_task_folder(tmp_path)
    assert task_state(task, metrics) == "done"
    assert read_task_results(task.run_dir, metrics).values["final x [m]"] == 0.03
    path = Path(task.run_dir) / file
    if damage is None:
        path.unlink()
    else:
        path.write_bytes(damage(path.read_bytes()))
    assert task_state(task, metrics) == "pending"
    assert read_task_results(task.run_dir, metrics) is None


def test_a_task_whose_model_or_demonstration_changed_is_stale(tmp_path):
    """scenario.yaml names its model files and its demonstration by path: a task is done
    only while their contents are the ones it ran with (inputs.sha256 beside it)."""
    from conftest import write_sweep

    from hlcmp_drake.config.sweep import INPUTS_FILE
    from hlcmp_drake.io.paths import DIAGRAMS_DIR, MODELS_DIR

    demo = tmp_path / "demo.csv"
    demo.write_bytes((DIAGRAMS_DIR / "demos" / "insertion_demo.csv").read_bytes())
    foam = tmp_path / "foam.sdf"
    foam.write_bytes((MODELS_DIR / "foam_plank.sdf").read_bytes())
    text = (DIAGRAMS_DIR / "insertion.yaml").read_text()
    text = text.replace("file: demos/insertion_demo.csv", "file: demo.csv")
    text = text.replace("package://hlcmp_drake/models/foam_plank.sdf", f"file://{foam}")
    (tmp_path / "mine.yaml").write_text(text)
    sweep = write_sweep(tmp_path, "scenario: mine.yaml\ngrid:\n  duration_s: [0.1]\n")
    task = plan_tasks(load_sweep(sweep), tmp_path / "out")[0]
    run_dir = Path(task.run_dir)
    run_dir.mkdir(parents=True)
    (run_dir / "scenario.yaml").write_text(task.scenario_yaml)
    (run_dir / INPUTS_FILE).write_text(task.inputs_digest + "\n")
    (run_dir / "metrics.json").write_text('{"status": "ok"}')
    assert task_state(task, []) == "done"
    for changed in (foam, demo):
        kept = changed.read_bytes()
        changed.write_bytes(kept + b"\n")  # the same path, another content
        again = plan_tasks(load_sweep(sweep), tmp_path / "out")[0]
        assert again.scenario_yaml == task.scenario_yaml and task_state(again, []) == "stale"
        changed.write_bytes(kept)
        assert task_state(plan_tasks(load_sweep(sweep), tmp_path / "out")[0], []) == "done"
    (run_dir / INPUTS_FILE).unlink()  # a folder from before the digest: its text decides
    assert task_state(task, []) == "done"


# --- results -------------------------------------------------------------------------


def test_metric_values_come_from_metrics_json_and_the_time_series(tmp_path):
    from hlcmp_drake.config.sweep import SweepMetric

    (tmp_path / "metrics.json").write_text(
        json.dumps(
            {
                "status": "ok",
                "controllers": {
                    "vic_fd_0.5": {"reach_time_s": None, "x": {"z": 0.25}, "tau": [0.1, 0.2]}
                },
                "claims": {"C5": {"holds": False}},
            }
        )
    )
    t = np.arange(0.0, 2.0, 0.5)
    np.savez(
        tmp_path / "timeseries.npz",
        t=t,
        **{
            "hlcmp/Ks": np.column_stack([t, -t]),
            "hlcmp/x": np.array([[0.4], [0.31], [0.29], [np.nan]]),
        },
    )
    metrics = [
        SweepMetric(label="reach", path="controllers.vic_fd_0.5.reach_time_s"),
        SweepMetric(label="z mm", path="controllers.vic_fd_0.5.x.z", scale=1000.0),
        SweepMetric(label="C5", path="claims.C5.holds"),
        SweepMetric(label="max Ks", series="hlcmp/Ks", reduce="max"),
        SweepMetric(label="max Ks early", series="hlcmp/Ks", reduce="max", window_s=[0.0, 0.6]),
        SweepMetric(label="min |Ks_y|", series="hlcmp/Ks", reduce="max_abs", column=1),
        SweepMetric(label="through", series="hlcmp/x", reduce="min", below=0.30),
        SweepMetric(label="last x", series="hlcmp/x", reduce="final"),
        SweepMetric(label="typo", path="controllers.vic_fd_0.5.nope"),
        SweepMetric(label="a dict", path="controllers.vic_fd_0.5.x"),
        SweepMetric(label="tau_y", path="controllers.vic_fd_0.5.tau.1", scale=10.0),
        SweepMetric(label="a list", path="controllers.vic_fd_0.5.tau"),
        SweepMetric(label="past its end", path="controllers.vic_fd_0.5.tau.2"),
        SweepMetric(label="no series", series="pid/Ks"),
    ]
    results = read_task_results(tmp_path, metrics)
    assert results.status == "ok"
    assert results.values == {
        "reach": None,
        "z mm": 250.0,
        "C5": False,
        "max Ks": 1.5,
        "max Ks early": 0.5,
        "min |Ks_y|": 1.5,
        "through": True,
        "last x": 0.29,
        "typo": None,
        "a dict": None,
        "tau_y": 2.0,
        "a list": None,
        "past its end": None,
        "no series": None,
    }
    assert results.missing == ["typo", "a dict", "a list", "past its end", "no series"]


# --- engines -------------------------------------------------------------------------


def _read_csv(path):
    with open(path) as stream:
        return list(csv.DictReader(stream))


@pytest.mark.slow  # a pool of two processes (about 2.1 s)
def test_the_local_engine_runs_a_tiny_sweep_and_a_rerun_skips_it(tmp_path):
    out = tmp_path / "out"
    result = run_sweep(tiny(tmp_path), out, workers=2)
    assert (
        sorted(result.ran) == ["pi=1.0", "pi=5.0"]
        and result.already_done == 0
        and not result.failed
    )
    rows = _read_csv(out / "sweep.csv")
    assert [(r["id"], r["controllers.hlcmp.pi"], r["status"]) for r in rows] == [
        ("pi=1.0", "1.0", "ok"),
        ("pi=5.0", "5.0", "ok"),
    ]
    for row in rows:  # the table's numbers are the task's own outputs
        run_dir = out / "tasks" / row["id"]
        with np.load(run_dir / "timeseries.npz") as arrays:
            assert float(row["x final [mm]"]) == pytest.approx(1000 * arrays["hlcmp/x"][-1, 0])
            assert float(row["max K_s [N/m]"]) == pytest.approx(np.nanmax(arrays["hlcmp/Ks"][:, 0]))
        metrics = json.loads((run_dir / "metrics.json").read_text())
        assert float(row["final x [m]"]) == metrics["controllers"]["hlcmp"]["final_position_m"]
        assert list(metrics["controllers"]) == ["hlcmp"]
        assert (run_dir / "scenario.yaml").is_file() and (run_dir / "recording.html").is_file()
    assert rows[0]["x final [mm]"] != rows[1]["x final [mm]"]  # pi changes the motion
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["counts"] == {"tasks": 2, "ok": 2, "unstable": 0, "error": 0, "pending": 0}
    assert (out / "plots" / "controllers.hlcmp.pi.png").stat().st_size > 10_000
    assert (
        result.table.headers[:2] == ["controllers.hlcmp.pi", "x final [mm]"]
        and len(result.table.rows) == 2
    )

    stamps = {p: p.stat().st_mtime_ns for p in out.glob("tasks/*/metrics.json")}
    again = run_sweep(tiny(tmp_path), out, workers=2)
    assert again.ran == [] and again.already_done == 2
    assert {p: p.stat().st_mtime_ns for p in out.glob("tasks/*/metrics.json")} == stamps
    assert _read_csv(out / "sweep.csv") == rows

    (out / "tasks" / "pi=5.0" / "timeseries.npz").unlink()  # a series metric reads it
    damaged = run_sweep(tiny(tmp_path), out, workers=2)
    assert damaged.ran == ["pi=5.0"] and damaged.already_done == 1 and not damaged.failed

    def timeless(table):
        return [{k: v for k, v in row.items() if k != "wall_s"} for row in table]

    assert timeless(_read_csv(out / "sweep.csv")) == timeless(rows)


@pytest.mark.slow
def test_a_deleted_result_reruns_that_task_only_and_an_edited_sweep_reruns_what_changed(tmp_path):
    out = tmp_path / "out"
    run_sweep(tiny(tmp_path), out, workers=2)
    kept = out / "tasks" / "pi=5.0" / "metrics.json"
    stamp = kept.stat().st_mtime_ns
    (out / "tasks" / "pi=1.0" / "metrics.json").unlink()
    assert plan_sweep(tiny(tmp_path), out).states == {"pi=1.0": "pending", "pi=5.0": "done"}
    result = run_sweep(tiny(tmp_path), out, workers=2)
    assert (
        result.ran == ["pi=1.0"] and result.already_done == 1 and kept.stat().st_mtime_ns == stamp
    )
    assert [r["status"] for r in _read_csv(out / "sweep.csv")] == ["ok", "ok"]
    # A longer duration is another scenario: both tasks are stale and run again.
    result = run_sweep(tiny(tmp_path, duration=0.2), out, workers=2)
    assert sorted(result.ran) == ["pi=1.0", "pi=5.0"] and result.stale == 2
    with np.load(out / "tasks" / "pi=1.0" / "timeseries.npz") as arrays:
        assert arrays["t"][-1] == pytest.approx(0.2)
    assert result.foreign == []
    # Another value is another task: the old one's folder stays, said to be no task of it.
    result = run_sweep(tiny(tmp_path, duration=0.2, values="[1.0, 3.0]"), out, workers=2)
    assert result.ran == ["pi=3.0"] and result.foreign == ["pi=5.0"]
    assert [r["id"] for r in _read_csv(out / "sweep.csv")] == ["pi=1.0", "pi=3.0"]


@pytest.mark.slow
def test_a_killed_sweep_keeps_its_finished_tasks_and_a_rerun_runs_only_the_rest(tmp_path):
    sweep = tiny(tmp_path, duration=0.5, values="[1.0, 2.0, 5.0, 10.0]")
    out = tmp_path / "out"
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "hlcmp_drake.cli",
            "sweep",
            str(sweep),
            "--out",
            str(out),
            "--workers",
            "2",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.time() + 240
    while (
        not list(out.glob("tasks/*/metrics.json"))
        and time.time() < deadline
        and process.poll() is None
    ):
        time.sleep(0.2)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    finished = {p.parent.name for p in out.glob("tasks/*/metrics.json")}
    if process.returncode == 0:
        pytest.skip("the sweep finished before it could be killed")
    assert process.returncode == 130 and "every finished task is kept" in err, err
    assert finished and len(finished) < 4
    rows = {r["id"]: r["status"] for r in _read_csv(out / "sweep.csv")}
    assert {i for i, s in rows.items() if s == "ok"} <= finished  # listed ones are finished ones
    result = run_sweep(sweep, out, workers=2)
    assert sorted(result.ran) == sorted({"pi=1.0", "pi=2.0", "pi=5.0", "pi=10.0"} - finished)
    assert [r["status"] for r in _read_csv(out / "sweep.csv")] == ["ok"] * 4


def _descendants(pid):
    """The processes below `pid`, children first."""
    found, queue = [], [pid]
    while queue:
        tasks = Path(f"/proc/{queue.pop(0)}/task")
        for task in tasks.iterdir() if tasks.exists() else []:
            with contextlib.suppress(OSError):  # the task ended meanwhile
                children = [int(c) for c in (task / "children").read_text().split()]
                found += children
                queue += children
    return found


@pytest.mark.slow  # a sweep in a process of its own, killed while its pool runs (about 2.9 s)
@pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="the kernel's parent-death signal is Linux's"
)
def test_a_sweep_killed_outright_leaves_no_worker_running(tmp_path):
    """SIGKILL gives the sweep no chance to stop its pool: the kernel ends the workers."""
    sweep = tiny(tmp_path, duration=3.0, values="[1.0, 2.0, 5.0, 10.0]")
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "hlcmp_drake.cli",
            "sweep",
            str(sweep),
            "--out",
            str(tmp_path / "out"),
            "--workers",
            "2",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.time() + 120
    workers = []
    # The fork server, the two workers it forked and the resource tracker.
    while len(workers) < 4 and time.time() < deadline:
        time.sleep(0.2)
        workers = _descendants(process.pid)
    assert len(workers) >= 4, f"the sweep did not start its workers: {workers}"
    started = []  # a task writes its scenario.yaml first: both workers are into a task
    while len(started) < 2 and time.time() < deadline:
        time.sleep(0.05)
        started = list((tmp_path / "out" / "tasks").glob("*/scenario.yaml"))
    assert len(started) >= 2, f"the workers started no tasks: {started}"
    process.kill()
    process.communicate(timeout=30)
    deadline = time.time() + 30
    alive = workers
    while alive and time.time() < deadline:
        time.sleep(0.2)
        alive = [
            pid
            for pid in workers
            if Path(f"/proc/{pid}").exists()
            and "Z" not in Path(f"/proc/{pid}/stat").read_text().split()[2]
        ]
    assert not alive, f"still running after the sweep was killed: {alive}"


@pytest.mark.slow
@pytest.mark.xdist_group("ray")  # one local Ray instance at a time
def test_the_ray_engine_runs_the_tiny_sweep(tmp_path):
    pytest.importorskip("ray")
    out = tmp_path / "out"
    result = run_sweep(tiny(tmp_path), out, engine="ray", workers=2)
    assert sorted(result.ran) == ["pi=1.0", "pi=5.0"] and not result.failed
    assert [r["status"] for r in _read_csv(out / "sweep.csv")] == ["ok", "ok"]
    assert (out / "tasks" / "pi=1.0" / "timeseries.npz").is_file()
    # What Ray wrote is finished for the local engine too.
    assert run_sweep(tiny(tmp_path), out, workers=1).ran == []


# --- command line --------------------------------------------------------------------


def test_the_command_lists_tasks_with_dry_run_and_writes_nothing(tmp_path):
    result = run_cli("sweep", tiny(tmp_path), "--out", tmp_path / "out", "--dry-run")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert "2 tasks of one_dof.yaml" in lines[0] and "2 to run" in lines[0]
    assert lines[1].split()[:2] == ["pending", "pi=1.0"] and "controllers.hlcmp.pi=1.0" in lines[1]
    assert not (tmp_path / "out").exists()


def test_folders_of_no_task_of_the_sweep_are_said_and_left(tmp_path):
    """An edited grid leaves its old tasks' folders: the sweep says so, keeps them and
    leaves them out of its tables (here told by a dry run, which runs nothing)."""
    from hlcmp_drake.run.sweep.planning import foreign_task_folders

    out = tmp_path / "out"
    for old in ("pi=3.0", "pi=7.0", "pi=9.0", "pi=11.0"):
        (out / "tasks" / old).mkdir(parents=True)
    (out / "tasks" / "pi=1.0").mkdir()  # one of this sweep's, pending
    plan = plan_sweep(tiny(tmp_path), out)
    assert foreign_task_folders(plan) == ["pi=11.0", "pi=3.0", "pi=7.0", "pi=9.0"]
    result = run_cli("sweep", tiny(tmp_path), "--out", out, "--dry-run")
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[-1] == (
        f"4 folder(s) in {out}/tasks are no task of this sweep (an earlier grid's?), left as "
        "they are and out of its tables: pi=11.0, pi=3.0, pi=7.0 and 1 more"
    )
    assert all((out / "tasks" / old).is_dir() for old in ("pi=3.0", "pi=9.0"))


@pytest.mark.parametrize(
    "args, expected",
    [
        (
            ["nowhere"],
            "nowhere: not a bundled sweep (insertion_learning_rate, one_dof_sensitivity, "
            "peg_rotational_q, tiny",
        ),
        (["tiny", "--address", "auto"], "--address: joins a Ray cluster, so it needs --engine ray"),
        (["tiny", "--workers", "0"], "must be at least 1"),
        (["tiny", "--engine", "spark"], "invalid choice"),
    ],
)
def test_bad_sweep_arguments_exit_2_with_one_line(tmp_path, args, expected):
    result = run_cli("sweep", *args, "--out", tmp_path / "out")
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert expected in result.stderr
    assert not (tmp_path / "out").exists()


def test_the_ray_engine_without_ray_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails as if not installed
    result = run_cli("sweep", tiny(tmp_path), "--out", tmp_path / "out", "--engine", "ray")
    assert result.returncode == 2, result.stderr
    assert result.stderr.strip() == (
        "hlcmp: error: --engine ray needs Ray, which is not installed: pip install -e '.[ray]'"
    )
    assert not (tmp_path / "out").exists()


# --- metric paths, checked before any task runs ---------------------------------------

HEAD = """\
scenario: one_dof
set:
  duration_s: 0.1
grid:
  controllers.hlcmp.pi: [1.0, 5.0]
{controllers}metrics:
- {{label: "x final [mm]", series: hlcmp/x, reduce: final, scale: 1000.0}}
"""


@pytest.mark.parametrize(
    "entry, expected",
    [
        (
            "path: controllers.hlcmp.final_position",
            "path 'controllers.hlcmp.final_position': controllers.hlcmp has no 'final_position' "
            "(position_at_10s_m, final_position_m, reach_time_s, return_time_s, task)",
        ),
        (
            "path: controllers.hlcpm.reach_time_s",
            "path 'controllers.hlcpm.reach_time_s': the scenario has no controller 'hlcpm' (its "
            "controllers: hlcmp, hlcmp_per_step, vic_fd_0.5, vic_fd_1.5, vic_fd_5.0; did you "
            "mean 'hlcmp'?)",
        ),
        (
            "path: controllers.vic_fd_2.final_position_m",
            "the scenario has no controller 'vic_fd_2' (its controllers: hlcmp, hlcmp_per_step, "
            "vic_fd_0.5, vic_fd_1.5, vic_fd_5.0; did you mean 'vic_fd_5.0'?)",
        ),
        (
            "path: instability.pid.t_s",
            "the scenario has no controller 'pid' (its controllers: hlcmp, hlcmp_per_step, "
            "vic_fd_0.5, vic_fd_1.5, vic_fd_5.0)",
        ),
        ("path: controllers.hlcmp", "controllers.hlcmp is a group (position_at_10s_m"),
        ("path: controller.hlcmp.reach_time_s", "metrics.json has no 'controller' (scenario,"),
        ("path: status.ok", "status is a single value, it has no 'ok'"),
        ("path: claims.hlcmp.C5.holds", "this sweep's tasks judge no claim"),
        ("series: hlcmp/Kss", "series 'hlcmp/Kss': hlcmp logs no 'Kss' (x, xd, f_ext"),
        ("series: nope/x", "no controller 'nope' runs in the tasks (hlcmp)"),
        (
            "series: vic_fd_0.5/x",
            "'vic_fd_0.5' does not run: the sweep's `controllers` leaves it out (it runs hlcmp)",
        ),
        (
            "path: controllers.vic_fd_1.5.reach_time_s",
            "'vic_fd_1.5' does not run: the sweep's `controllers` leaves it out (it runs hlcmp)",
        ),
        ("{series: hlcmp/x, column: 1}", "column 1: hlcmp/x has 1 column(s)"),
        (
            "{series: hlcmp/Ks, reduce: max, window_s: [2.0, 3.0]}",
            "window_s [2.0, 3.0] begins after every task's run has ended (the longest lasts "
            "0.1 s): nothing to reduce",
        ),
    ],
)
def test_a_metric_no_task_will_write_stops_the_sweep_before_the_first_task(
    tmp_path, entry, expected
):
    entry = entry if entry.startswith("{") else f"{{{entry}}}"
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(HEAD.format(controllers="controllers: [hlcmp]\n") + f"- {entry}\n")
    result = run_cli("sweep", sweep, "--out", tmp_path / "out")
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert result.stderr.startswith(f"hlcmp: error: {sweep}:9: metrics: entry 2: "), result.stderr
    assert expected in result.stderr
    assert not (tmp_path / "out").exists()  # no task ran, nothing was written


def test_a_path_into_a_list_names_one_element_by_its_index():
    from hlcmp_drake.run.sweep.planning import TaskOutputs, path_problem

    outputs = TaskOutputs({"controllers": {"c": {"tau": [0.1, 0.2, 0.3]}}}, {}, [], None)
    assert path_problem(outputs, "controllers.c.tau.2") is None
    assert path_problem(outputs, "controllers.c.tau") == (
        "controllers.c.tau is a list of 3 values: name one by its index (controllers.c.tau.0)"
    )
    assert path_problem(outputs, "controllers.c.tau.3") == (
        "controllers.c.tau is a list of 3: '3' is no index of it (0 to 2)"
    )
    assert path_problem(outputs, "controllers.c.tau.y") == (
        "controllers.c.tau is a list of 3: 'y' is no index of it (0 to 2)"
    )
    assert path_problem(outputs, "controllers.c.tau.0.x") == (
        "controllers.c.tau.0 is a single value, it has no 'x'"
    )


@pytest.mark.slow  # two peg runs in a pool of processes (about 2.8 s)
def test_a_sweep_over_the_rotational_learning_rates_runs_with_the_6d_metrics(tmp_path):
    """peg_in_hole's hlcmp_6d for 0.1 s at two Q_kr: each task's table row holds the 6-D
    metrics of its own metrics.json and time series, and the larger Q_kr learns the
    larger K_r (the override reached the controller)."""
    sweep = tmp_path / "rotational.yaml"
    sweep.write_text(
        "scenario: peg_in_hole\nset: {duration_s: 0.1}\ncontrollers: [hlcmp_6d]\n"
        "grid:\n  controllers.hlcmp_6d.q_kr: [[0.3, 0.3, 0.3], [30.0, 30.0, 30.0]]\n"
        "metrics:\n"
        "- {label: e_rx, path: controllers.hlcmp_6d.mean_abs_orientation_error_rad.0}\n"
        "- {label: tau_y, path: controllers.hlcmp_6d.max_abs_torque_Nm.1}\n"
        "- {label: Kr_z, path: controllers.hlcmp_6d.max_rotational_stiffness_Nm_per_rad.2}\n"
        "- {label: Kr_z series, series: hlcmp_6d/Kr, reduce: max, column: 2}\n"
    )
    out = tmp_path / "out"
    result = run_sweep(sweep, out, workers=1)
    assert sorted(result.ran) == ["q_kr=0.3_0.3_0.3", "q_kr=30.0_30.0_30.0"]
    assert not result.failed and not result.missing
    rows = {row["id"]: row for row in _read_csv(out / "sweep.csv")}
    for task, row in rows.items():
        assert row["status"] == "ok"
        entry = json.loads((out / "tasks" / task / "metrics.json").read_text())
        entry = entry["controllers"]["hlcmp_6d"]
        assert float(row["e_rx"]) == pytest.approx(entry["mean_abs_orientation_error_rad"][0])
        assert float(row["tau_y"]) == pytest.approx(entry["max_abs_torque_Nm"][1])
        assert float(row["Kr_z"]) == pytest.approx(entry["max_rotational_stiffness_Nm_per_rad"][2])
        assert float(row["Kr_z series"]) == pytest.approx(float(row["Kr_z"]))
    slow, fast = rows["q_kr=0.3_0.3_0.3"], rows["q_kr=30.0_30.0_30.0"]
    assert float(fast["Kr_z"]) > float(slow["Kr_z"])


def test_claims_and_kind_dependent_series_are_checked_against_every_task(tmp_path):
    from hlcmp_drake.io.errors import InputError
    from hlcmp_drake.run.sweep.planning import check_metrics

    every = tmp_path / "every.yaml"  # every controller: the claims are judged
    every.write_text(
        HEAD.format(controllers="")
        + "- {path: claims.hlcmp_per_step.C5.holds}\n- {path: claims.hlcmp.C6.holds}\n"
    )
    with pytest.raises(InputError, match=r"every.yaml:9: metrics: entry 3: .*has no 'C6' \(C5\)"):
        check_metrics(plan_sweep(every, tmp_path / "out"))
    # K_s is logged only where hlcmp is an Hl-CMP: one task that has it is enough
    cases = tmp_path / "cases.yaml"
    cases.write_text(
        "scenario: one_dof\nset: {duration_s: 0.1}\ncontrollers: [hlcmp]\ncases:\n"
        "- {label: learner}\n"
        "- label: fixed\n  set:\n    controllers.hlcmp: '!ConstantImpedanceConfig "
        "{stiffness_N_per_m: [100.0], damping_Ns_per_m: [10.0], gain_l: [0.0]}'\n"
        "metrics:\n- {series: hlcmp/Ks}\n"
    )
    check_metrics(plan_sweep(cases, tmp_path / "out"))
    assert not (tmp_path / "out").exists()


@pytest.mark.slow  # the three bundled scenarios' whole runs
@pytest.mark.parametrize("name", ["one_dof", "insertion", "cutting"])
def test_the_short_check_run_accepts_every_value_a_whole_run_writes(tmp_path, name, request):
    """check_metrics' short run has the keys of a whole run's metrics.json and series."""
    from hlcmp_drake.run.sweep.planning import path_problem, task_outputs

    run_dir = request.getfixturevalue(f"{name}_run")
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(f"scenario: {name}\n")
    found = task_outputs(plan_sweep(sweep, tmp_path / "out").tasks[0])
    whole = json.loads((run_dir / "metrics.json").read_text())

    def leaves(node, prefix):
        for key, value in node.items():
            if isinstance(value, dict):
                yield from leaves(value, f"{prefix}{key}.")
            else:
                yield f"{prefix}{key}"

    paths = list(
        leaves({k: whole[k] for k in ("scenario", "status", "controllers", "learners")}, "")
    )
    paths += [
        f"claims.{learner}.{claim}.holds"
        for learner in whole["claims"]
        for claim in whole["claims"][learner]
    ]
    assert paths and [p for p in paths if path_problem(found, p)] == []
    with np.load(run_dir / "timeseries.npz") as arrays:
        assert set(found.series) == set(arrays.files) - {"t"}


def test_a_ray_address_that_is_no_address_is_one_line(tmp_path):
    pytest.importorskip("ray")
    result = run_cli(
        "sweep", "tiny", "--engine", "ray", "--address", "notanaddress", "--out", tmp_path / "s"
    )
    assert one_line_error(result).startswith(
        "hlcmp: error: --address notanaddress: cannot join a Ray cluster there"
    )
    assert not (tmp_path / "s").exists()  # joined before any run, so nothing is written


def _imported(module):
    return module in sys.modules


def _compiler_prepared(_):
    from hlcmp_drake.core import kernels

    return bool(kernels._numba)  # numba imported and its compiler set up (prepare_compiler)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="spawned elsewhere")
def test_local_workers_start_with_the_task_imports_and_the_pools_environment(monkeypatch):
    """Forked from the fork server, a worker has imported what tasks need before its first
    (matplotlib's Agg backend and Figure, which nothing else imports here) and numba's
    compiler set up (`worker_start`), and runs in the environment
    of its sweep's process when the pool was made, not of when the server started."""
    results = []

    def keep(item, result, error):
        results.append((item, result, error))

    run_in_processes(_imported, ["matplotlib.backends.backend_agg", "matplotlib.figure"], 1, keep)
    if numba_available():
        run_in_processes(_compiler_prepared, ["numba"], 1, keep)
    monkeypatch.setenv("HLCMP_SWEEP_TEST", "set after the fork server started")
    run_in_processes(os.getenv, ["HLCMP_SWEEP_TEST"], 2, keep)
    # A variable the fork server's imports read when imported (matplotlib's, here): the
    # pool is spawned, its workers importing under the new value.
    monkeypatch.setenv("MPL_HLCMP_SWEEP_TEST", "set after the fork server started")
    run_in_processes(_imported, ["matplotlib.backends.backend_agg"], 1, keep)
    assert results == [
        ("matplotlib.backends.backend_agg", True, None),
        ("matplotlib.figure", True, None),
        *([("numba", True, None)] if numba_available() else []),
        ("HLCMP_SWEEP_TEST", "set after the fork server started", None),
        ("matplotlib.backends.backend_agg", False, None),
    ]


def _kernels_cache_folder(_):
    from hlcmp_drake.core import kernels

    kernels.numba_available()
    return kernels._numba[0].config.CACHE_DIR


@pytest.mark.skipif(not numba_available(), reason="the compiled path needs numba")
def test_a_pool_made_after_the_cache_home_changed_compiles_into_the_new_one(monkeypatch, tmp_path):
    """The fork server sets numba's compiler up, its cache folder under XDG_CACHE_HOME as
    it was then: a pool made after it changed is spawned and files its kernels under the
    new one, as a new process would."""
    found = []
    run_in_processes(_kernels_cache_folder, [0], 1, lambda *done: found.append(done[1]))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    run_in_processes(_kernels_cache_folder, [0], 1, lambda *done: found.append(done[1]))
    assert not found[0].startswith(str(tmp_path)) and found[1].startswith(str(tmp_path))


SIGINT_PROBE = """\
import os, signal
with open(os.environ["SIGINT_PROBE"], "w") as record:
    record.write(str(signal.getsignal(signal.SIGINT) == signal.SIG_IGN))
"""


@pytest.mark.slow  # a pool started in a Python process of its own (about 1.9 s)
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="spawned elsewhere")
def test_the_fork_server_ignores_ctrl_c_while_it_imports(tmp_path):
    """Ctrl-C reaches the whole process group: the fork server, still importing what tasks
    need, must not print a traceback of its own under the sweep's one-line message."""
    (tmp_path / "sigint_probe.py").write_text(SIGINT_PROBE)
    script = (
        "from hlcmp_drake.run.sweep import engines\n"
        "engines.WORKER_IMPORTS = ('sigint_probe', *engines.WORKER_IMPORTS)\n"
        "if __name__ == '__main__':\n"
        "    engines.run_in_processes(abs, [-1], 1, lambda *done: print(done))\n"
    )
    record = tmp_path / "record"
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        # PYTHONPATH, not sys.path: Python 3.11's fork server imports from its own path
        env={**os.environ, "SIGINT_PROBE": str(record), "PYTHONPATH": str(tmp_path)},
        timeout=120,
    )
    assert done.stdout.split() == ["(-1,", "1,", "None)"], done.stderr
    assert record.read_text() == "True"  # ignored from the server's first import on


def _refuse(value):
    raise ValueError(f"refused {value}\nsecond line of the message")


def test_a_local_tasks_error_reaches_the_sweep_in_one_line():
    results = []
    run_in_processes(_refuse, [1], 1, lambda item, result, error: results.append(error))
    assert results == ["ValueError: refused 1 second line of the message"]


def _dies_on_negative(value):
    if value < 0:
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.05)
    return value * 10


def test_a_task_that_kills_its_worker_fails_alone_and_the_others_finish():
    """A worker killed outright breaks its pool; the tasks it had not run, and those that
    ran beside the culprit, still finish, and the culprit fails with how its worker ended."""
    results = {}

    def keep(item, result, error):
        assert item not in results  # each task reported once
        results[item] = (result, error)

    run_in_processes(_dies_on_negative, [1, 2, -3, 4, 5, 6, 7], 2, keep)
    assert results.pop(-3) == (None, "its worker process died (killed by SIGKILL)")
    assert results == {v: (10 * v, None) for v in (1, 2, 4, 5, 6, 7)}


class _KillsTheWorkerThatReceivesIt:
    """A task argument whose unpickling ends the worker, before any task can run."""

    def __reduce__(self):
        return os._exit, (1,)


def test_a_pool_whose_workers_die_before_any_task_fails_every_task_and_returns():
    from hlcmp_drake.run.sweep.engines import NO_TASK_RAN

    results = []
    items = [_KillsTheWorkerThatReceivesIt() for _ in range(3)]
    run_in_processes(str, items, 2, lambda item, result, error: results.append((result, error)))
    assert results == [(None, NO_TASK_RAN)] * 3


def test_a_pool_that_breaks_while_its_tasks_are_handed_out_fails_them_as_it_fails_the_rest(
    monkeypatch,
):
    """A worker may die before the last task is handed to the pool: the pool refuses that
    task then, which counts as one the pool did not start (seen in CI, where the first
    worker died of its task before the third was submitted)."""
    from concurrent.futures import ProcessPoolExecutor

    from hlcmp_drake.run.sweep import engines

    class HandsOutAfterItBroke(ProcessPoolExecutor):
        def submit(self, *args, **kwargs):
            if self._submitted:  # wait for the first task to kill its worker
                deadline = time.time() + 60
                while not self._broken and time.time() < deadline:
                    time.sleep(0.01)
            self._submitted += 1
            return super().submit(*args, **kwargs)

        _submitted = 0

    monkeypatch.setattr(engines, "ProcessPoolExecutor", HandsOutAfterItBroke)
    results = []
    items = [_KillsTheWorkerThatReceivesIt() for _ in range(3)]
    run_in_processes(str, items, 2, lambda item, result, error: results.append((result, error)))
    assert results == [(None, engines.NO_TASK_RAN)] * 3


@pytest.mark.slow  # five sweeps, each with a process pool (about 3.2 s)
def test_a_sweep_again_into_its_folder_removes_its_own_stale_plots_alone(tmp_path):
    """Sweeping another key into the same --out left the old key's plot beside the new
    one, and a sweep without a grid said it wrote plots/ where it wrote none: the plots of
    the sweep before go (a file of yours in plots/ stays), and plots/ is said only when
    written."""
    out = tmp_path / "out"
    first = run_cli("sweep", tiny(tmp_path), "--out", out, "--workers", 1, "--quiet")
    assert first.returncode == 0, first.stderr
    assert (
        first.stdout.splitlines()[-1] == f"results in {out}: sweep.csv, sweep.json, plots/, tasks/"
    )
    (out / "plots" / "mine.png").write_bytes(b"my own")
    other_key = TINY_BY_DURATION.format(durations="[0.1, 0.2]")
    second = run_cli("sweep", write_sweep(tmp_path, other_key), "--out", out, "--workers", 1)
    assert second.returncode == 0, second.stderr
    assert sorted(p.name for p in (out / "plots").iterdir()) == ["duration_s.png", "mine.png"]
    no_grid = TINY_BY_DURATION.format(durations="[0.1]").replace("grid:", "set:")
    no_grid = no_grid.replace("[0.1]", "0.1")
    third = run_cli("sweep", write_sweep(tmp_path, no_grid), "--out", out, "--workers", 1)
    assert third.returncode == 0, third.stderr
    assert f"results in {out}: sweep.csv, sweep.json, tasks/" in third.stdout.splitlines()
    assert [p.name for p in (out / "plots").iterdir()] == ["mine.png"]
    (out / "plots" / "mine.png").unlink()
    assert (
        run_cli("sweep", write_sweep(tmp_path, other_key), "--out", out, "--workers", 1).returncode
        == 0
    )
    assert (
        run_cli("sweep", write_sweep(tmp_path, no_grid), "--out", out, "--workers", 1).returncode
        == 0
    )
    assert not (out / "plots").exists()


TINY_BY_DURATION = """\
scenario: one_dof
grid:
  duration_s: {durations}
controllers: [hlcmp]
metrics:
- {{label: "final x [m]", path: controllers.hlcmp.final_position_m, digits: 4}}
"""


def test_a_path_names_the_longest_controller_label_it_begins_with():
    """Labels may hold dots: with vic_fd_1 left out and vic_fd_1.5 running, a path into
    vic_fd_1.5 is vic_fd_1.5's, and the other way round it is the left-out one's."""
    from hlcmp_drake.run.sweep.planning import TaskOutputs, path_problem

    metrics = {"controllers": {"vic_fd_1.5": {"reach_time_s": 1.0}}}
    outputs = TaskOutputs(metrics, {}, [], None, ["vic_fd_1"])
    assert path_problem(outputs, "controllers.vic_fd_1.5.reach_time_s") is None
    assert path_problem(outputs, "controllers.vic_fd_1.reach_time_s").startswith(
        "'vic_fd_1' does not run"
    )
    outputs = TaskOutputs({"controllers": {"vic_fd_1": {}}}, {}, [], None, ["vic_fd_1.5"])
    assert path_problem(outputs, "controllers.vic_fd_1.5.reach_time_s") == (
        "'vic_fd_1.5' does not run: the sweep's `controllers` leaves it out (it runs vic_fd_1)"
    )
