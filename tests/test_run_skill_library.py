"""hlcmp_drake.run.skill_library (`hlcmp generalize`) on synthetic libraries -- skills
written directly, no simulation: the Gaussian process recovers a smooth function of the
task parameters, its standard deviation grows away from the data, nearest picks the
nearest skill, a query is checked (each refusal exit 2, one line), and the written skill
records the world of the query, so `learn --skill` with those --set values accepts it."""

import dataclasses
import json
import pickle
import re
import shlex
from pathlib import Path

import numpy as np
import pytest
from conftest import DEMO_CSV, one_line_error, run_cli

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.world import world_of_scenario
from hlcmp_drake.core.dmp import Dmp, DmpSettings
from hlcmp_drake.io.demos import read_demonstration
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.paths import DIAGRAMS_DIR
from hlcmp_drake.io.skill import Skill, load_skill, save_skill
from hlcmp_drake.run.skill_library import EXTRAPOLATION_MARGIN, SkillLibrary

DEPTH, FRICTION = "task.puncture.depth_m", "task.puncture.hole_friction_N_per_m"


def smooth(depth, friction):
    """A smooth function of both parameters, one value per weight (shape (3, N))."""
    d, f = (depth - 0.010) / 0.005, (friction - 60.0) / 60.0
    n = np.arange(10)
    return np.sin(1.3 * d + 0.2 * n)[None, :] * (1 + 0.5 * f) + np.array([[0.0], [1.0], [2.0]])


def _dmp(tmp_path):
    demo = tmp_path / "demo.csv"
    demo.write_text(DEMO_CSV)
    t, p, axes = read_demonstration(demo)
    return Dmp.fit(t, p, axes, DmpSettings(n_basis=10))


def write_library(
    tmp_path, depths, frictions, function=smooth, goal_shift=None, demo_force=lambda depth: None
):
    """library.json and one skill per grid point, theta_v = function(query) (theta_k, theta_d
    scaled copies); with `goal_shift`, each skill's goal moves with the depth; each skill's
    demonstration force is demo_force(depth)."""
    dmp = _dmp(tmp_path)
    entries = []
    for depth in depths:
        for friction in frictions:
            identifier = f"d={depth},f={friction}"
            values = function(depth, friction)
            skill_dmp = dmp
            if goal_shift is not None:
                skill_dmp = dmp.with_goal(dmp.goal + np.array([0.0, 0.0, goal_shift * depth]))
            skill = Skill(
                skill_dmp, 100 * values, 10 * values, values, demo_force=demo_force(depth)
            )
            save_skill(tmp_path / "L" / "skills" / identifier / "skill.npz", skill)
            entries.append(
                {
                    "id": identifier,
                    "query": {DEPTH: depth, FRICTION: friction},
                    "skill": f"skills/{identifier}/skill.npz",
                    "metrics": {},
                }
            )
    return write_record(tmp_path, [DEPTH, FRICTION], entries)


def write_record(tmp_path, parameters, entries):
    """The library.json of an insertion library over `parameters` with `entries`."""
    record = {
        "format_version": 1,
        "scenario": "insertion",
        "scenario_path": str(DIAGRAMS_DIR / "insertion.yaml"),
        "set": {},
        "trials": 1,
        "parameters": parameters,
        "skills": entries,
        "not_learned": [],
    }
    (tmp_path / "L" / "library.json").write_text(json.dumps(record))
    return tmp_path / "L"


GRID = ([0.010, 0.0125, 0.015], [60.0, 90.0, 120.0])


def test_the_regression_recovers_a_smooth_function_between_the_grid_points(tmp_path):
    library = SkillLibrary.load(write_library(tmp_path, *GRID)).fit()
    for depth, friction in [(0.01125, 75.0), (0.01375, 105.0), (0.011, 110.0)]:
        query = {DEPTH: depth, FRICTION: friction}
        truth = smooth(depth, friction)
        regressed = library.predict(query).mean["theta_v"]
        nearest = library.predict(query, "nearest").mean["theta_v"]
        regression_error = np.max(np.abs(regressed - truth))
        assert regression_error < 0.05 * np.ptp(truth)
        assert regression_error < 0.5 * np.max(np.abs(nearest - truth))
        assert np.allclose(library.predict(query).mean["theta_k"], 100 * regressed, rtol=1e-6)


