"""hlcmp_drake.run.library (`hlcmp library`): a tiny library (two skills, one short trial
each) is learned on the local engine into library.json of the documented schema, each
skill recording its query's world; a rerun relearns nothing, a changed number of trials or
a lost record relearns only what changed; and the acceptance flow of the bundled library
from the command line (slow)."""

import json
import shutil
from pathlib import Path

import pytest
from conftest import INSERTION_DEMO, one_line_error, run_cli

from hlcmp_drake.config.library import load_library_spec, plan_library_tasks
from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.sweep import INPUTS_FILE
from hlcmp_drake.config.world import world_of_scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.skill import load_skill
from hlcmp_drake.run.library import (
    TASK_RECORD,
    build_library,
    library_learner,
    library_tasks,
    run_library_task,
    skill_state,
)

DEPTH = "task.puncture.depth_m"
TINY = """\
scenario: insertion
trials: {trials}
demo_force: {demo_force}
set:
  duration_s: 0.3
grid:
  task.puncture.depth_m: [0.010, 0.015]
"""


def tiny(folder, trials=1, demo_force=False):
    path = Path(folder) / "tiny_library.yaml"
    path.write_text(TINY.format(trials=trials, demo_force=str(demo_force).lower()))
    return path


@pytest.fixture(scope="session")  # a worker may run other modules' tests between its users
def tiny_library(tmp_path_factory):
    """The tiny library learned once from the command line on two local workers: (its
    file, its folder, what the command ended with). Tests change only copies of it."""
    folder = tmp_path_factory.mktemp("tiny")
    spec, out = tiny(folder), folder / "L"
    first = run_cli("library", spec, "--out", out, "--workers", "2", "--quiet")
    return spec, out, first


def copy_of(tiny_library, folder):
    """The tiny library's file and a copy of its folder (file times kept) in `folder`."""
    spec, out, _ = tiny_library
    shutil.copytree(out, folder / "L")
    return spec, folder / "L"


@pytest.mark.slow  # five library tasks in pools, after the shared library's two (about 7.5 s)
def test_a_tiny_library_is_learned_indexed_and_resumed(tiny_library, tmp_path):
    spec, out = copy_of(tiny_library, tmp_path)
    record = json.loads((out / "library.json").read_text())
    assert record["scenario"] == "insertion" and record["parameters"] == [DEPTH]
    assert record["set"] == {"duration_s": "0.3"} and record["trials"] == 1
    assert record["not_learned"] == []
    assert [entry["query"] for entry in record["skills"]] == [{DEPTH: 0.01}, {DEPTH: 0.015}]
    for entry in record["skills"]:
        assert set(entry) == {"id", "query", "skill", "metrics"}
        assert entry["skill"] == f"skills/{entry['id']}/skill.npz"
        assert entry["metrics"]["trial"] == 1 and entry["metrics"]["status"] == "ok"
        skill = load_skill(out / entry["skill"])
        scenario, _ = load_scenario("insertion", [f"{DEPTH}={entry['query'][DEPTH]}"])
        assert skill.world.same_world(world_of_scenario(scenario))  # each knows its plank
        assert [o.split("=")[0] for o in skill.world.overrides] == [DEPTH]  # and its --set
    stamps = {p: p.stat().st_mtime_ns for p in out.rglob("skill.npz")}

    again = build_library(spec, out, workers=2)
    assert again.ran == [] and again.already_done == 2 and not again.failed
    assert again.record == record  # the index of the same skills, as written before
    assert {p: p.stat().st_mtime_ns for p in out.rglob("skill.npz")} == stamps

    (out / "skills" / "depth_m=0.015" / TASK_RECORD).unlink()  # as if killed mid-learning
    partial = build_library(spec, out, workers=2)
    assert partial.ran == ["depth_m=0.015"] and partial.already_done == 1
    assert partial.record == json.loads((out / "library.json").read_text())

    # Learned from the demonstration's force: relearned, and each skill says so.
    forced = build_library(tiny(tmp_path, demo_force=True), out, workers=2)
    assert sorted(forced.ran) == ["depth_m=0.01", "depth_m=0.015"]
    assert forced.record["demo_force"] is True
    for entry in forced.record["skills"]:
        metrics = json.loads((out / "skills" / entry["id"] / "metrics.json").read_text())
        assert metrics["feedforward_from_demo_force"] is True

    more = build_library(tiny(tmp_path, trials=2, demo_force=True), out, workers=2)
    assert sorted(more.ran) == ["depth_m=0.01", "depth_m=0.015"]
    assert all(e["metrics"]["trial"] == 2 for e in more.record["skills"])


