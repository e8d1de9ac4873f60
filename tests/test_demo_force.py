"""The demonstration's force end to end: the CSV's fx,fy,fz columns (and their refusals),
the skill file's demo_force, `hlcmp fit` / `rollout` with the encoded force, and `hlcmp
learn --demo-force` starting theta_v from it."""

import json
import re
import subprocess
import sys

import numpy as np
import pytest
from conftest import INSERTION_DEMO, REPO_ROOT, one_line_error, run_cli

from hlcmp_drake.core.demo_force import feedforward_along
from hlcmp_drake.core.dmp import Dmp, phase_at
from hlcmp_drake.io.demos import read_demonstration, write_trajectory
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.paths import DIAGRAMS_DIR
from hlcmp_drake.io.skill import Skill, load_skill, save_skill

BUNDLED = [DIAGRAMS_DIR / "demos" / f"{task}_demo.csv" for task in ("insertion", "cutting")]


def rows(t, *columns):
    return "".join(
        ",".join(f"{v:.6g}" for v in values) + "\n" for values in zip(t, *columns, strict=True)
    )


T = 0.1 * np.arange(20)
X, Z = 0.5 + 0.01 * T, 0.3 - 0.02 * T
FZ = np.where(T > 1.0, 5.0, 0.0)


@pytest.mark.parametrize("source", BUNDLED, ids=lambda p: p.stem)
def test_the_bundled_demonstrations_carry_their_force(source):
    t, positions, axes, force = read_demonstration(source, with_force=True)
    assert source.read_text().splitlines()[0] == "t,x,y,z,fx,fy,fz"
    assert force.shape == positions.shape and np.abs(force[:, 2]).max() > 5.0
    # The force is the environment's on the tool: the plank resists the rod pushed down
    # into it (+z) and the block the blade cutting along +y (-y).
    assert force[:, 2].max() > 8.0
    if "cutting" in source.stem:
        assert force[:, 1].min() < -5.0


