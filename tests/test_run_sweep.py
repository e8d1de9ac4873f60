"""`hlcmp sweep`: sweep files load with file:line errors, tasks get stable ids and carry
their scenario as YAML text, the local engine runs a tiny sweep and writes its table and
plots, and a re-run does only what is missing (after a deleted result or a kill)."""

import csv
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hlcmp_drake.config.loading import load_scenario_text
from hlcmp_drake.config.sweep import SWEEPS_DIR, load_sweep, plan_tasks, task_id
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.present.sweep import parameter_number, parameter_text, sweep_table
from hlcmp_drake.present.tables import to_markdown
from hlcmp_drake.run.sweep import plan_sweep, run_sweep, task_state, task_values

TINY = """\
scenario: one_dof
set:
  duration_s: {duration}
grid:
  controllers.hlcmp.pi: {values}
controllers: [hlcmp]
metrics:
- {{label: "x final [mm]", series: hlcmp/x, reduce: final, scale: 1000.0, digits: 1}}
- {{label: "max K_s [N/m]", series: hlcmp/Ks, reduce: max}}
- {{label: "final x [m]", path: controllers.hlcmp.final_position_m, digits: 4}}
"""


def write_sweep(folder, text, name="sweep.yaml"):
    path = Path(folder) / name
    path.write_text(text)
    return path


def tiny(folder, duration=0.1, values="[1.0, 5.0]", name="sweep.yaml"):
    return write_sweep(folder, TINY.format(duration=duration, values=values), name)


def hlcmp(*args, **kwargs):
    return subprocess.run(
        [sys.executable, "-m", "hlcmp_drake.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
        **kwargs,
    )


# --- loading -------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text, expected",
    [
        (
            "scenario: one_dof\ngrid:\n  dmp.n_basis: [2, 3]\nrepetition: 2\n",
            ":4: The fields ['repetition'] were unknown",
        ),
        ("scenario: one_dof\ngrid:\n  dmp.n_basis: [2, 3\n", ":4:"),
        (
            "scenario: one_dof\nrepetitions: 1.5\n",
            ":2: Expected a <class 'int'> value for 'repetitions'",
        ),
        ("scenario: one_dof\nrepetitions: 0\n", ":2: repetitions: must be between 1 and 1000"),
        ("scenario: nowhere\n", ":1: scenario: nowhere: not a bundled scenario"),
        ("scenario: missing.yaml\n", ":1: scenario: "),
        ("grid:\n  dmp.n_basis: [2]\n", "scenario: must be given"),
        (
            "scenario: one_dof\nset:\n  dmp.n_basis: 3\ngrid:\n  dmp.n_basis: [2, 4]\n",
            ":5: grid: 'dmp.n_basis' is also in set",
        ),
        (
            "scenario: one_dof\ngrid:\n  dmp.n_basis: 2\n",
            ":3: grid: 'dmp.n_basis' needs a non-empty list",
        ),
        (
            "scenario: one_dof\ngrid:\n  dmp.n_basis: [2, 2]\n",
            ":3: grid: 'dmp.n_basis' lists a value twice",
        ),
        (
            "scenario: one_dof\ncases:\n- {label: a}\n- {label: a}\n",
            ":2: cases: two cases share a label",
        ),
        (
            "scenario: one_dof\nlabels: {dmp.n_basis: N}\n",
            ":2: labels: 'dmp.n_basis' is not a swept parameter",
        ),
        (
            "scenario: one_dof\nmetrics:\n- label: k\n  series: hlcmp/Ks\n  reduce: median\n",
            ":5: metrics: entry 1: reduce must be one of max, min",
        ),
        ("scenario: one_dof\nmetrics:\n- {label: k}\n", ":2: metrics: entry 1: give either `path`"),
        ("scenario: one_dof\nmetrics:\n- {series: Ks}\n", "series is CONTROLLER/NAME"),
    ],
)
def test_a_bad_sweep_file_is_one_error_naming_its_line(tmp_path, text, expected):
    path = write_sweep(tmp_path, text)
    with pytest.raises(InputError) as error:
        load_sweep(path)
    assert str(error.value).startswith(str(path)), error.value
    assert expected in str(error.value), error.value