@pytest.mark.slow
@pytest.mark.xdist_group("ray")  # one local Ray instance at a time
def test_the_ray_engine_learns_the_tiny_library_as_the_local_engine_does(tmp_path):
    pytest.importorskip("ray")
    on_ray = build_library(tiny(tmp_path), tmp_path / "ray", engine="ray", workers=2)
    assert sorted(on_ray.ran) == ["depth_m=0.01", "depth_m=0.015"] and not on_ray.failed
    local = build_library(tiny(tmp_path), tmp_path / "local", workers=1)
    for ray_entry, local_entry in zip(on_ray.record["skills"], local.record["skills"]):
        assert ray_entry["query"] == local_entry["query"]
        assert ray_entry["metrics"] == local_entry["metrics"]
        ray_skill = load_skill(tmp_path / "ray" / ray_entry["skill"])
        local_skill = load_skill(tmp_path / "local" / local_entry["skill"])
        assert (ray_skill.theta_k == local_skill.theta_k).all()
        assert (ray_skill.theta_v == local_skill.theta_v).all()
    # What Ray wrote is finished for the local engine too.
    assert build_library(tiny(tmp_path), tmp_path / "ray", workers=1).ran == []


@pytest.mark.slow  # the tiny library, then the command twice (about 2.2 s)
def test_the_command_prints_the_skills_and_a_rerun_says_nothing_was_relearned(
    tiny_library, tmp_path
):
    first = tiny_library[2]
    assert first.returncode == 0, first.stderr
    assert "2 skill(s) learned" in first.stdout
    spec, out = copy_of(tiny_library, tmp_path)
    second = run_cli("library", spec, "--out", out, "--quiet")
    assert second.returncode == 0, second.stderr
    assert "all 2 skills were already learned; nothing relearned" in second.stdout
    # A generalized skill replays in its query's world (check_skill_world, which serve
    # shares), and is refused in the bundled plank's.
    made = run_cli("generalize", out, "--query", f"{DEPTH}=0.012", "--out", tmp_path / "s.npz")
    assert made.returncode == 0, made.stderr
    assert "replay it: hlcmp reproduce" in made.stdout and "--controller hlcmp " in made.stdout
    replay = ["reproduce", tmp_path / "s.npz", "--scenario", "insertion", "--freeze", "--quiet"]
    here = run_cli(
        *replay, "--set", f"{DEPTH}=0.012", "--set", "duration_s=0.3", "--out", tmp_path / "r"
    )
    assert here.returncode == 0 and "warning" not in here.stderr, here.stderr
    elsewhere = run_cli(*replay, "--set", "duration_s=0.3", "--out", tmp_path / "e")
    assert "the skill was learned in 'insertion'" in one_line_error(elsewhere)


@pytest.mark.slow
def test_the_acceptance_flow_of_the_bundled_library(tmp_path):
    # From a fresh clone: learn the bundled library, again (nothing relearned), generalize
    # between its grid points, and learn one trial from the generalized skill.
    out = tmp_path / "L"
    first = run_cli("library", "diagrams/libraries/insertion.yaml", "--out", out, "--quiet")
    assert first.returncode == 0, first.stderr
    assert json.loads((out / "library.json").read_text())["parameters"] == [
        DEPTH,
        "task.puncture.hole_friction_N_per_m",
    ]
    again = run_cli("library", "diagrams/libraries/insertion.yaml", "--out", out, "--quiet")
    assert "nothing relearned" in again.stdout, again.stdout
    query = [f"{DEPTH}=0.01125", "task.puncture.hole_friction_N_per_m=90"]
    made = run_cli(
        "generalize", out, *[a for q in query for a in ("--query", q)], "--out", tmp_path / "s.npz"
    )
    assert made.returncode == 0, made.stderr
    sets = [a for q in query for a in ("--set", q)]
    learned = run_cli(
        "learn",
        INSERTION_DEMO,
        "--scenario",
        "insertion",
        "--skill",
        tmp_path / "s.npz",
        *sets,
        "--trials",
        "1",
        "--out",
        tmp_path / "learn",
        "--quiet",
    )
    assert learned.returncode == 0 and "warning" not in learned.stderr, learned.stderr


def test_files_from_a_remote_worker_are_stored_with_the_task_record_last(tmp_path, monkeypatch):
    # A Ray node returns a skill's files; a kill while they are stored must not leave a
    # library_task.json (the finished mark) beside a missing skill.npz or metrics.json.
    from hlcmp_drake.io import outputs
    from hlcmp_drake.run.sweep import store_files

    (tmp_path / TASK_RECORD).write_text("{}")
    order = []
    real = outputs.atomic_write
    monkeypatch.setattr(
        outputs,
        "atomic_write",
        lambda path, write: order.append(Path(path).name) or real(path, write),
    )
    files = {name: b"x" for name in (TASK_RECORD, "metrics.json", "skill.npz", "scenario.yaml")}
    assert (tmp_path / TASK_RECORD).exists()
    store_files(tmp_path, files)
    assert order == ["scenario.yaml", "skill.npz", "metrics.json", TASK_RECORD]


