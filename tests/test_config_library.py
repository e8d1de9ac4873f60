"""hlcmp_drake.config.library: library files load, plan one skill per grid point, and
every problem is one line naming the file's line, exit 2, before anything is learned."""

import pytest
from conftest import one_line_error, run_cli

from hlcmp_drake.config.library import LIBRARIES_DIR, load_library_spec, plan_library_tasks
from hlcmp_drake.config.loading import load_scenario_text

GOOD = """\
scenario: insertion
trials: 2
set:
  duration_s: 0.3
grid:
  task.puncture.depth_m: [0.010, 0.015]
  task.puncture.hole_friction_N_per_m: [60.0, 90, 120.0]
"""


def write(tmp_path, text, name="lib.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("name", ["insertion", "insertion_per_step"])
def test_the_bundled_libraries_plan_six_skills_over_two_physical_parameters(tmp_path, name):
    spec = load_library_spec(name)
    assert spec.path == LIBRARIES_DIR / f"{name}.yaml"
    assert spec.parameters == ["task.puncture.depth_m", "task.puncture.hole_friction_N_per_m"]
    tasks = plan_library_tasks(spec, tmp_path)
    assert len(tasks) == 6 == len({t.id for t in tasks})
    assert all(t.trials == 3 for t in tasks)
    units = {
        load_scenario_text(t.scenario_yaml, t.scenario_path).controllers["hlcmp"].q_units
        for t in tasks
    }
    assert units == {"per_step" if name.endswith("per_step") else "per_second"}


def test_demo_force_needs_a_demonstration_with_force_columns(tmp_path):
    from conftest import INSERTION_DEMO

    from hlcmp_drake.io.demos import read_demonstration, write_trajectory

    forced = GOOD.replace("trials: 2", "trials: 2\ndemo_force: true")
    tasks = plan_library_tasks(load_library_spec(write(tmp_path, forced)), tmp_path / "out")
    assert all(task.demo_force for task in tasks)  # the bundled demonstration has its force
    t, positions, axes = read_demonstration(INSERTION_DEMO)
    plain = write_trajectory(tmp_path / "positions.csv", t, positions, axes)
    text = forced.replace("set:\n", f"set:\n  reference.file: {plain}\n")
    path = write(tmp_path, text)
    result = run_cli("library", path, "--out", tmp_path / "L")
    assert one_line_error(result) == (
        f"hlcmp: error: {path}:3: demo_force: the demonstration {plain} has no force columns "
        "(fx,fy,fz) to start the feed-forward from"
    )
    assert not (tmp_path / "L").exists()


def test_a_library_file_plans_every_combination_with_numbers_as_queries(tmp_path):
    spec = load_library_spec(write(tmp_path, GOOD))
    tasks = plan_library_tasks(spec, tmp_path / "out")
    assert [t.query for t in tasks][:2] == [
        {"task.puncture.depth_m": 0.01, "task.puncture.hole_friction_N_per_m": 60.0},
        {"task.puncture.depth_m": 0.01, "task.puncture.hole_friction_N_per_m": 90.0},
    ]
    assert len(tasks) == 6
    scenario = load_scenario_text(tasks[-1].scenario_yaml, tasks[-1].scenario_path)
    assert scenario.task.puncture.depth_m == 0.015 and scenario.duration_s == 0.3
    assert tasks[0].run_dir == str(tmp_path / "out" / "skills" / tasks[0].id)
    assert tasks[0].overrides[0] == "duration_s=0.3"


def test_a_grid_in_scientific_notation_holds_numbers_as_a_sweeps_does(tmp_path):
    """PyYAML (YAML 1.1) reads 1e-2 as text; the scenario loader (Drake's YAML), and so a
    sweep's grid, as a number: a library's grid reads it as they do."""
    text = GOOD.replace("[0.010, 0.015]", "[1e-2, 1.5E-2]")
    tasks = plan_library_tasks(load_library_spec(write(tmp_path, text)), tmp_path / "out")
    assert [t.query["task.puncture.depth_m"] for t in tasks[::3]] == [0.01, 0.015]
    assert tasks[0].id.startswith("depth_m=1e-2,")
    scenario = load_scenario_text(tasks[0].scenario_yaml, tasks[0].scenario_path)
    assert scenario.task.puncture.depth_m == 0.01


@pytest.mark.parametrize(
    "text, line, expected",
    [
        (GOOD.replace("trials: 2", "trials: 0"), 2, "trials: must be between 1 and 100"),
        (GOOD.replace("[0.010, 0.015]", "[0.010]"), 6, "needs at least two values"),
        (GOOD.replace("[0.010, 0.015]", "[0.010, abc]"), 6, "must be a finite number, got abc"),
        (GOOD.replace("[0.010, 0.015]", "[0.010, 0.010]"), 6, "lists a value twice"),
        (GOOD.replace("[0.010, 0.015]", "[1e-2, 0.010]"), 6, "lists a value twice"),
        (
            "scenario: insertion\ngrid:\n  reference.duration_s: [0.5, 0]\n",
            3,
            "grid: 'reference.duration_s': 0 means as demonstrated, not a duration the skills "
            "can be regressed on: give the demonstration's duration in seconds",
        ),
        (GOOD.replace("task.puncture.depth_m:", "task.puncture.nope:"), 6, "no field 'nope'"),
        (
            GOOD.replace("task.puncture.depth_m:", "dmp.smoothing_s:"),
            6,
            "grid: 'dmp.smoothing_s': the DMP's settings are no task parameter",
        ),
        (GOOD.replace("scenario: insertion", "scenario: nowhere"), 1, "not a bundled scenario"),
        (
            "scenario: one_dof\ngrid:\n  controllers.hlcmp.pi: [1.0, 5.0]\n",
            1,
            "scenario: scenario 'one_dof' does not follow a demonstration",
        ),
        (GOOD.replace("trials: 2", "trails: 2"), 2, "trails"),
        (
            GOOD.replace("trials: 2", "trials: 2\ndemo_force: yes please"),
            3,
            "demo_force: must be true or false, got 'yes please'",
        ),
        (GOOD.replace("  duration_s: 0.3", "  task.puncture.depth_m: 0.01"), 6, "also in set"),
        ("scenario: insertion\n", None, "grid: a library needs at least one task parameter"),
        ("scenario: [insertion\n", 2, "expected ',' or ']'"),
        (
            GOOD.replace("hole_friction_N_per_m: [60.0, 90, 120.0]", "depth_m: [0.02, 0.025]"),
            7,
            "'task.puncture.depth_m' is given twice in the same map (first at line 6)",
        ),
    ],
)
def test_a_bad_library_file_exits_2_naming_its_line_before_anything_runs(
    tmp_path, text, line, expected
):
    path = write(tmp_path, text)
    result = run_cli("library", path, "--out", tmp_path / "L")
    message = one_line_error(result)
    where = f"{path}:{line}:" if line else f"{path}: "
    assert where in message and expected in message, message
    assert not (tmp_path / "L").exists()


def test_bad_engine_arguments_exit_2_with_one_line(tmp_path):
    path = write(tmp_path, GOOD)
    for args, expected in [
        (["--workers", "0"], "must be at least 1"),
        (["--address", "auto"], "--address: joins a Ray cluster, so it needs --engine ray"),
        (["--engine", "spark"], "invalid choice"),
    ]:
        result = run_cli("library", path, "--out", tmp_path / "L", *args)
        assert expected in one_line_error(result)
        assert not (tmp_path / "L").exists()


def test_a_relative_demonstration_is_read_beside_the_library_file(tmp_path, monkeypatch):
    """As in a sweep file: beside the library file, from any working directory; each
    skill's overrides carry the path read, which learn applies again over its
    scenario.yaml in the skill's own folder."""
    from conftest import INSERTION_DEMO

    (tmp_path / "libs").mkdir()
    (tmp_path / "libs" / "mydemo.csv").write_bytes(INSERTION_DEMO.read_bytes())
    monkeypatch.chdir(tmp_path)
    path = write(tmp_path / "libs", GOOD.replace("set:\n", "set:\n  reference.file: mydemo.csv\n"))
    tasks = plan_library_tasks(load_library_spec(path), tmp_path / "out")
    beside = str(tmp_path / "libs" / "mydemo.csv")
    assert all(
        load_scenario_text(t.scenario_yaml, t.scenario_path).reference.file == beside for t in tasks
    )
    assert tasks[0].overrides[0] == f'reference.file="{beside}"'