def test_a_library_of_pose_skills_is_refused_rather_than_stripped(tmp_path):
    from hlcmp_drake.core.orientation_dmp import OrientationDmp

    folder = write_library(tmp_path, *GRID)
    dmp = _dmp(tmp_path)
    turn = OrientationDmp(
        dmp.settings, dmp.tau, np.array([1.0, 0, 0, 0]), np.array([1.0, 0, 0, 0]),
        np.zeros(3), np.zeros((3, 10)), 1.0, False,
    )  # fmt: skip
    save_skill(folder / "skills" / "d=0.01,f=60.0" / "skill.npz", Skill.untrained(dmp, turn))
    with pytest.raises(InputError, match="are pose skills .* would drop their orientation"):
        SkillLibrary.load(folder)


def test_the_standard_deviation_grows_away_from_the_data(tmp_path):
    library = SkillLibrary.load(write_library(tmp_path, *GRID)).fit()

    def std(depth):
        return np.mean(library.predict({DEPTH: depth, FRICTION: 90.0}).std["theta_v"])

    at_a_point, between, outside = std(0.0125), std(0.01125), std(0.0155)
    assert at_a_point < between < outside
    assert std(0.020) > outside  # further out still (predict allows it; generalize refuses)


def test_nearest_returns_the_nearest_skills_arrays(tmp_path):
    library = SkillLibrary.load(write_library(tmp_path, *GRID))
    prediction = library.predict({DEPTH: 0.0121, FRICTION: 65.0}, "nearest")
    assert prediction.nearest == "d=0.0125,f=60.0" and prediction.std is None
    assert np.array_equal(prediction.mean["theta_v"], smooth(0.0125, 60.0))


def test_a_library_whose_goal_moves_regresses_the_dmp_too(tmp_path):
    library = SkillLibrary.load(write_library(tmp_path, *GRID, goal_shift=2.0))
    assert "goal" in library.fields
    skill, prediction, _ = library.generalize({DEPTH: 0.01125, FRICTION: 90.0})
    first = library.skills[0].dmp.goal
    span = 2.0 * (0.015 - 0.010)  # the library's goals span 10 mm in z
    truth = first[2] + 2.0 * (0.01125 - 0.010)
    assert skill.dmp.goal[2] == pytest.approx(truth, abs=0.05 * span)
    assert np.array_equal(skill.dmp.goal[:2], first[:2])
    assert "goal" in prediction.std


def test_the_written_skill_loads_and_records_the_querys_world(tmp_path):
    folder = write_library(tmp_path, *GRID)
    out = tmp_path / "s.npz"
    result = run_cli(
        "generalize",
        folder,
        "--query",
        f"{DEPTH}=0.01125",
        "--query",
        f"{FRICTION}=90",
        "--out",
        out,
    )
    assert result.returncode == 0, result.stderr
    skill = load_skill(out)
    scenario, _ = load_scenario("insertion", [f"{DEPTH}=0.01125", f"{FRICTION}=90.0"])
    assert skill.world == world_of_scenario(scenario, [f"{DEPTH}=0.01125", f"{FRICTION}=90.0"])
    other, _ = load_scenario("insertion")
    assert not skill.world.same_world(world_of_scenario(other))
    with np.load(out) as data:
        assert data["std_theta_v"].shape == skill.theta_v.shape
        assert json.loads(str(data["generalized_query"])) == {DEPTH: 0.01125, FRICTION: 90.0}
        assert str(data["generalized_method"]) == "regression"
    assert f"--set {DEPTH}=0.01125" in result.stdout
    # The commands it prints parse as written (the skill is positional for reproduce).
    from hlcmp_drake.cli import build_parser

    printed = [line.split(": ", 1)[1] for line in result.stdout.splitlines() if ": hlcmp " in line]
    assert [command.split()[1] for command in printed] == ["reproduce", "learn", "serve"]
    for command in printed:
        argv = shlex.split(command.replace("DIR", "o").replace("URL", "memq://"))[1:]
        parsed = build_parser().parse_args(argv)
        assert Path(parsed.skill) == out
        assert parsed.set == [f"{DEPTH}=0.01125", f"{FRICTION}=90.0"]