@pytest.mark.slow
def test_make_demos_records_the_bundled_forces_again_byte_for_byte(tmp_path):
    script = REPO_ROOT / "scripts" / "make_demos.py"
    result = subprocess.run(
        [sys.executable, str(script), "--out-dir", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr
    for source in BUNDLED:
        assert (tmp_path / source.name).read_bytes() == source.read_bytes(), source.name


def test_force_columns_do_not_change_the_positions_or_their_dmp(tmp_path):
    t, positions, axes, force = read_demonstration(INSERTION_DEMO, with_force=True)
    bare = write_trajectory(tmp_path / "bare.csv", t, positions, axes)
    t2, positions2, axes2, none = read_demonstration(bare, with_force=True)
    assert none is None and axes2 == axes
    np.testing.assert_array_equal(positions2, positions)
    np.testing.assert_array_equal(t2, t)
    with_force, without = Dmp.fit(t, positions, axes), Dmp.fit(t2, positions2, axes2)
    np.testing.assert_array_equal(with_force.theta_p, without.theta_p)


def test_a_pose_demonstration_carries_its_force_after_the_orientation(tmp_path):
    from conftest import tilted_turn

    t, positions, quaternions, _ = tilted_turn(seed=5)
    force = np.column_stack([np.sin(t), np.cos(t), 5.0 + 0 * t])
    demo = write_trajectory(
        tmp_path / "pose.csv", t, positions, "xyz", quaternions=quaternions, force=force
    )
    assert demo.read_text().splitlines()[0] == "t,x,y,z,qw,qx,qy,qz,fx,fy,fz"
    _, _, _, q, read = read_demonstration(demo, with_orientation=True, with_force=True)
    assert q.shape == (len(t), 4)
    np.testing.assert_allclose(read, force, rtol=1e-8)
    assert run_cli("fit", demo, "--out", tmp_path / "pose.npz").returncode == 0
    skill = load_skill(tmp_path / "pose.npz")
    assert skill.orientation is not None and skill.demo_force.shape == (3, 30)
    assert run_cli("rollout", tmp_path / "pose.npz", "--out", tmp_path / "r.csv").returncode == 0
    header = (tmp_path / "r.csv").read_text().splitlines()[0]
    assert header == "t,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz,fx,fy,fz"
    *_, rolled = read_demonstration(tmp_path / "r.csv", with_orientation=True, with_force=True)
    assert np.abs(rolled[:, 2] - 5.0).max() < 0.05


def test_a_two_axis_demonstration_has_two_force_columns(tmp_path):
    path = tmp_path / "xz.csv"
    path.write_text("t,x,z,fx,fz\n" + rows(T, X, Z, 0 * T, FZ))
    _, _, axes, force = read_demonstration(path, with_force=True)
    assert axes == ("x", "z")
    np.testing.assert_allclose(force, np.column_stack([0 * T, FZ]))


@pytest.mark.parametrize(
    "header, columns, expected",
    [
        (
            "t,x,y,z,fx,fy",
            6,
            ":1: force columns must be fx,fy,fz, one per position axis; found fx,fy",
        ),
        (
            "t,x,z,fx,fy,fz",
            6,
            ":1: force columns must be fx,fz, one per position axis; found fx,fy,fz",
        ),
        ("t,x,y,z,fz,fy,fx", 7, ":1: force columns must be fx,fy,fz"),
        ("t,fx,fy,fz,x,y,z", 7, ":1: force columns fx,fy,fz must be the last columns"),
        ("t,x,y,z,fx,fy,fz,vx,vy,vz", 10, ":1: force columns fx,fy,fz must be the last columns"),
        ("t,x,y,z,fx,fy,fz,qw,qx,qy,qz", 11, ":1: force columns fx,fy,fz must be the last"),
        ("t,x,y,z,fx,fy,fz,fx", 8, ":1: force columns must be fx,fy,fz, one per position axis"),
        ("t,x,y,z,tz,fx,fy,fz", 8, ":1: unknown column 'tz'"),
        ("t,fx,fy,fz", 4, ":1: no position column"),
    ],
)
def test_incomplete_or_misplaced_force_columns_are_refused_with_the_header_line(
    tmp_path, header, columns, expected
):
    path = tmp_path / "demo.csv"
    path.write_text(header + "\n" + rows(T, *([X] * (columns - 1))))
    with pytest.raises(InputError, match=re.escape(expected)) as error:
        read_demonstration(path)
    assert str(error.value).startswith(f"{path}:1: ")


@pytest.mark.parametrize(
    "value, says",
    [
        ("nan", "is not"),
        ("inf", "is not"),
        ("-inf", "is not"),
        ("abc", "is not"),
        ("", "is not"),
        ("1e200", "is 1e200: forces are in newtons, within 10000 N"),
        ("-2e4", "is -2e4: forces are in newtons"),
    ],
)
def test_a_non_finite_or_absurd_force_is_refused_with_its_line_by_fit(tmp_path, value, says):
    path = tmp_path / "demo.csv"
    lines = ("t,x,y,z,fx,fy,fz\n" + rows(T, X, 0 * T, Z, 0 * T, 0 * T, FZ)).splitlines()
    lines[7] = lines[7].rsplit(",", 1)[0] + "," + value  # the sample on line 8, its fz
    path.write_text("\n".join(lines) + "\n")
    line = one_line_error(run_cli("fit", path, "--out", tmp_path / "skill.npz"))
    assert f"{path}:8: column 'fz' {says}" in line
    assert not (tmp_path / "skill.npz").exists()


def test_incomplete_force_columns_stop_fit_with_exit_2(tmp_path):
    path = tmp_path / "demo.csv"
    path.write_text("t,x,y,z,fx,fy\n" + rows(T, X, 0 * T, Z, 0 * T, 0 * T))
    line = one_line_error(run_cli("fit", path, "--out", tmp_path / "skill.npz"))
    assert f"{path}:1: force columns must be fx,fy,fz" in line


def test_the_skill_file_keeps_the_encoded_force_and_reads_files_without_it(tmp_path, smooth_demo):
    t, positions = smooth_demo
    dmp = Dmp.fit(t, positions, "xyz")
    weights = np.random.default_rng(3).normal(0, 5, dmp.theta_p.shape)
    loaded = load_skill(save_skill(tmp_path / "f.npz", Skill.untrained(dmp, demo_force=weights)))
    np.testing.assert_array_equal(loaded.demo_force, weights)
    assert load_skill(save_skill(tmp_path / "n.npz", Skill.untrained(dmp))).demo_force is None
    with np.load(tmp_path / "f.npz") as data:
        arrays = dict(data)
    for bad, message in [
        (weights[:, :-1], r"field 'demo_force' has shape \(3, 29\), expected \(3, 30\)"),
        (
            np.where(weights > 0, np.nan, weights),
            "field 'demo_force' must hold finite numbers, not NaN",
        ),
    ]:
        np.savez(tmp_path / "bad.npz", **{**arrays, "demo_force": bad})
        with pytest.raises(InputError, match=message):
            load_skill(tmp_path / "bad.npz")


def demonstrated_vs_encoded(demo, tmp_path, *fit_options):
    """The demonstration's force and the force `fit` + `rollout` encode, at the rollout's
    samples."""
    assert run_cli("fit", demo, "--out", tmp_path / "s.npz", *fit_options).returncode == 0
    roll = run_cli("rollout", tmp_path / "s.npz", "--out", tmp_path / "r.csv", "--dt", 0.01)
    assert roll.returncode == 0, roll.stderr
    assert (tmp_path / "r.csv").read_text().splitlines()[0] == "t,x,y,z,vx,vy,vz,fx,fy,fz"
    t, _, _, force = read_demonstration(demo, with_force=True)
    t_roll, _, _, encoded = read_demonstration(tmp_path / "r.csv", with_force=True)
    demonstrated = np.column_stack([np.interp(t_roll, t - t[0], f) for f in force.T])
    return demonstrated, encoded


@pytest.mark.parametrize("smoothing", [[], ["--smoothing", 0.05]], ids=["fit", "scenario"])
@pytest.mark.parametrize("source", BUNDLED, ids=lambda p: p.stem)
def test_the_rollout_follows_the_bundled_demonstrated_force(tmp_path, source, smoothing):
    demonstrated, encoded = demonstrated_vs_encoded(source, tmp_path, *smoothing)
    rms = np.sqrt(np.mean((encoded - demonstrated) ** 2, axis=0))
    assert np.all(rms <= 0.1 * np.ptp(demonstrated, axis=0)), (rms, np.ptp(demonstrated, axis=0))


def test_the_rollout_follows_an_untuned_demonstrated_force(tmp_path):
    from test_core_demo_force import untuned_demonstration

    t, force = untuned_demonstration(seed=11)
    u = t / t[-1]
    path = np.column_stack([0.5 + 0.1 * u, 0.05 * np.sin(np.pi * u), 0.4 - 0.1 * u**2])
    demo = write_trajectory(tmp_path / "demo.csv", t, path, "xyz", force=force)
    demonstrated, encoded = demonstrated_vs_encoded(demo, tmp_path)
    rms = np.sqrt(np.mean((encoded - demonstrated) ** 2, axis=0))
    assert np.all(rms <= 0.1 * np.ptp(demonstrated, axis=0)), (rms, np.ptp(demonstrated, axis=0))


def test_a_skill_without_force_rolls_out_positions_and_velocities_only(tmp_path):
    demo = tmp_path / "demo.csv"
    demo.write_text("t,x,y,z\n" + rows(T, X, 0 * T, Z))
    assert run_cli("fit", demo, "--out", tmp_path / "s.npz").returncode == 0
    assert run_cli("rollout", tmp_path / "s.npz", "--out", tmp_path / "r.csv").returncode == 0
    assert (tmp_path / "r.csv").read_text().splitlines()[0] == "t,x,y,z,vx,vy,vz"


# --- learn --demo-force ------------------------------------------------------------------


def test_demo_force_needs_force_columns_and_no_skill(tmp_path, monkeypatch):
    def never(*_, **__):
        raise AssertionError("simulated before refusing")

    monkeypatch.setattr("hlcmp_drake.run.learning.run_trials", never)
    bare = tmp_path / "bare.csv"
    t, positions, axes = read_demonstration(INSERTION_DEMO)
    write_trajectory(bare, t, positions, axes)
    learn = ["learn", "--scenario", "insertion", "--out", tmp_path / "o", "--demo-force"]
    line = one_line_error(run_cli(*learn[:1], bare, *learn[1:]))
    assert f"{bare}: no force columns (fx,fy,fz)" in line
    dmp = Dmp.fit(t, positions, axes)
    skill = save_skill(tmp_path / "s.npz", Skill.untrained(dmp))
    line = one_line_error(run_cli(*learn[:1], INSERTION_DEMO, *learn[1:], "--skill", skill))
    assert "--demo-force starts the feed-forward from the demonstration, --skill" in line
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_learn_demo_force_starts_theta_v_from_the_demonstration(tmp_path):
    # Q_v = 0: the feed-forward keeps its start, so the logged v is theta_v(t0) . g(s)
    # over the whole trial -- the demonstration's force, encoded (its 14.5 N spike at the
    # tear, 0.3 s long, as a 6.6 N peak on the N = 30 basis).
    out = tmp_path / "learn"
    common = ["--scenario", "insertion", "--set", "duration_s=4", "--quiet"]
    fixed_v = ["--set", "controllers.hlcmp.q_v=[0,0,0]"]
    result = run_cli("learn", INSERTION_DEMO, *common, *fixed_v, "--demo-force", "--out", out)
    assert result.returncode == 0, result.stderr
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["feedforward_from_demo_force"] is True
    skill = load_skill(out / "skill.npz")
    np.testing.assert_array_equal(skill.theta_v, skill.demo_force)
    data = np.load(out / "timeseries.npz")
    t, v = data["t"], data["trial_1/v"]
    s = phase_at(t, skill.dmp.tau, skill.dmp.settings.alpha_s)
    expected = feedforward_along(skill.demo_force, s, skill.dmp.settings)
    np.testing.assert_allclose(v[0], expected[0], atol=1e-9)  # theta_v at t0
    # The run's phase is integrated, not the closed form: a few µN apart over the run.
    np.testing.assert_allclose(v, expected, rtol=0, atol=1e-4)
    assert v[:, 2].max() > 5.0
    # The same trial without --demo-force: theta_v(t0) = 0, and with Q_v = 0 it stays 0.
    plain = run_cli("learn", INSERTION_DEMO, *common, *fixed_v, "--out", tmp_path / "plain")
    assert plain.returncode == 0, plain.stderr
    assert np.abs(np.load(tmp_path / "plain" / "timeseries.npz")["trial_1/v"]).max() == 0.0
    np.testing.assert_array_equal(
        load_skill(tmp_path / "plain" / "skill.npz").demo_force, skill.demo_force
    )
