"""hlcmp learn / reproduce: skills as files, repeated trials, frozen replays."""

import dataclasses as dc
import json

import numpy as np
import pytest
from conftest import INSERTION_DEMO, assert_output_names, run_cli

from hlcmp_drake.cli import main
from hlcmp_drake.core.dmp import basis_centers_and_widths, normalized_basis, phase_at
from hlcmp_drake.io.paths import DIAGRAMS_DIR
from hlcmp_drake.io.skill import load_skill


@pytest.fixture(scope="module")
def short_world():
    """The insertion world cut to 4.5 s (approach and the start of the push), as arguments."""
    return ["--scenario", "insertion", "--set", "duration_s=4.5"]


@pytest.fixture(scope="module")
def learned(short_world, tmp_path_factory):
    out = tmp_path_factory.mktemp("learned")
    assert (
        main(
            [
                "learn",
                str(INSERTION_DEMO),
                *short_world,
                "--trials",
                "2",
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    return out


@pytest.mark.slow
def test_two_trials_each_continuing_from_the_last(learned):
    metrics = json.loads((learned / "metrics.json").read_text())
    assert metrics["status"] == "ok" and [row["trial"] for row in metrics["trials"]] == [1, 2]
    for row in metrics["trials"]:
        assert set(row) == {
            "trial",
            "status",
            "mean_abs_position_error_m",
            "mean_abs_force_N",
            "force_smoothness_N",
            "effort_N",
            "task",
        }
        # Cut to 4.5 s, the run ends before the tool reaches the tear depth.
        assert row["task"]["done"] is False and row["task"]["tear_s"] is None
        assert "did not go through the plank" in row["task"]["evidence"]
    assert set(metrics["improves_over_trials"]) == {
        "position_error",
        "mean_force",
        "smoothness_z",
        "effort",
    }
    data = np.load(learned / "timeseries.npz")
    # Trial 2 starts with the stiffness trial 1 ended with: not zero, unlike trial 1.
    assert data["trial_1/Ks"][0].max() == 0.0 and data["trial_2/Ks"][0].max() > 0.0
    assert (learned / "figures" / "trials.png").exists() and (learned / "recording.html").exists()
    skill = load_skill(learned / "skill.npz")
    assert skill.theta_k.shape == (3, 30) and np.abs(skill.theta_k).max() > 0


@pytest.mark.slow
def test_frozen_reproduction_keeps_the_learned_profiles(learned, short_world, tmp_path, capsys):
    out = tmp_path / "replay"
    assert (
        main(
            [
                "reproduce",
                str(learned / "skill.npz"),
                *short_world,
                "--freeze",
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["adaptation"] == "frozen" and not (out / "skill.npz").exists()
    assert metrics["controller"] == "hlcmp" and metrics["overrides"] == ["duration_s=4.5"]
    task_line = next(
        line for line in capsys.readouterr().out.splitlines() if line.startswith("task")
    )
    assert task_line.startswith("task (hlcmp): NOT done -- ")  # one replay: no trial number
    skill = load_skill(learned / "skill.npz")
    data = np.load(out / "timeseries.npz")
    centers, widths = basis_centers_and_widths(
        skill.dmp.settings.n_basis, skill.dmp.settings.alpha_s
    )
    for k in (0, 150, 300, 440):
        s = phase_at(data["t"][k], skill.dmp.tau, skill.dmp.settings.alpha_s)
        np.testing.assert_allclose(
            data["trial_1/Ks"][k],
            skill.theta_k @ normalized_basis(s, centers, widths),
            rtol=1e-3,
            atol=1e-6,
        )


def test_a_skill_of_other_axes_is_refused(tmp_path, short_world, capsys):
    demo = tmp_path / "xz.csv"
    demo.write_text(
        "t,x,z\n" + "".join(f"{k * 0.1:.1f},{0.6 + 0.001 * k:.3f},0.4\n" for k in range(20))
    )
    assert main(["fit", str(demo), "--out", str(tmp_path / "xz.npz")]) == 0
    capsys.readouterr()
    assert (
        main(["reproduce", str(tmp_path / "xz.npz"), *short_world, "--out", str(tmp_path / "o")])
        == 2
    )
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "the skill's axes (x,z) do not match" in error[0]


def test_effort_and_improvement_by_hand():
    from types import SimpleNamespace

    from hlcmp_drake.run.learning import effort, improvement

    run = SimpleNamespace(
        series={
            "u": np.array([[1.0, -2.0, 0.0], [3.0, 0.0, 1.0]]),
            "v": np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 1.0]]),
        }
    )
    # mean |u + v| per axis: x (2 + 2)/2 = 2, y (2 + 0)/2 = 1, z (0 + 2)/2 = 1 -> 4
    assert effort(run) == 4.0

    def row(error, force, smooth, work):
        return {
            "mean_abs_position_error_m": {"x": error, "y": 0.0, "z": 0.0},
            "mean_abs_force_N": {"x": force, "y": 0.0, "z": 0.0},
            "force_smoothness_N": {"x": 0.0, "y": 0.0, "z": smooth},
            "effort_N": work,
        }

    assert improvement([row(2.0, 1.0, 5.0, 1.0)]) is None
    assert improvement([row(2.0, 1.0, 5.0, 1.0), row(1.0, 2.0, 4.0, 3.0)]) == {
        "position_error": True,
        "mean_force": False,
        "smoothness_z": True,
        "effort": False,
    }


# --- how long a trial lasts ----------------------------------------------------------


def resampled_demo(path, seconds, source=INSERTION_DEMO):
    """The bundled insertion demonstration played in `seconds` (same path), 100 Hz."""
    from hlcmp_drake.io.demos import read_demonstration, write_trajectory

    t, positions, axes = read_demonstration(source)
    new_t = np.linspace(0.0, seconds, int(round(100 * seconds)) + 1)
    scaled = t * seconds / t[-1]
    resampled = np.column_stack([np.interp(new_t, scaled, p) for p in positions.T])
    write_trajectory(path, new_t, resampled, axes)
    return path


class Simulated(Exception):
    """Raised in place of simulating: what would have run."""


@pytest.fixture
def no_simulation(monkeypatch):
    """run_trials replaced: records the scenario it would simulate, then stops the command."""
    seen = []

    def run_trials(scenario, dmp, trials, **_):
        seen.append(scenario)
        raise Simulated(scenario.duration_s)

    monkeypatch.setattr("hlcmp_drake.run.learning.run_trials", run_trials)
    return seen


@pytest.fixture(scope="module")
def insertion_skill(tmp_path_factory):
    """A skill of the bundled insertion demonstration (θ = 0), recorded as learned in the
    insertion world: what `hlcmp learn` would save, without the simulation."""
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.config.world import world_of_scenario
    from hlcmp_drake.io.skill import Skill, save_skill
    from hlcmp_drake.worlds.arm import fit_demonstration

    scenario, _ = load_scenario("insertion")
    skill = dc.replace(
        Skill.untrained(fit_demonstration(scenario)), world=world_of_scenario(scenario)
    )
    return save_skill(tmp_path_factory.mktemp("skill") / "insertion.npz", skill)


def test_sets_duration_sees_only_the_scenario_duration():
    from hlcmp_drake.run.learning import sets_duration

    assert sets_duration(["duration_s=4"]) and sets_duration([" duration_s = 4"])
    assert sets_duration([{"duration_s": 4}])
    assert not sets_duration([])
    assert not sets_duration(["reference.duration_s=6", "controllers.hlcmp.pi=4"])
    assert not sets_duration([{"reference.duration_s": 6}])


@pytest.mark.parametrize(
    "extra, expected",
    [
        ([], 6.0 + 1.0),  # the demonstration's 6 s and SETTLE_S
        (["--set", "duration_s=2.5"], 2.5),  # the user's, as said
        (["--set", "reference.duration_s=3"], 3.0 + 1.0),  # the DMP replayed at tau = 3 s
    ],
)
def test_learn_runs_the_demonstration_and_the_settle_time(tmp_path, no_simulation, extra, expected):
    from hlcmp_drake.run.learning import SETTLE_S

    assert SETTLE_S == 1.0
    demo = resampled_demo(tmp_path / "six.csv", 6.0)
    # The bundled insertion scenario runs 9.5 s (its own 8.5 s demonstration + 1 s).
    with pytest.raises(Simulated):
        main(["learn", str(demo), "--scenario", "insertion", "--out", str(tmp_path / "o"), *extra])
    assert no_simulation[0].duration_s == pytest.approx(expected)


def test_reproduce_runs_the_skill_and_the_settle_time(tmp_path, no_simulation):
    from hlcmp_drake.cli import main as cli
    from hlcmp_drake.core.dmp import Dmp
    from hlcmp_drake.io.demos import read_demonstration
    from hlcmp_drake.io.skill import Skill, save_skill

    t, positions, axes = read_demonstration(resampled_demo(tmp_path / "six.csv", 6.0))
    path = save_skill(tmp_path / "six.npz", Skill.untrained(Dmp.fit(t, positions, axes)))
    with pytest.raises(Simulated):
        cli(["reproduce", str(path), "--scenario", "insertion", "--out", str(tmp_path / "o")])
    assert no_simulation[0].duration_s == pytest.approx(7.0)


# --- skills know their world ---------------------------------------------------------


def test_a_skill_is_refused_in_another_world_in_one_line(
    insertion_skill, tmp_path, capsys, no_simulation
):
    args = ["reproduce", str(insertion_skill), "--scenario", "cutting", "--freeze"]
    assert main([*args, "--out", str(tmp_path / "cutting")]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1, error
    assert error[0].startswith("hlcmp: error: the skill was learned in 'insertion' (ArmTask")
    assert "not in 'cutting'" in error[0] and "--any-scenario" in error[0]
    # Moving the plank by an override makes another world, under the same name.
    moved = ["--set", "task.puncture.depth_m=0.01"]
    assert main(["reproduce", str(insertion_skill), "--scenario", "insertion", *moved,
                 "--out", str(tmp_path / "moved")]) == 2  # fmt: skip
    assert "not in this 'insertion'" in capsys.readouterr().err
    assert no_simulation == []  # refused before anything was simulated
    assert not (tmp_path / "cutting").exists()


def test_a_world_that_cannot_learn_is_refused_for_that_not_for_the_skills_world(
    insertion_skill, tmp_path, capsys, no_simulation
):
    """The 1-DOF world follows no demonstration: no skill can be used there, so its refusal
    says so, not "learned in another world (pass --any-scenario ...)", which would then
    fail all the same (serve: tests/test_run_serve.py)."""
    demo = str(DIAGRAMS_DIR / "demos" / "insertion_demo.csv")
    skill = ["--skill", str(insertion_skill)]
    for args in (
        ["reproduce", str(insertion_skill), "--scenario", "one_dof"],
        ["reproduce", str(insertion_skill), "--scenario", "one_dof", "--any-scenario"],
        ["learn", demo, "--scenario", "one_dof", *skill],
    ):
        assert main([*args, "--out", str(tmp_path / "o")]) == 2
        error = capsys.readouterr().err.strip().splitlines()
        assert error == [
            "hlcmp: error: scenario 'one_dof' does not follow a demonstration; learning and "
            "reproducing skills needs one that does, such as insertion, cutting or peg_in_hole"
        ], args
    assert no_simulation == [] and not (tmp_path / "o").exists()


def test_any_scenario_replays_it_elsewhere_with_a_warning(
    insertion_skill, tmp_path, capsys, no_simulation
):
    with pytest.raises(Simulated):
        main(["reproduce", str(insertion_skill), "--scenario", "cutting", "--any-scenario",
              "--freeze", "--out", str(tmp_path / "o")])  # fmt: skip
    assert no_simulation[0].name == "cutting"
    warning = capsys.readouterr().err.strip().splitlines()
    assert warning == [
        "hlcmp: warning: the skill was learned in 'insertion' (ArmTask world "
        f"{load_skill(insertion_skill).world.digest[:12]}), not in 'cutting' (ArmTask world "
        f"{_digest('cutting')[:12]}); used here all the same (--any-scenario)"
    ]


def _digest(name):
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.config.world import world_of_scenario

    return world_of_scenario(load_scenario(name)[0]).digest


def test_its_own_world_replays_silently(insertion_skill, tmp_path, capsys, no_simulation):
    with pytest.raises(Simulated):
        main(["reproduce", str(insertion_skill), "--scenario", "insertion", "--freeze",
              "--set", "controllers.hlcmp.pi=4", "--out", str(tmp_path / "o")])  # fmt: skip
    assert capsys.readouterr().err == ""


def test_learning_from_a_skill_of_another_world_is_refused_too(
    insertion_skill, tmp_path, capsys, no_simulation
):
    demo = str(DIAGRAMS_DIR / "demos" / "cutting_demo.csv")
    args = ["learn", demo, "--scenario", "cutting", "--out", str(tmp_path / "o")]
    assert main([*args, "--skill", str(insertion_skill)]) == 2
    assert "the skill was learned in 'insertion'" in capsys.readouterr().err
    assert main([*args, "--any-scenario"]) == 2
    assert "--any-scenario needs --skill" in capsys.readouterr().err
    assert no_simulation == []


def test_a_skill_without_a_world_is_used_with_a_warning(
    insertion_skill, tmp_path, capsys, no_simulation
):
    """A format 1 file (and a skill of hlcmp fit) records no world: replayed, with a line."""
    old = tmp_path / "old.npz"
    with np.load(insertion_skill) as data:
        arrays = {k: data[k] for k in data.files if not k.startswith("world_")}
    np.savez(old, **{**arrays, "format_version": np.array(1)})
    with pytest.raises(Simulated):
        main(["reproduce", str(old), "--scenario", "cutting", "--out", str(tmp_path / "o")])
    assert capsys.readouterr().err.strip().splitlines() == [
        "hlcmp: warning: the skill records no world (a skill of hlcmp fit, or a file saved "
        "before skill format 2): it is used in 'cutting' unchecked"
    ]


def test_check_skill_world_by_hand(insertion_skill):
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.io.errors import InputError
    from hlcmp_drake.run.learning import check_skill_world

    skill = load_skill(insertion_skill)
    insertion, cutting = (load_scenario(name)[0] for name in ("insertion", "cutting"))
    assert check_skill_world(skill, insertion) is None
    with pytest.raises(InputError, match="not in 'cutting'"):
        check_skill_world(skill, cutting)
    assert "all the same" in check_skill_world(skill, cutting, any_scenario=True)
    assert "records no world" in check_skill_world(dc.replace(skill, world=None), insertion)


# --- reproduce is itself --------------------------------------------------------------


def test_rows_are_labelled_by_the_command_that_ran_them():
    from hlcmp_drake.run.learning import run_label, trials_table

    row = {
        "trial": 1,
        "mean_abs_position_error_m": {"x": 0.001},
        "mean_abs_force_N": {"x": 1.0},
        "force_smoothness_N": {"z": 2.0},
        "effort_N": 0.5,
    }
    learned = {"command": "learn", "adaptation": "on", "trials": [row, {**row, "trial": 2}]}
    frozen = {"command": "reproduce", "adaptation": "frozen", "trials": [row]}
    adapting = {"command": "reproduce", "adaptation": "on", "trials": [row]}
    assert run_label(learned, 2) == "learn, trial 2"
    assert run_label(frozen, 1) == "reproduce --freeze"
    assert run_label(adapting, 1) == "reproduce"
    assert run_label({"adaptation": "frozen"}, 1) == "learn, trial 1"  # before "command"
    assert [r[0] for r in trials_table(adapting).rows] == ["reproduce"]
    assert [r[0] for r in trials_table(learned, frozen).rows] == [
        "learn, trial 1",
        "learn, trial 2",
        "reproduce --freeze",
    ]


def test_each_command_describes_its_own_output(capsys):
    for command, says, never in (
        ("learn", "the learned skill.npz", "unless --freeze"),
        ("reproduce", "unless --freeze", "when learning"),
    ):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert says in text and never not in text
        assert "--any-scenario" in text


@pytest.mark.slow
def test_a_short_skill_runs_its_own_time_and_records_its_world(tmp_path):
    """A 2 s demonstration (the bundled one's approach) in the 9.5 s insertion scenario:
    learning and the frozen replay run 2 + 1 s; the skill records the insertion world;
    after the demonstration the frozen profiles are the last basis function's weights."""
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.config.world import world_of_scenario
    from hlcmp_drake.io.demos import read_demonstration, write_trajectory

    t, positions, axes = read_demonstration(INSERTION_DEMO)
    keep = t <= 2.0 + 1e-9
    demo = write_trajectory(tmp_path / "approach.csv", t[keep], positions[keep], axes)
    per_step = ["--set", "controllers.hlcmp.q_units=per_step"]  # profiles worth looking at
    world = ["--scenario", "insertion", *per_step, "--quiet"]
    assert main(["learn", str(demo), *world, "--out", str(tmp_path / "learn")]) == 0
    skill = load_skill(tmp_path / "learn" / "skill.npz")
    assert skill.dmp.tau == pytest.approx(2.0)
    scenario, _ = load_scenario("insertion", ["controllers.hlcmp.q_units=per_step"])
    assert skill.world == world_of_scenario(scenario)
    assert main(["reproduce", str(tmp_path / "learn" / "skill.npz"), *world, "--freeze",
                 "--out", str(tmp_path / "frozen")]) == 0  # fmt: skip
    for out in ("learn", "frozen"):
        assert_output_names(tmp_path / out)
        metrics = json.loads((tmp_path / out / "metrics.json").read_text())
        assert metrics["duration_s"] == pytest.approx(3.0) and metrics["settle_s"] == 1.0
        assert metrics["world"]["digest"] == skill.world.digest
        assert np.load(tmp_path / out / "timeseries.npz")["t"][-1] == pytest.approx(3.0, abs=0.011)
    data = np.load(tmp_path / "frozen" / "timeseries.npz")
    late = data["t"] >= 2.0 + 0.9
    assert np.abs(skill.theta_v[:, -1]).max() > 1e-3  # a feed-forward to hold, not zero
    for series, theta in (("Ks", skill.theta_k), ("Kd", skill.theta_d), ("v", skill.theta_v)):
        np.testing.assert_allclose(
            data[f"trial_1/{series}"][late],
            np.broadcast_to(theta[:, -1], (late.sum(), 3)),
            rtol=2e-3,
            atol=1e-3 * np.abs(theta).max(),
        )


@pytest.mark.slow
def test_a_skill_learned_at_another_tau_is_saved_and_replayed_at_it(tmp_path):
    """`learn --set reference.duration_s=1.5` replays the 2 s approach at tau = 1.5 s: the
    skill it saves holds that tau, and its replay (no override) runs 1.5 + 1 s."""
    from hlcmp_drake.io.demos import read_demonstration, write_trajectory

    t, positions, axes = read_demonstration(INSERTION_DEMO)
    keep = t <= 2.0 + 1e-9
    demo = write_trajectory(tmp_path / "approach.csv", t[keep], positions[keep], axes)
    world = ["--scenario", "insertion", "--quiet"]
    faster = ["--set", "reference.duration_s=1.5"]
    assert main(["learn", str(demo), *world, *faster, "--out", str(tmp_path / "learn")]) == 0
    skill = load_skill(tmp_path / "learn" / "skill.npz")
    assert skill.dmp.tau == pytest.approx(1.5)
    replay = ["reproduce", str(tmp_path / "learn" / "skill.npz"), *world, "--freeze"]
    assert main([*replay, "--out", str(tmp_path / "frozen")]) == 0
    for out in ("learn", "frozen"):
        metrics = json.loads((tmp_path / out / "metrics.json").read_text())
        assert metrics["skill_duration_s"] == pytest.approx(1.5), out
        assert metrics["duration_s"] == pytest.approx(2.5), out


def test_a_pose_skill_is_refused_by_the_translational_scenarios(tmp_path):
    from conftest import tilted_turn

    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.core.dmp import Dmp
    from hlcmp_drake.core.orientation_dmp import OrientationDmp
    from hlcmp_drake.io.errors import InputError
    from hlcmp_drake.io.skill import Skill
    from hlcmp_drake.run.learning import check_skill_fits

    t, positions, quaternions, _ = tilted_turn(0)
    dmp = Dmp.fit(t, positions, "xyz")
    scenario, _ = load_scenario("insertion", [])
    check_skill_fits(Skill.untrained(dmp), scenario)
    with pytest.raises(InputError, match="has an orientation .* controls the translation only"):
        check_skill_fits(Skill.untrained(dmp, OrientationDmp.fit(t, quaternions)), scenario)


# --- 6-D skills (peg_in_hole's hlcmp_6d) -----------------------------------------------

PEG_DEMO = DIAGRAMS_DIR / "demos" / "peg_in_hole_demo.csv"


@pytest.fixture(scope="module")
def peg_skills(tmp_path_factory):
    """Skills of the bundled peg-in-hole demonstration (θ = 0), recorded as learned in the
    peg_in_hole world: a 6-D one (both DMPs, six weights) and a translational one."""
    import dataclasses as dc

    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.config.world import world_of_scenario
    from hlcmp_drake.io.skill import Skill, save_skill
    from hlcmp_drake.worlds.arm import fit_demonstration, fit_orientation_demonstration

    scenario, _ = load_scenario("peg_in_hole")
    world, folder = world_of_scenario(scenario), tmp_path_factory.mktemp("peg_skills")
    dmp, orientation = fit_demonstration(scenario), fit_orientation_demonstration(scenario)
    six_d = dc.replace(Skill.untrained(dmp, orientation), world=world)
    rng = np.random.default_rng(3)  # distinct weights, to see them arrive
    six_d = dc.replace(six_d, **{k: rng.uniform(0, 1, (3, 30)) for k in ("theta_kr", "theta_vr")})
    translational = dc.replace(Skill.untrained(dmp), world=world)
    return {
        "six_d": save_skill(folder / "six_d.npz", six_d),
        "translational": save_skill(folder / "translational.npz", translational),
    }


@pytest.fixture
def trials_seen(monkeypatch):
    """run_trials replaced: records what it would simulate (the scenario and its keyword
    arguments), then stops the command."""
    seen = []

    def run_trials(scenario, dmp, trials, **options):
        seen.append((scenario, dmp, options))
        raise Simulated(scenario.duration_s)

    monkeypatch.setattr("hlcmp_drake.run.learning.run_trials", run_trials)
    return seen


def test_a_6d_skill_replays_with_its_orientation_dmp_and_six_weights(
    peg_skills, tmp_path, trials_seen
):
    skill = load_skill(peg_skills["six_d"])
    with pytest.raises(Simulated):
        main(["reproduce", str(peg_skills["six_d"]), "--scenario", "peg_in_hole", "--freeze",
              "--out", str(tmp_path / "o")])  # fmt: skip
    scenario, dmp, options = trials_seen[0]
    assert list(scenario.controllers) == ["hlcmp_6d"]  # the first learner, frozen
    assert scenario.controllers["hlcmp_6d"].q_kr == [0.0] * 3
    np.testing.assert_array_equal(dmp.theta_p, skill.dmp.theta_p)
    np.testing.assert_array_equal(options["orientation_dmp"].theta, skill.orientation.theta)
    assert len(options["theta0"]) == 6
    for given, stored in zip(options["theta0"], skill.theta, strict=True):
        np.testing.assert_array_equal(given, stored)


@pytest.mark.parametrize(
    "skill, controller, expected",
    [
        (
            "translational",
            [],
            "the skill holds no rotational profiles (a translational skill), and the "
            "controller 'hlcmp_6d' of 'peg_in_hole' is a 6-D Hl-CMP",
        ),
        (
            "six_d",
            ["--controller", "hlcmp"],
            "the skill has an orientation (a 6-D skill), and the controller 'hlcmp' of "
            "'peg_in_hole' controls the translation only",
        ),
        (
            "six_d",
            ["--controller", "const_6d_stiff"],
            "--controller const_6d_stiff: scenario 'peg_in_hole' has no learning controller "
            "of that label (its learners: hlcmp_6d, hlcmp)",
        ),
    ],
)
def test_a_skill_whose_weights_do_not_fit_the_learner_is_refused_in_one_line(
    peg_skills, tmp_path, capsys, trials_seen, skill, controller, expected
):
    for command in (["reproduce", str(peg_skills[skill])],
                    ["learn", str(PEG_DEMO), "--skill", str(peg_skills[skill])]):  # fmt: skip
        args = [*command, "--scenario", "peg_in_hole", *controller, "--out", str(tmp_path / "o")]
        assert main(args) == 2
        error = capsys.readouterr().err.strip().splitlines()
        named = f"{peg_skills[skill]}: " if expected.startswith("the skill") else ""
        assert len(error) == 1 and error[0].startswith(f"hlcmp: error: {named}{expected}"), error
    assert trials_seen == [] and not (tmp_path / "o").exists()


def test_each_learner_takes_the_skill_that_fits_it(peg_skills, tmp_path, trials_seen):
    for skill, controller in (("translational", "hlcmp"), ("six_d", "hlcmp_6d")):
        with pytest.raises(Simulated):
            main(["reproduce", str(peg_skills[skill]), "--scenario", "peg_in_hole",
                  "--controller", controller, "--out", str(tmp_path / skill)])  # fmt: skip
        scenario, _, options = trials_seen[-1]
        assert list(scenario.controllers) == [controller]
        assert len(options["theta0"]) == (6 if skill == "six_d" else 3)
        assert (options["orientation_dmp"] is None) == (skill == "translational")


def test_a_6d_learner_needs_a_pose_demonstration(tmp_path, capsys, trials_seen):
    from hlcmp_drake.io.demos import read_demonstration, write_trajectory

    t, positions, axes = read_demonstration(PEG_DEMO, with_orientation=True)[:3]
    demo = write_trajectory(tmp_path / "positions.csv", t, positions, axes)
    args = ["learn", str(demo), "--scenario", "peg_in_hole", "--out", str(tmp_path / "o")]
    assert main(args) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert error == [
        f"hlcmp: error: {demo}: no orientation columns (qw,qx,qy,qz): the controller "
        "'hlcmp_6d' is a 6-D Hl-CMP, which learns along the demonstrated orientation"
    ]
    with pytest.raises(Simulated):  # the translational learner follows its positions
        main([*args, "--controller", "hlcmp"])
    assert trials_seen[0][2]["theta0"] is None


@pytest.mark.slow
def test_a_6d_skill_learned_over_two_trials_replays_frozen(tmp_path):
    """hlcmp_6d on peg_in_hole, 2 trials of 0.3 s (the approach): the skill holds both
    DMPs and six weights; trial 2 starts where trial 1 ended; the frozen replay's profiles
    are the skill's weights on the basis and its reference orientation the skill's DMP."""
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.config.world import world_of_scenario
    from hlcmp_drake.io.skill import SIX_D_FORMAT_VERSION

    per_step = ["--set", "controllers.hlcmp_6d.q_units=per_step"]  # profiles worth looking at
    world = ["--scenario", "peg_in_hole", *per_step, "--set", "duration_s=0.3", "--quiet"]
    args = ["learn", str(PEG_DEMO), *world, "--trials", "2", "--out", str(tmp_path / "learn")]
    assert main(args) == 0
    with np.load(tmp_path / "learn" / "skill.npz") as data:
        assert int(data["format_version"]) == SIX_D_FORMAT_VERSION
    skill = load_skill(tmp_path / "learn" / "skill.npz")
    scenario, _ = load_scenario("peg_in_hole", ["controllers.hlcmp_6d.q_units=per_step"])
    assert skill.six_d and skill.world == world_of_scenario(scenario)
    assert skill.orientation is not None and np.abs(skill.theta_kr).max() > 0
    rows = json.loads((tmp_path / "learn" / "metrics.json").read_text())["trials"]
    assert [len(row["mean_abs_orientation_error_rad"]) for row in rows] == [3, 3]
    assert [len(row["max_abs_torque_Nm"]) for row in rows] == [3, 3]
    learned = np.load(tmp_path / "learn" / "timeseries.npz")
    config = scenario.controllers["hlcmp_6d"]
    assert np.all(learned["trial_1/Kr"][0] == config.theta_kr0)
    assert np.all(learned["trial_2/Kr"][0] > config.theta_kr0)  # continued from trial 1

    assert main(["reproduce", str(tmp_path / "learn" / "skill.npz"), *world, "--freeze",
                 "--out", str(tmp_path / "frozen")]) == 0  # fmt: skip
    data = np.load(tmp_path / "frozen" / "timeseries.npz")
    centers, widths = basis_centers_and_widths(30, skill.dmp.settings.alpha_s)
    rolled_t, rolled_q, _, _ = skill.orientation.rollout(dt=0.01)
    pairs = (("Ks", skill.theta_k), ("Kr", skill.theta_kr), ("Dr", skill.theta_dr),
             ("vr", skill.theta_vr))  # fmt: skip
    for k in (0, 15, 29):
        s = phase_at(data["t"][k], skill.dmp.tau, skill.dmp.settings.alpha_s)
        for series, theta in pairs:
            np.testing.assert_allclose(
                data[f"trial_1/{series}"][k],
                theta @ normalized_basis(s, centers, widths),
                rtol=1e-6,
                atol=1e-12,
            )
        assert rolled_t[k] == pytest.approx(data["t"][k])
        np.testing.assert_allclose(data["trial_1/q_tool_d"][k], rolled_q[k], atol=1e-9)


def test_a_6d_learner_starts_from_the_demonstrated_force_and_its_rotational_theta0():
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.run.learning import demo_force_start, learning_scenario

    overrides = ["controllers.hlcmp_6d.theta_kr0=2.0", "controllers.hlcmp_6d.theta_k0=50.0"]
    scenario = learning_scenario(load_scenario("peg_in_hole", overrides)[0])
    force = np.arange(90.0).reshape(3, 30)
    theta = demo_force_start(scenario, force)
    assert [t.shape for t in theta] == [(3, 30)] * 6
    np.testing.assert_array_equal(theta[2], force)
    assert np.all(theta[0] == 50.0) and np.all(theta[3] == 2.0)
    assert np.all(theta[1] == 0.0) and not np.any(theta[4:])
    translational = learning_scenario(load_scenario("peg_in_hole")[0], controller="hlcmp")
    assert len(demo_force_start(translational, force)) == 3


def test_an_unstable_trial_says_why_and_when(tmp_path):
    """As `hlcmp run` does for a controller: the trial, the learner, the reason and the
    time, from metrics.json's `instability`."""
    absurd = "controllers.hlcmp.gain_l=[1.0e6, 1.0e6, 1.0e6]"
    learned = run_cli(
        "learn", INSERTION_DEMO, "--scenario", "insertion", "--set", absurd,
        "--set", "duration_s=0.5", "--out", tmp_path / "L", "--quiet",
    )  # fmt: skip
    assert learned.returncode == 3, learned.stderr
    problem = json.loads((tmp_path / "L" / "metrics.json").read_text())["instability"]["trial_1"]
    assert (
        f"UNSTABLE trial 1 (hlcmp): {problem['reason']} at t = {problem['time_s']:.3f} s"
        in learned.stdout
    )


@pytest.mark.slow  # an insertion learned and reproduced with all their files (about 2.9 s)
def test_reference_duration_is_checked_against_what_learn_and_reproduce_replay(tmp_path):
    """`--set reference.duration_s` rescales the user's demonstration (learn) or the skill
    (reproduce), not the scenario's 8.5 s one: 0.2 s replays the first second of the
    insertion (0.11 m/s) five times as fast, which is accepted; 0.03 s would move at 3.6
    m/s, which is refused naming the file and its own duration."""
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.core.dmp import Dmp
    from hlcmp_drake.io.demos import read_demonstration, write_trajectory
    from hlcmp_drake.io.skill import Skill, save_skill

    t, positions, axes = read_demonstration(INSERTION_DEMO)
    demo = write_trajectory(tmp_path / "ins1s.csv", t[:100], positions[:100], axes)
    dmp = Dmp.fit(t[:100], positions[:100], axes, load_scenario("insertion")[0].dmp)
    skill = save_skill(tmp_path / "first_second.npz", Skill.untrained(dmp))
    short = ["--scenario", "insertion", "--set", "duration_s=0.3", "--quiet"]
    for command, replayed, what in (
        ("learn", demo, "0.99 s demonstration ins1s.csv"),
        ("reproduce", skill, "0.99 s skill first_second.npz"),
    ):
        too_fast = run_cli(
            command, replayed, *short, "--set", "reference.duration_s=0.03", "--out", tmp_path
        )
        assert too_fast.returncode == 2 and too_fast.stderr.count("\n") == 1, too_fast.stderr
        assert f"duration_s: replays the {what} in 0.03 s, 33 times as fast" in too_fast.stderr
        out = tmp_path / command
        fast = run_cli(command, replayed, *short, "--set", "reference.duration_s=0.2", "--out", out)
        assert fast.returncode == 0, fast.stderr
        assert json.loads((out / "metrics.json").read_text())["skill_duration_s"] == 0.2