def test_a_ray_address_with_no_cluster_is_one_line_and_writes_nothing(tmp_path):
    pytest.importorskip("ray")
    out = tmp_path / "L"
    result = run_cli(
        "library", tiny(tmp_path), "--engine", "ray", "--address", "notanaddress", "--out", out
    )
    assert one_line_error(result).startswith(
        "hlcmp: error: --address notanaddress: cannot join a Ray cluster there"
    )
    assert not out.exists()


def as_finished(task, record, metrics=None):
    """The files a finished skill's folder holds, written by hand (no learning): its
    scenario.yaml, inputs.sha256, `metrics` as metrics.json (default: its status alone),
    a stand-in skill.npz unless it went unstable, and `record` as library_task.json."""
    run_dir = Path(task.run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    status = record.get("status", "ok")
    (run_dir / "scenario.yaml").write_text(task.scenario_yaml)
    (run_dir / INPUTS_FILE).write_text(task.inputs_digest + "\n")
    (run_dir / "metrics.json").write_text(json.dumps(metrics or {"status": status}))
    if status == "ok":
        (run_dir / "skill.npz").write_bytes(_skill_bytes())
    (run_dir / TASK_RECORD).write_text(json.dumps(record))


_SKILL_BYTES: list = []


def _skill_bytes():
    """A readable skill file (the insertion demonstration's untrained skill), made once."""
    if not _SKILL_BYTES:
        import tempfile

        from hlcmp_drake.core.dmp import Dmp
        from hlcmp_drake.io.demos import read_demonstration
        from hlcmp_drake.io.skill import Skill, save_skill

        t, positions, axes = read_demonstration(INSERTION_DEMO)
        dmp = Dmp.fit(t, positions, axes, load_scenario("insertion")[0].dmp)
        with tempfile.TemporaryDirectory() as folder:
            path = save_skill(Path(folder) / "skill.npz", Skill.untrained(dmp))
            _SKILL_BYTES.append(path.read_bytes())
    return _SKILL_BYTES[0]


def test_skills_that_ended_unstable_are_counted_apart_with_their_reasons(tmp_path, monkeypatch):
    """An unstable skill saved none: `hlcmp library` does not count it as learned, and
    prints its reason (its metrics.json's) on its line; so does a rerun."""
    import hlcmp_drake.run.library as library
    from hlcmp_drake.cli import EXIT_UNSTABLE

    why = "joint torques saturated for more than max_saturation_s = 0.2 s"

    def learned_by_hand(function, tasks, workers, on_done):  # no simulation: 0.01 unstable
        for task in tasks:
            status = "unstable" if task.query[DEPTH] == 0.01 else "ok"
            metrics = {
                "status": status,
                "trials": [{"trial": 1, "mean_abs_position_error_m": {"x": 0.001}}],
                "instability": {"trial_1": {"reason": why, "time_s": 0.21}},
            }
            record = {"trials": 1, "demo_force": False, "controller": "hlcmp", "status": status}
            as_finished(task, record, metrics)
            on_done(task, {"status": status, "wall_s": 0.1}, None)

    monkeypatch.setattr(library, "run_in_processes", learned_by_hand)
    spec = tiny(tmp_path)
    for summary in [
        "1 skill(s) learned, 1 unstable (no skill saved), 0 already learned; ",
        "all 2 skills were already run, 1 of them unstable (no skill saved); nothing relearned",
    ]:
        result = run_cli("library", spec, "--out", tmp_path / "L", "--quiet")
        assert result.returncode == EXIT_UNSTABLE, result.stderr
        lines = result.stdout.splitlines()
        assert f"  depth_m=0.01: UNSTABLE, no skill saved: trial 1: {why} at t = 0.210 s" in lines
        assert lines[-2].startswith(summary), result.stdout
        assert lines[-1].endswith("library.json (1 skill)")


def test_a_finished_skill_whose_file_is_lost_or_damaged_is_learned_again(tmp_path):
    """A skill is finished only while library.json's files of it are there and read: its
    metrics.json, and its skill.npz unless it went unstable (and saved none)."""
    ok, unstable = library_tasks(load_library_spec(tiny(tmp_path)), tmp_path / "L")
    record = {"trials": 1, "demo_force": False, "controller": "hlcmp"}
    as_finished(ok, {**record, "status": "ok"})
    as_finished(unstable, {**record, "status": "unstable"})
    assert skill_state(ok) == "done" and skill_state(unstable) == "done"
    skill = Path(ok.run_dir) / "skill.npz"
    skill.write_bytes(skill.read_bytes()[: skill.stat().st_size // 2])  # damaged: generalize
    assert skill_state(ok) == "stale"  # would refuse it
    skill.unlink()
    assert skill_state(ok) == "stale"
    (Path(unstable.run_dir) / "metrics.json").write_text("{")
    assert skill_state(unstable) == "stale"
    (Path(unstable.run_dir) / "metrics.json").unlink()
    assert skill_state(unstable) == "stale"


def test_a_skill_whose_demonstration_changed_is_learned_again(tmp_path):
    """A skill's scenario.yaml names its demonstration by path: it is finished only while
    the demonstration holds what it was learned from (inputs.sha256)."""
    from hlcmp_drake.io.paths import DIAGRAMS_DIR

    demo = tmp_path / "demo.csv"
    demo.write_bytes(INSERTION_DEMO.read_bytes())
    text = (DIAGRAMS_DIR / "insertion.yaml").read_text()
    (tmp_path / "mine.yaml").write_text(
        text.replace("file: demos/insertion_demo.csv", "file: demo.csv")
    )
    spec = tmp_path / "lib.yaml"
    spec.write_text(
        "scenario: mine.yaml\ntrials: 1\ngrid:\n  task.puncture.depth_m: [0.01, 0.015]\n"
    )

    def first_task():
        return library_tasks(load_library_spec(spec), tmp_path / "L")[0]

    task = first_task()
    as_finished(task, {"trials": 1, "demo_force": False, "controller": "hlcmp"})
    assert skill_state(task) == "done"
    demo.write_bytes(INSERTION_DEMO.read_bytes() + b"\n")
    assert skill_state(first_task()) == "stale"


PEG = """\
scenario: peg_in_hole
trials: 1
{controller}
set:
  duration_s: 0.3
grid:
  reference.duration_s: [6.5, 7.5]
"""


def _peg_tasks(folder, controller=""):
    path = Path(folder) / "peg.yaml"
    path.write_text(PEG.format(controller=f"controller: {controller}" if controller else ""))
    spec = load_library_spec(path)
    return spec, plan_library_tasks(spec, Path(folder) / "L")


def test_the_learner_is_the_scenarios_first_in_its_own_order_or_the_one_named(tmp_path):
    """A YAML dump sorts the controllers by label: peg_in_hole's skills were learned by
    'hlcmp', its second learner, where `hlcmp learn` takes 'hlcmp_6d', its first."""
    spec, tasks = _peg_tasks(tmp_path)
    assert library_learner(spec, tasks[0]) == "hlcmp_6d"
    spec, tasks = _peg_tasks(tmp_path, "hlcmp")
    assert library_learner(spec, tasks[0]) == "hlcmp"
    spec, tasks = _peg_tasks(tmp_path, "const_6d_stiff")
    with pytest.raises(InputError, match=r"peg.yaml:3: controller: 'const_6d_stiff' is not a"):
        library_learner(spec, tasks[0])


def test_a_skill_learned_before_the_learner_was_recorded_is_kept_only_if_it_is_the_same(
    tmp_path,
):
    """A record without `controller` was learned by the first learner of its sorted
    scenario.yaml: kept for the insertion (hlcmp either way), learned again for the peg."""
    peg = library_tasks(*_peg_tasks(tmp_path)[:1], tmp_path / "L")[0]
    insertion = library_tasks(load_library_spec(tiny(tmp_path)), tmp_path / "I")[0]
    for task in (peg, insertion):
        record = {"id": task.id, "trials": task.trials, "demo_force": False, "status": "ok"}
        as_finished(task, record)
    assert skill_state(peg) == "stale" and skill_state(insertion) == "done"
    (Path(peg.run_dir) / TASK_RECORD).write_text(json.dumps({**record, "controller": "hlcmp_6d"}))
    assert skill_state(peg) == "done"


def test_a_peg_skill_is_learned_by_its_learner(tmp_path):
    task = library_tasks(_peg_tasks(tmp_path)[0], tmp_path / "L")[0]
    info = run_library_task(task)
    assert info["controller"] == "hlcmp_6d" and info["status"] == "ok"
    metrics = json.loads((Path(task.run_dir) / "metrics.json").read_text())
    assert metrics["controller"] == "hlcmp_6d"
    assert load_skill(Path(task.run_dir) / "skill.npz").theta_kr is not None  # a 6-D skill