def test_a_bad_override_or_controller_is_found_before_anything_runs(tmp_path):
    path = write_sweep(tmp_path, "scenario: one_dof\ngrid:\n  controllers.hlcmp.pi: [1.0, -2.0]\n")
    with pytest.raises(
        InputError,
        match=r":3: override 'controllers.hlcmp.pi=-2.0': pi: .*pi must be > 0.*"
        r"\(task controllers.hlcmp.pi=-2.0\)",
    ):
        plan_tasks(load_sweep(path), tmp_path / "out")
    path = write_sweep(tmp_path, "scenario: one_dof\ngrid:\n  controllers.hlcmp.nope: [1]\n")
    with pytest.raises(InputError, match=r":3: override .*no field 'nope'"):
        plan_tasks(load_sweep(path), tmp_path / "out")
    path = write_sweep(tmp_path, "scenario: one_dof\n\ncontrollers: [hlcmp, pid]\n")
    with pytest.raises(InputError, match=r":3: controllers: pid not in the scenario"):
        plan_tasks(load_sweep(path), tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_values_are_yaml_written_plainly_or_as_text(tmp_path):
    path = write_sweep(
        tmp_path,
        "scenario: one_dof\ngrid:\n  controllers.hlcmp.gain_l: [[1.0], '[10.0]']\n"
        "  dmp.n_basis: [2]\n",
    )
    sweep = load_sweep(path)
    assert sweep.config.grid == {
        "controllers.hlcmp.gain_l": ["[1.0]", "[10.0]"],
        "dmp.n_basis": ["2"],
    }
    tasks = plan_tasks(sweep, tmp_path / "out")
    gains = [
        load_scenario_text(t.scenario_yaml, t.scenario_path).controllers["hlcmp"].gain_l
        for t in tasks
    ]
    assert gains == [[1.0], [10.0]]


def test_a_relative_scenario_path_is_read_beside_the_sweep_file(tmp_path):
    scenario = (
        (SWEEPS_DIR.parent / "one_dof.yaml").read_text().replace("name: one_dof", "name: mine")
    )
    (tmp_path / "worlds").mkdir()
    (tmp_path / "worlds" / "mine.yaml").write_text(scenario)
    (tmp_path / "sweeps").mkdir()
    path = write_sweep(
        tmp_path / "sweeps", "scenario: ../worlds/mine.yaml\ngrid:\n  dmp.n_basis: [3]\n"
    )
    (task,) = plan_tasks(load_sweep(path), tmp_path / "out")
    assert load_scenario_text(task.scenario_yaml, task.scenario_path).name == "mine"


# --- tasks ---------------------------------------------------------------------------


def test_task_ids_are_readable_and_depend_only_on_the_swept_values():
    assert (
        task_id({"dmp.n_basis": "2", "controllers.hlcmp.gain_l": "[1.0]"}) == "n_basis=2,gain_l=1.0"
    )
    assert task_id({"case": "x10"}, 2, 3) == "case=x10,rep=2"
    assert task_id({}) == "run"
    # Two keys ending alike keep their whole names; odd characters never reach the folder name.
    assert (
        task_id({"controllers.a.pi": "1", "controllers.b.pi": "[1, 2]"})
        == "controllers.a.pi=1,controllers.b.pi=1_2"
    )
    assert task_id({"a": "!Tag {k: v}"}) == "a=-Tagk-v"
    long = task_id({"controllers.hlcmp.q_k": "[" + ", ".join(["3000000.0"] * 12) + "]"})
    assert len(long) == 91 and long == task_id(
        {"controllers.hlcmp.q_k": "[" + ", ".join(["3000000.0"] * 12) + "]"}
    )


def test_the_same_sweep_plans_the_same_tasks_and_a_new_value_keeps_the_others(tmp_path):
    first = [
        (t.id, t.scenario_yaml) for t in plan_tasks(load_sweep(tiny(tmp_path)), tmp_path / "out")
    ]
    again = [
        (t.id, t.scenario_yaml) for t in plan_tasks(load_sweep(tiny(tmp_path)), tmp_path / "out")
    ]
    assert first == again and [i for i, _ in first] == ["pi=1.0", "pi=5.0"]
    more = plan_tasks(load_sweep(tiny(tmp_path, values="[1.0, 5.0, 20.0]")), tmp_path / "out")
    assert [(t.id, t.scenario_yaml) for t in more][:2] == first


def test_a_task_carries_its_whole_scenario_as_yaml_text(tmp_path):
    tasks = plan_tasks(load_sweep(tiny(tmp_path)), tmp_path / "out")
    for task, pi in zip(tasks, (1.0, 5.0)):
        assert isinstance(task.scenario_yaml, str) and task.run_dir == str(
            tmp_path / "out" / "tasks" / task.id
        )
        scenario = load_scenario_text(task.scenario_yaml, task.scenario_path)
        assert list(scenario.controllers) == ["hlcmp"] == task.controllers and not task.claims
        assert scenario.controllers["hlcmp"].pi == pi and scenario.duration_s == 0.1
        assert task.overrides == ["duration_s=0.1", f"controllers.hlcmp.pi={pi}"]


@pytest.mark.parametrize(
    "name, count", [("tiny", 2), ("one_dof_sensitivity", 18), ("insertion_learning_rate", 4)]
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


def test_a_task_is_done_only_beside_its_own_scenario(tmp_path):
    task = plan_tasks(load_sweep(tiny(tmp_path)), tmp_path / "out")[0]
    run_dir = Path(task.run_dir)
    run_dir.mkdir(parents=True)
    assert task_state(task) == "pending"
    (run_dir / "scenario.yaml").write_text(task.scenario_yaml)
    assert task_state(task) == "pending"  # started, never finished
    (run_dir / "metrics.json").write_text("{}")
    assert task_state(task) == "done"
    (run_dir / "scenario.yaml").write_text(
        task.scenario_yaml.replace("duration_s: 0.1", "duration_s: 0.2")
    )
    assert task_state(task) == "stale"


# --- results -------------------------------------------------------------------------


def test_metric_values_come_from_metrics_json_and_the_time_series(tmp_path):
    from hlcmp_drake.config.sweep import SweepMetric

    (tmp_path / "metrics.json").write_text(
        json.dumps(
            {
                "status": "ok",
                "controllers": {"vic_fd_0.5": {"reach_time_s": None, "x": {"z": 0.25}}},
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
        SweepMetric(label="no series", series="pid/Ks"),
    ]
    values, missing = task_values(tmp_path, metrics)
    assert values == {
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
        "no series": None,
    }
    assert missing == ["typo", "a dict", "no series"]


def test_the_table_shows_values_as_the_readme_does():
    summary = {
        "repetitions": 1,
        "parameters": [
            {"key": "dmp.n_basis", "label": "N"},
            {"key": "controllers.hlcmp.gain_l", "label": "L"},
        ],
        "metrics": [
            {"label": "x [m]", "digits": 4, "missing": "n/a", "yes_no": False},
            {"label": "reach [s]", "digits": 2, "missing": "never", "yes_no": False},
            {"label": "C4", "digits": 2, "missing": "n/a", "yes_no": False},
        ],
        "tasks": [
            {
                "id": "a",
                "parameters": {"dmp.n_basis": "2", "controllers.hlcmp.gain_l": "[10.0]"},
                "repetition": 1,
                "status": "ok",
                "values": {"x [m]": -0.11163, "reach [s]": None, "C4": True},
            },
            {
                "id": "b",
                "parameters": {"dmp.n_basis": "30", "controllers.hlcmp.gain_l": "[1.0]"},
                "repetition": 1,
                "status": "pending",
                "values": {},
            },
        ],
    }
    assert to_markdown(sweep_table(summary), code_first_column=False) == (
        "| N | L | x [m] | reach [s] | C4 |\n|---|---|---|---|---|\n"
        "| 2 | 10 | -0.1116 | never | yes |\n"
    )
    summary["tasks"][1].update(status="unstable", values={"x [m]": 3.0})
    assert sweep_table(summary).rows[1] == ["30", "1", "3.0000", "never", "n/a", "unstable"]
    assert parameter_number("[3.0, 3.0]") == 3.0 and parameter_number("[1, 2]") is None
    assert parameter_text("abc") == "abc" and parameter_text("1.0e-3") == "0.001"


# --- engines -------------------------------------------------------------------------


def _read_csv(path):
    with open(path) as stream:
        return list(csv.DictReader(stream))


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
    children = Path(f"/proc/{process.pid}/task/{process.pid}/children")
    deadline = time.time() + 120
    workers = []
    while len(workers) < 3 and time.time() < deadline:  # the two workers and the resource tracker
        time.sleep(0.2)
        workers = children.read_text().split() if children.exists() else []
    assert len(workers) >= 3, "the sweep did not start its workers"
    time.sleep(2.0)  # into their first tasks
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
    result = hlcmp("sweep", tiny(tmp_path), "--out", tmp_path / "out", "--dry-run")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert "2 tasks of one_dof.yaml" in lines[0] and "2 to run" in lines[0]
    assert lines[1].split()[:2] == ["pending", "pi=1.0"] and "controllers.hlcmp.pi=1.0" in lines[1]
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "args, expected",
    [
        (
            ["nowhere"],
            "nowhere: not a bundled sweep (insertion_learning_rate, one_dof_sensitivity, tiny",
        ),
        (["tiny", "--address", "auto"], "--address: joins a Ray cluster, so it needs --engine ray"),
        (["tiny", "--workers", "0"], "must be at least 1"),
        (["tiny", "--engine", "spark"], "invalid choice"),
    ],
)
def test_bad_sweep_arguments_exit_2_with_one_line(tmp_path, args, expected):
    result = hlcmp("sweep", *args, "--out", tmp_path / "out")
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert expected in result.stderr
    assert not (tmp_path / "out").exists()


def test_the_ray_engine_without_ray_says_how_to_install_it(tmp_path):
    try:
        import ray  # noqa: F401

        pytest.skip("Ray is installed")
    except ImportError:
        pass
    result = hlcmp("sweep", tiny(tmp_path), "--out", tmp_path / "out", "--engine", "ray")
    assert result.returncode == 2, result.stderr
    assert result.stderr.strip() == (
        "hlcmp: error: --engine ray needs Ray, which is not installed: pip install -e '.[ray]'"
    )
    assert not (tmp_path / "out").exists()