def test_a_generalized_skill_refused_in_another_world_says_which_sets_make_its_own(tmp_path):
    """Replayed without the query's --set, the skill is refused with the overrides that
    make its world (the library's fixed ones that are not the world's left out)."""
    from hlcmp_drake.run.learning import check_skill_world

    library = SkillLibrary.load(write_library(tmp_path, *GRID))
    skill, _, _ = library.generalize({DEPTH: 0.01125, FRICTION: 90.0})
    save_skill(tmp_path / "s.npz", skill)
    loaded = load_skill(tmp_path / "s.npz")
    assert loaded.world.overrides == (f"{DEPTH}=0.01125", f"{FRICTION}=90.0")
    with pytest.raises(InputError) as error:
        check_skill_world(loaded, load_scenario("insertion")[0])
    assert str(error.value).startswith(
        f"the skill was learned in 'insertion' with --set {DEPTH}=0.01125 --set "
        f"{FRICTION}=90.0 (ArmTask world "
    )
    here, _ = load_scenario("insertion", list(loaded.world.overrides))
    assert check_skill_world(loaded, here) is None


def test_a_library_over_the_skills_tau_regresses_it(tmp_path):
    """A library whose grid varies reference.duration_s: each skill is saved at the tau it
    learned at, and the skill at a query between two has the tau between them."""
    folder = write_library(tmp_path, *GRID)
    for k, path in enumerate(sorted((folder / "skills").glob("*/skill.npz"))):
        skill = load_skill(path)
        slower = dataclasses.replace(skill.dmp, tau=6.0 + 0.5 * (k // 3))  # by depth
        save_skill(path, dataclasses.replace(skill, dmp=slower))
    library = SkillLibrary.load(folder)
    assert "tau" in library.fields
    skill, _, _ = library.generalize({DEPTH: 0.01125, FRICTION: 90.0})
    assert 6.0 < skill.dmp.tau < 6.5 and isinstance(skill.dmp.tau, float)


@pytest.mark.parametrize(
    "method, extrapolate", [("regression", False), ("regression", True), ("nearest", False)]
)
def test_a_library_over_reference_duration_gives_the_querys_duration_as_tau(
    tmp_path, method, extrapolate
):
    """Each skill of a library over reference.duration_s was saved at that duration: the
    skill at a query has the query's tau, not a regression's near it (30 s gave 26.41 s)."""
    key, durations = "reference.duration_s", [6.0, 8.5, 11.0]
    dmp, entries = _dmp(tmp_path), []
    for duration in durations:
        values = smooth(duration / 1000.0, 90.0)
        skill = Skill(dataclasses.replace(dmp, tau=duration), 100 * values, 10 * values, values)
        identifier = f"duration_s={duration}"
        save_skill(tmp_path / "L" / "skills" / identifier / "skill.npz", skill)
        entries.append(
            {"id": identifier, "query": {key: duration}, "skill": f"skills/{identifier}/skill.npz",
             "metrics": {}}
        )  # fmt: skip
    folder = write_record(tmp_path, [key], entries)
    query = 11.5 if extrapolate else 7.3
    skill, _, _ = SkillLibrary.load(folder).generalize(
        {key: query}, method=method, extrapolate=extrapolate
    )
    assert skill.dmp.tau == query and isinstance(skill.dmp.tau, float)


def test_generalize_prints_the_length_scales(tmp_path):
    folder = write_library(tmp_path, *GRID)
    result = run_cli(
        "generalize", folder, "--query", f"{DEPTH}=0.01125", "--query", f"{FRICTION}=90",
        "--out", tmp_path / "s.npz",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    lines = [line for line in result.stdout.splitlines() if line.startswith("  theta_v:")]
    assert len(lines) == 1 and "; length scales depth_m " in lines[0]
    assert ", hole_friction_N_per_m " in lines[0]


@pytest.mark.parametrize(
    "force, kept",
    [
        (lambda depth: np.full((3, 10), 2.0), True),  # one demonstration's force: kept
        (lambda depth: None, False),
        (lambda depth: np.full((3, 10), depth), False),  # no one demonstration: none kept
    ],
)
def test_the_generalized_skill_keeps_the_demonstrations_force(tmp_path, force, kept):
    library = SkillLibrary.load(write_library(tmp_path, *GRID, demo_force=force))
    skill, _, _ = library.generalize({DEPTH: 0.01125, FRICTION: 90.0})
    if kept:
        np.testing.assert_array_equal(skill.demo_force, np.full((3, 10), 2.0))
        saved = load_skill(save_skill(tmp_path / "s.npz", skill))
        np.testing.assert_array_equal(saved.demo_force, skill.demo_force)
    else:
        assert skill.demo_force is None


@pytest.mark.parametrize(
    "queries, expected",
    [
        ([f"{DEPTH}=0.012", f"{FRICTION}=90", "duration_s=3"], "--query duration_s: the library "),
        ([f"{DEPTH}=0.012"], f"--query: missing {FRICTION}"),
        ([f"{DEPTH}=0.012", f"{FRICTION}=200"], "outside the library's range [60, 120]"),
        ([f"{DEPTH}=0.012", f"{FRICTION}=abc"], f"--query {FRICTION}=abc: expected one finite "),
        ([f"{DEPTH}=0.012", f"{DEPTH}=0.013", f"{FRICTION}=90"], "given twice"),
        ([f"{DEPTH}=0.012", f"{FRICTION}=nan"], f"--query {FRICTION}=nan: expected one finite "),
    ],
)
def test_a_bad_query_exits_2_with_one_line_and_writes_nothing(tmp_path, queries, expected):
    folder = write_library(tmp_path, *GRID)
    args = [a for q in queries for a in ("--query", q)]
    result = run_cli("generalize", folder, *args, "--out", tmp_path / "s.npz")
    assert expected in one_line_error(result)
    assert not (tmp_path / "s.npz").exists()


@pytest.mark.parametrize("text", ["11mm", "0.011,0.012", "", "inf"])
def test_a_query_value_that_is_not_one_number_is_refused_in_one_form(tmp_path, text):
    """A unit typed with the value and two values read alike, as the library names a value
    it refuses (`--query KEY=VALUE: ...`): they read "expected comma-separated numbers" and
    "expected one number, got '0.011,0.012'", one naming the value and the other not."""
    folder = write_library(tmp_path, *GRID)
    args = ["--query", f"{DEPTH}={text}", "--query", f"{FRICTION}=90"]
    result = run_cli("generalize", folder, *args, "--out", tmp_path / "s.npz")
    assert one_line_error(result) == (
        f"hlcmp: error: --query {DEPTH}={text}: expected one finite number"
    )
    assert not (tmp_path / "s.npz").exists()
    with pytest.raises(InputError, match=rf"^--query {DEPTH}=nan: expected one finite number$"):
        SkillLibrary.load(folder).query_vector({DEPTH: float("nan"), FRICTION: 90.0})


@pytest.mark.parametrize("text", ["1", "1e0", "1.000"])
def test_a_query_the_world_refuses_is_named_as_the_query(tmp_path, text):
    """The value as typed (the message named 1e0 and 1.000 as 1, by rewriting the override's
    text), and a query given from Python by its shortest repr; never as an override the
    user did not type."""
    folder = write_library(tmp_path, *GRID)
    args = ("--query", f"{DEPTH}={text}", "--query", f"{FRICTION}=90", "--extrapolate")
    result = run_cli("generalize", folder, *args, "--out", tmp_path / "s.npz")
    assert one_line_error(result).startswith(
        f"hlcmp: error: --query {DEPTH}={text}: puncture: depth_m must be in (0, thickness_m"
    )
    assert "override" not in result.stderr
    assert not (tmp_path / "s.npz").exists()
    library = SkillLibrary.load(folder)
    with pytest.raises(InputError, match=rf"^--query {DEPTH}=1\.0: puncture: depth_m "):
        library.generalize({DEPTH: 1.0, FRICTION: 90.0}, extrapolate=True)
    # so named also where a worker loads the world (pickled as they are)
    overrides = pickle.loads(pickle.dumps(library.overrides({DEPTH: 1.0, FRICTION: 90.0})))
    assert [(o, o.typed) for o in overrides] == [
        (f"{DEPTH}=1.0", f"--query {DEPTH}=1.0"),
        (f"{FRICTION}=90.0", f"--query {FRICTION}=90.0"),
    ]


def test_extrapolate_allows_a_query_beyond_the_margin_with_a_warning(tmp_path):
    folder = write_library(tmp_path, *GRID)
    inside = 120 + 0.9 * EXTRAPOLATION_MARGIN * 60
    ok = run_cli(
        "generalize",
        folder,
        "--query",
        f"{DEPTH}=0.012",
        "--query",
        f"{FRICTION}={inside}",
        "--out",
        tmp_path / "a.npz",
    )
    assert ok.returncode == 0 and "warning" not in ok.stderr, ok.stderr
    beyond = 120 + 1.1 * EXTRAPOLATION_MARGIN * 60
    result = run_cli(
        "generalize",
        folder,
        "--query",
        f"{DEPTH}=0.012",
        "--query",
        f"{FRICTION}={beyond}",
        "--out",
        tmp_path / "b.npz",
        "--extrapolate",
    )
    assert result.returncode == 0, result.stderr
    assert "warning" in result.stderr and "extrapolated" in result.stderr
    assert (tmp_path / "b.npz").is_file()


def test_a_folder_that_is_no_library_exits_2_with_one_line(tmp_path):
    result = run_cli("generalize", tmp_path, "--query", "a=1", "--out", tmp_path / "s.npz")
    assert "library.json: no such file" in one_line_error(result)
    (tmp_path / "a_file").write_text("")
    result = run_cli(
        "generalize", tmp_path / "a_file", "--query", "a=1", "--out", tmp_path / "t.npz"
    )
    assert one_line_error(result).endswith(
        "a_file: is a file, not a folder written by hlcmp library"
    )
    folder = write_library(tmp_path, [0.010], [60.0])
    result = run_cli("generalize", folder, "--query", "a=1", "--out", tmp_path / "s.npz")
    assert "generalising needs at least two" in one_line_error(result)


def edited_library(folder, edit):
    """library.json of `folder` after `edit(record)` (a hand edit)."""
    record = json.loads((folder / "library.json").read_text())
    edit(record)
    (folder / "library.json").write_text(json.dumps(record))
    return folder


def test_a_parameter_every_skill_shares_is_left_out_of_the_regression(tmp_path):
    """The skills at a parameter's other values went unstable (none saved): every skill
    has one value of it, which tells the regression nothing. It is left out of the inputs
    (no zero span to normalise by); a query must give that value, or --extrapolate."""
    folder = write_library(tmp_path, [0.010, 0.0125, 0.015], [90.0])
    args = ["generalize", folder, "--query", f"{DEPTH}=0.01125", "--out", tmp_path / "s.npz"]
    made = run_cli(*args, "--query", f"{FRICTION}=90")
    assert made.returncode == 0, made.stderr
    assert np.isfinite(load_skill(tmp_path / "s.npz").theta_v).all()
    scales = [line for line in made.stdout.splitlines() if line.startswith("  theta_v:")]
    assert len(scales) == 1 and re.search(r"; length scales depth_m [0-9.e+-]+$", scales[0])
    elsewhere = run_cli(*args, "--query", f"{FRICTION}=100")
    assert one_line_error(elsewhere) == (
        f"hlcmp: error: --query {FRICTION}=100: every skill of the library was learned at 90: "
        "nothing is known of other values (the regression leaves it out); pass --extrapolate "
        "to predict there all the same"
    )
    extrapolated = run_cli(*args, "--query", f"{FRICTION}=100", "--extrapolate")
    assert extrapolated.returncode == 0 and "extrapolated" in extrapolated.stderr
    library = SkillLibrary.load(folder)
    assert library.regressed == [DEPTH]
    skill, prediction, notes = library.generalize({DEPTH: 0.01125, FRICTION: 90.0})
    assert np.isfinite(prediction.std["theta_v"]).all()
    assert all(FRICTION not in note for note in notes)
    nearest = library.predict({DEPTH: 0.0126, FRICTION: 90.0}, "nearest").nearest
    assert nearest == "d=0.0125,f=90.0"


def test_two_skills_at_one_query_are_refused_in_one_line(tmp_path):
    folder = write_library(tmp_path, [0.010, 0.015], [90.0])

    def same_query(record):
        record["skills"][1]["query"] = dict(record["skills"][0]["query"])

    edited_library(folder, same_query)
    result = run_cli(
        "generalize", folder, "--query", f"{DEPTH}=0.01", "--query", f"{FRICTION}=90",
        "--out", tmp_path / "s.npz",
    )  # fmt: skip
    assert one_line_error(result) == (
        f"hlcmp: error: {folder / 'library.json'}: skills[1]: 'd=0.015,f=90.0' has the query "
        "of 'd=0.01,f=90.0'; a library holds one skill per query"
    )
    assert not (tmp_path / "s.npz").exists()


def _set_query(value):
    def edit(record):
        record["skills"][1]["query"][DEPTH] = value

    return edit


@pytest.mark.parametrize(
    "edit, expected",
    [
        (_set_query("abc"), f"skills[1] ('d=0.015,f=60.0'): query {DEPTH}: must be a number"),
        (_set_query(True), f"query {DEPTH}: must be a number, got true"),
        (_set_query(None), f"query {DEPTH}: must be a number, got null"),
        (_set_query(float("nan")), f"query {DEPTH}: must be finite"),
        (lambda record: record["skills"][1]["query"].pop(DEPTH), f"query {DEPTH}: missing"),
        (lambda record: record["skills"][0].pop("skill"), "skills[0]: missing key 'skill'"),
        (
            lambda record: record["skills"][0].update(skill=3),
            "skills[0]: 'skill' must be a string, got a number",
        ),
        (
            lambda record: record["skills"].__setitem__(0, "x"),
            "skills[0]: must be an object, got a string",
        ),
        (lambda record: record.update(skills={}), "'skills' must be an array, got an object"),
        (lambda record: record.update(parameters=[1]), "'parameters' must list the task"),
        (lambda record: record.update(set=[]), "'set' must be an object, got an array"),
        (lambda record: record.pop("scenario_path"), "missing key 'scenario_path'"),
        (lambda record: record.update(controller=1), "'controller' must be a string"),
    ],
)
def test_a_hand_edited_library_json_is_refused_in_one_line(tmp_path, edit, expected):
    folder = edited_library(write_library(tmp_path, [0.010, 0.015], [60.0]), edit)
    result = run_cli(
        "generalize", folder, "--query", f"{DEPTH}=0.012", "--query", f"{FRICTION}=60",
        "--out", tmp_path / "s.npz",
    )  # fmt: skip
    line = one_line_error(result)
    assert line.startswith(f"hlcmp: error: {folder / 'library.json'}: ") and expected in line
    assert not (tmp_path / "s.npz").exists()


def test_a_library_json_that_is_no_object_is_refused_in_one_line(tmp_path):
    folder = tmp_path / "L"
    folder.mkdir()
    (folder / "library.json").write_text("[1, 2]")
    result = run_cli("generalize", folder, "--query", "a=1", "--out", tmp_path / "s.npz")
    assert one_line_error(result).endswith(
        "library.json: not a library.json (a JSON object written by hlcmp library)"
    )


@pytest.mark.parametrize(
    "out",
    [
        "library.json",
        "skills/d=0.01,f=60.0/skill.npz",  # a learned skill: the library would list the guess
        "skills/d=0.01,f=60.0/guess.npz",
        "../elsewhere/skill.npz",  # a skill file library.json lists outside the folder
    ],
)
def test_generalize_never_writes_over_its_librarys_files(tmp_path, out):
    folder = write_library(tmp_path, [0.010, 0.015], [60.0])
    elsewhere = tmp_path / "elsewhere" / "skill.npz"
    elsewhere.parent.mkdir()
    (folder / "skills" / "d=0.015,f=60.0" / "skill.npz").rename(elsewhere)
    edited_library(folder, lambda record: record["skills"][1].update(skill=str(elsewhere)))
    before = {path: path.read_bytes() for path in tmp_path.rglob("*") if path.is_file()}
    result = run_cli(
        "generalize", folder, "--query", f"{DEPTH}=0.012", "--query", f"{FRICTION}=60",
        "--out", folder / out,
    )  # fmt: skip
    assert one_line_error(result) == (
        f"hlcmp: error: --out {folder / out}: is a file of the library {folder} (its "
        "library.json, in its skills/ or a skill it lists); it would be overwritten: give a "
        "file outside them"
    )
    assert {path: path.read_bytes() for path in tmp_path.rglob("*") if path.is_file()} == before
    beside = run_cli(
        "generalize", folder, "--query", f"{DEPTH}=0.012", "--query", f"{FRICTION}=60",
        "--out", folder / "guess.npz",
    )  # fmt: skip
    assert beside.returncode == 0, beside.stderr  # the folder is the user's too


@pytest.mark.parametrize(
    "settings, differs",
    [
        (DmpSettings(n_basis=12), "DMP's n_basis (10 and 12)"),
        (DmpSettings(n_basis=10, smoothing_s=0.05), "DMP's smoothing_s (0.01 and 0.05)"),
    ],
)
def test_skills_of_another_dmp_are_not_regressed_and_the_setting_is_named(
    tmp_path, settings, differs
):
    """The regression needs one DMP's settings; the nearest skill is taken as it is, its
    own DMP with it."""
    folder = write_library(tmp_path, [0.010, 0.015], [60.0])
    path = folder / "skills" / "d=0.015,f=60.0" / "skill.npz"
    other = Dmp.fit(*read_demonstration(tmp_path / "demo.csv"), settings)
    save_skill(path, Skill(other, *[np.ones((3, settings.n_basis))] * 3))
    query = [f"{DEPTH}=0.014", f"{FRICTION}=60"]
    args = [a for q in query for a in ("--query", q)]
    result = run_cli("generalize", folder, *args, "--out", tmp_path / "s.npz")
    assert one_line_error(result) == (
        f"hlcmp: error: {folder}/library.json: the skills 'd=0.01,f=60.0' and "
        f"'d=0.015,f=60.0' differ in their {differs}, which cannot be regressed: the "
        "regression takes skills of one DMP's settings, axes and goal scaling (--method "
        "nearest takes a skill as it is)"
    )
    nearest = run_cli(
        "generalize", folder, *args, "--out", tmp_path / "s.npz", "--method", "nearest"
    )
    assert nearest.returncode == 0, nearest.stderr
    skill = load_skill(tmp_path / "s.npz")
    assert skill.dmp.settings == settings and np.array_equal(skill.dmp.theta_p, other.theta_p)
    assert np.array_equal(skill.theta_v, np.ones((3, settings.n_basis)))


def test_a_trend_the_regression_cannot_find_is_said(tmp_path):
    """Two depths whose skills differ: the length scale along the depth goes to its lower
    bound (normalised to zero mean, two values are +1 and -1: best explained as
    uncorrelated), so a query between
    them gets about the library's mean; `generalize` warns and says what to do. Three
    depths of the same function find the trend, and no warning."""
    (tmp_path / "two").mkdir(), (tmp_path / "three").mkdir()
    two = write_library(tmp_path / "two", [0.010, 0.015], [60.0, 120.0])
    result = run_cli(
        "generalize", two, "--query", f"{DEPTH}=0.0125", "--query", f"{FRICTION}=90",
        "--out", tmp_path / "s.npz",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    warnings = [line for line in result.stderr.splitlines() if "no trend" in line]
    assert len(warnings) == 1, result.stderr
    assert (
        f"along {DEPTH} for theta_k, theta_d, theta_v (length scale at its lower bound 0.1)"
        in (warnings[0])
    )
    assert "only 2 values of it: give it three or more, or use --method nearest" in warnings[0]
    assert FRICTION not in warnings[0]
    library = SkillLibrary.load(two)
    library.fit()
    assert library.length_scales()["theta_v"][0] == pytest.approx(0.1)
    three = SkillLibrary.load(write_library(tmp_path / "three", [0.010, 0.0125, 0.015], [60, 120]))
    _, _, notes = three.generalize({DEPTH: 0.01125, FRICTION: 90.0})
    assert notes == [] and three.length_scales()["theta_v"][0] > 0.5


def test_a_weight_that_differs_only_by_round_off_has_no_standard_deviation(tmp_path):
    """Learned weights that every skill holds at one value up to round-off (here 4e-16
    apart, as a peg library's were) are known exactly: std 0, not the unit-scale std the
    GP gives a spread it takes for none."""

    def flat_first_row(depth, friction):
        values = smooth(depth, friction)
        values[0] = 2.6e-4 + (4e-16 if depth > 0.011 else 0.0)
        return values

    library = SkillLibrary.load(write_library(tmp_path, *GRID, function=flat_first_row)).fit()
    std = library.predict({DEPTH: 0.01125, FRICTION: 90.0}).std["theta_v"]
    assert (std[0] == 0).all() and (std[1:] > 0).all()


def test_generalize_refuses_to_replace_a_trained_skill_but_replaces_a_generalized_one(tmp_path):
    """A skill trained by learn is refused as --out (as fit refuses it: its learning would
    be lost); an earlier generalized skill is a prediction, which a new query replaces."""
    from hlcmp_drake.io.skill import SkillWorld

    folder = write_library(tmp_path, [0.010, 0.015], [60.0, 120.0])
    query = ["--query", f"{DEPTH}=0.012", "--query", f"{FRICTION}=90"]
    trained = tmp_path / "my_skill.npz"  # as learn writes it: with the world it learned in
    skill = load_skill(folder / "skills" / "d=0.01,f=60.0" / "skill.npz")
    save_skill(trained, dataclasses.replace(skill, world=SkillWorld("insertion", "k", "0" * 64)))
    kept = trained.read_bytes()
    assert one_line_error(run_cli("generalize", folder, *query, "--out", trained)) == (
        f"hlcmp: error: --out {trained}: holds a skill trained by learn or reproduce, which "
        "generalize would replace with one predicted from the library: choose another path"
    )
    assert trained.read_bytes() == kept
    generalized = tmp_path / "generalized.npz"
    for value in ("0.012", "0.013"):
        query[1] = f"{DEPTH}={value}"
        result = run_cli("generalize", folder, *query, "--out", generalized)
        assert result.returncode == 0, result.stderr
    assert load_skill(generalized).world is not None  # learned, and replaced all the same


def test_a_relative_demonstration_in_the_librarys_set_is_read_beside_its_file(
    tmp_path, monkeypatch
):
    """`hlcmp library` reads a relative reference.file of its `set` beside the library
    file; generalize reads it there too (it looked beside the scenario: not found, exit 2),
    and the commands it prints name it from anywhere."""
    folder = write_library(tmp_path, *GRID)
    (tmp_path / "specs").mkdir()
    (tmp_path / "specs" / "mydemo.csv").write_text(DEMO_CSV)
    record = json.loads((folder / "library.json").read_text())
    record["set"] = {"reference.file": "mydemo.csv"}
    record["library_file"] = str(tmp_path / "specs" / "lib.yaml")
    (folder / "library.json").write_text(json.dumps(record))
    monkeypatch.chdir(tmp_path)  # neither the library file's folder nor the scenario's
    out = tmp_path / "s.npz"
    result = run_cli(
        "generalize",
        folder,
        "--query",
        f"{DEPTH}=0.01125",
        "--query",
        f"{FRICTION}=90",
        "--out",
        out,
    )
    assert result.returncode == 0, result.stderr
    beside = str(tmp_path / "specs" / "mydemo.csv")
    assert SkillLibrary.load(folder).overrides({DEPTH: 0.01125, FRICTION: 90.0})[0] == (
        f'reference.file="{beside}"'
    )
    assert beside in result.stdout  # the printed commands' --set
