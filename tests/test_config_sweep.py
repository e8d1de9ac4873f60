"""hlcmp_drake.config.sweep: sweep files load with file:line errors, and tasks get stable ids
and carry their scenario as YAML text."""

import pytest
from conftest import tiny, write_sweep

from hlcmp_drake.config.loading import load_scenario_text
from hlcmp_drake.config.sweep import SWEEPS_DIR, load_sweep, plan_tasks, task_id
from hlcmp_drake.io.errors import InputError


@pytest.mark.parametrize(
    "text, expected",
    [
        (
            "scenario: one_dof\ngrid:\n  dmp.n_basis: [2, 3]\nrepetition: 2\n",
            ":4: repetition: no such field in SweepConfig (did you mean 'repetitions'?)",
        ),
        ("scenario: one_dof\ngrid:\n  dmp.n_basis: [2, 3\n", ":4:"),
        (
            "scenario: one_dof\nrepetitions: 1.5\n",
            ":2: repetitions: must be an integer, got 1.5",
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
            "scenario: one_dof\ngrid:\n  duration_s: [1, 2, 1.0]\n",
            ":3: grid: 'duration_s' lists a value twice: ['1', '2', '1.0']",
        ),
        (
            "scenario: one_dof\ngrid:\n  duration_s: [1e1, 10]\n",
            ":3: grid: 'duration_s' lists a value twice: ['1e1', '10']",
        ),
        ("scenario: one_dof\ncases: []\n", ":2: cases: the list is empty (leave cases out"),
        (
            "scenario: one_dof\ncontrollers: []\n",
            ":2: controllers: the list is empty (leave controllers out to run all of the",
        ),
        (
            "scenario: one_dof\nmetrics:\n- {label: x, series: hlcmp/x, digits: two}\n"
            "- label: y\n  series: hlcmp/x\n  digits: 1\n",
            ":3: metrics.0.digits: must be an integer, got 'two'",
        ),
        (
            "scenario: one_dof\ncases:\n- {label: a}\n- {label: a}\n",
            ":2: cases: case 1 and case 2 share the label 'a'",
        ),
        (
            "scenario: one_dof\ncases:\n- {set: {duration_s: 1}}\n- {label: '1'}\n",
            ":2: cases: case 1 (no label given: labelled by its number) and case 2 share the "
            "label '1'",
        ),
        (
            "scenario: one_dof\nmetrics:\n- {label: k, series: hlcmp/Ks, below: .nan}\n",
            ":3: metrics: entry 1: below must be a finite number, got nan",
        ),
        (
            "scenario: one_dof\ngrid:\n  dmp.n_basis: [2, 3]\nmetrics:\n"
            "- {label: k, series: hlcmp/Ks}\n- {label: status, path: status}\n",
            ":4: metrics: entry 2: label 'status' is one of sweep.csv's own columns (id, "
            "dmp.n_basis, repetition, status, wall_s): give it another",
        ),
        (
            "scenario: one_dof\ngrid:\n  dmp.n_basis: [2, 3]\nmetrics:\n"
            "- {label: dmp.n_basis, path: status}\n",
            ":4: metrics: entry 1: label 'dmp.n_basis' is one of sweep.csv's own columns",
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
        (
            "scenario: one_dof\ngrid:\n  dmp.n_basis: [2, 3]\ngrid:\n  duration_s: [1]\n",
            ":4: 'grid' is given twice in the same map (first at line 2)",
        ),
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
        r"\(in the task where controllers.hlcmp.pi=-2.0\)",
    ):
        plan_tasks(load_sweep(path), tmp_path / "out")
    path = write_sweep(tmp_path, "scenario: one_dof\ngrid:\n  controllers.hlcmp.nope: [1]\n")
    with pytest.raises(InputError, match=r":3: override .*no field 'nope'"):
        plan_tasks(load_sweep(path), tmp_path / "out")
    # A fixed override's problem is every task's, not the first task's alone.
    fixed = "scenario: one_dof\nset: {controllers.hlcmp.pii: 1.0}\ngrid:\n  duration_s: [1, 2]\n"
    with pytest.raises(InputError, match=r":2: override .*no field 'pii'.*\(in every task\)$"):
        plan_tasks(load_sweep(write_sweep(tmp_path, fixed)), tmp_path / "out")
    labelled = 'scenario: one_dof\nlabels:\n  controllers.hlcmp.pii: "pi"\ngrid:\n'
    path = write_sweep(tmp_path, labelled + "  controllers.hlcmp.pii: [1.0]\n")
    with pytest.raises(InputError, match=r":5: override .*no field 'pii'.*did you mean 'pi'"):
        plan_tasks(load_sweep(path), tmp_path / "out")  # the grid's line, not the label's
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


def test_a_relative_demonstration_is_read_beside_the_sweep_file(tmp_path, monkeypatch):
    """reference.file: mydemo.csv in a sweep's set was read beside the scenario file
    (diagrams/, for a bundled one), neither beside the sweep file nor in the working
    directory: it is read beside the sweep file, as its scenario is, from any working
    directory; in a grid or a case too. Not found, the one line says where it looked and
    why there."""
    from conftest import INSERTION_DEMO

    (tmp_path / "sweeps").mkdir()
    (tmp_path / "sweeps" / "mydemo.csv").write_bytes(INSERTION_DEMO.read_bytes())
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    sweep = "scenario: insertion\nset: {reference.file: mydemo.csv}\n"
    (fixed,) = plan_tasks(load_sweep(write_sweep(tmp_path / "sweeps", sweep)), tmp_path / "o")
    gridded = sweep.replace("set:", "grid:").replace("mydemo.csv}", "[mydemo.csv]}")
    (swept,) = plan_tasks(load_sweep(write_sweep(tmp_path / "sweeps", gridded)), tmp_path / "o")
    beside = str(tmp_path / "sweeps" / "mydemo.csv")
    for task in (fixed, swept):
        assert load_scenario_text(task.scenario_yaml, task.scenario_path).reference.file == beside
    assert fixed.overrides == [f'reference.file="{beside}"']
    path = write_sweep(tmp_path / "sweeps", sweep.replace("mydemo", "nodemo"))
    with pytest.raises(InputError) as error:
        plan_tasks(load_sweep(path), tmp_path / "o")
    assert str(error.value).startswith(
        f"{path}:2: override 'reference.file=nodemo.csv': file: demonstration file "
        f"'{tmp_path / 'sweeps' / 'nodemo.csv'}' not found (looked for "
        f"{tmp_path / 'sweeps' / 'nodemo.csv'}); a relative path in sweep.yaml is read beside it"
    ), error.value


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


def test_a_metrics_line_is_the_line_of_its_path_or_series(tmp_path):
    from hlcmp_drake.config.sweep import metric_line

    path = write_sweep(
        tmp_path,
        "scenario: one_dof\nmetrics:\n"
        "- {label: a, path: controllers.hlcmp.reach_time_s}\n"
        "- label: b\n  series: 'hlcmp/Ks'  # the stiffness\n"
        "- {label: c, path: controllers.hlcmp.reach_time_s, scale: 2.0}\n",
    )
    assert [metric_line(load_sweep(path), k) for k in range(3)] == [3, 5, 6]


def test_grid_values_are_compared_by_value_where_they_are_numbers(tmp_path):
    """A tagged config stays text (the safe loader makes none), 0 and false stay two values."""
    tagged = "!StepReferenceConfig {{times_s: [0.0], positions_m: [[{}]]}}"
    path = write_sweep(
        tmp_path,
        "scenario: one_dof\ngrid:\n"
        f"  reference: ['{tagged.format(-0.1)}', '{tagged.format(-0.05)}']\n",
    )
    assert len(plan_tasks(load_sweep(path), tmp_path / "out")) == 2
    path = write_sweep(tmp_path, "scenario: one_dof\ngrid:\n  duration_s: [0, false]\n")
    load_sweep(path)  # refused later, by the scenario's own check of each value
