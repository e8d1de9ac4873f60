"""hlcmp_drake.cli: fit/rollout work; every bad input ends with exit 2 and one line; output
paths are refused before any work; the small conveniences (--version, --debug, the help's
defaults and names, run --meshcat)."""

import contextlib
import gc
import io
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import (
    DEMO_CSV,
    INSERTION_DEMO,
    REPO_ROOT,
    one_line_error,
    run_cli,
    short_one_dof,
    tilted_turn,
)

from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.io.demos import read_demonstration


def write_demo(path, t, positions, header="t,x,y,z"):
    rows = [",".join(f"{v:.9g}" for v in [ti, *p]) for ti, p in zip(t, positions)]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def test_fit_then_rollout_with_new_goal_and_duration(tmp_path, smooth_demo):
    demo = write_demo(tmp_path / "demo.csv", *smooth_demo)
    fit = run_cli("fit", demo, "--out", tmp_path / "skill.npz", "--basis", 25)
    assert fit.returncode == 0, fit.stderr
    out = tmp_path / "traj.csv"
    roll = run_cli(
        "rollout",
        tmp_path / "skill.npz",
        "--out",
        out,
        "--duration",
        4,
        "--goal",
        "0.35,-0.1,0.1",
        "--dt",
        0.01,
    )
    assert roll.returncode == 0, roll.stderr
    t, positions, axes = read_demonstration(out)
    assert axes == ("x", "y", "z")
    assert t[-1] == pytest.approx(4.0)
    assert out.read_text().splitlines()[0] == "t,x,y,z,vx,vy,vz"
    np.testing.assert_allclose(positions[-1], [0.35, -0.1, 0.1], atol=0.01)


@pytest.mark.parametrize(
    "goal, shown",
    [("600,100,300", "x = 600"), ("0.3,-1e30,0", "y = -1e+30"), ("0.3,0,100.5", "z = 100.5")],
)
def test_a_goal_beyond_where_a_demonstration_may_be_is_refused(tmp_path, smooth_demo, goal, shown):
    """--goal 600,100,300 wrote x up to 600 m (300 m/s), which fit then refused as a
    demonstration: the goal is held to the reader's bound on positions before rolling out."""
    demo = write_demo(tmp_path / "demo.csv", *smooth_demo)
    assert run_cli("fit", demo, "--out", tmp_path / "s.npz").returncode == 0
    out = tmp_path / "r.csv"
    line = one_line_error(run_cli("rollout", tmp_path / "s.npz", "--out", out, f"--goal={goal}"))
    assert line == (
        f"hlcmp: error: --goal: {shown}: positions are in metres, within 100 m of the world origin"
    )
    assert not out.exists()


def test_a_rollout_faster_than_a_demonstration_may_move_is_refused(tmp_path, smooth_demo):
    """A far goal or a short duration rolls out a path that fit and learn refuse as a
    demonstration (faster than 3 m/s): refused, nothing written, with the shortest
    duration that keeps within the bound; that duration rolls out a file fit reads."""
    demo = write_demo(tmp_path / "demo.csv", *smooth_demo)
    assert run_cli("fit", demo, "--out", tmp_path / "s.npz").returncode == 0
    out = tmp_path / "r.csv"
    far = ["rollout", tmp_path / "s.npz", "--out", out, "--goal", "5,0,0.05"]
    line = one_line_error(run_cli(*far))
    shortest = re.fullmatch(
        r"hlcmp: error: --goal 5,0,0.05: the rolled-out path would move at [\d.]+ m/s at its "
        r"fastest, more than the 3 m/s a demonstration may move \(fit and learn refuse it\): "
        r"give a nearer goal or a --duration of at least ([\d.]+) s",
        line,
    )
    assert shortest, line
    assert not out.exists()
    short = one_line_error(run_cli("rollout", tmp_path / "s.npz", "--out", out, "--duration", 0.2))
    assert short.startswith("hlcmp: error: --duration 0.2: the rolled-out path would move at")
    assert run_cli(*far, "--duration", shortest[1]).returncode == 0
    assert run_cli("fit", out, "--out", tmp_path / "again.npz").returncode == 0


def test_a_rollout_turning_faster_than_a_demonstration_may_turn_names_what_helps(tmp_path):
    """A pose rollout refused for its turn rate said "give a nearer goal", as if it moved
    too fast: a nearer goal orientation helps a turn (where one was given), a nearer
    --goal does not; a longer --duration helps both."""
    t, positions, quaternions, truth = tilted_turn(3)
    demo = write_demo(
        tmp_path / "pose.csv", t, np.hstack([positions, quaternions]), "t,x,y,z,qw,qx,qy,qz"
    )
    assert run_cli("fit", demo, "--out", tmp_path / "s.npz").returncode == 0
    out = tmp_path / "r.csv"
    rollout = ["rollout", tmp_path / "s.npz", "--out", out, "--duration", 0.3]
    goal_orientation = ",".join(f"{v:.12g}" for v in truth(t[-1:])[0])
    turning = r"the rolled-out path would turn at [\d.]+ rad/s at its fastest, more than the 15 "
    turning += r"rad/s a demonstration may turn \(fit and learn refuse it\): give "
    line = one_line_error(run_cli(*rollout, "--goal-orientation", goal_orientation))
    assert re.fullmatch(
        rf"hlcmp: error: --goal-orientation \S+, --duration 0.3: {turning}a nearer goal "
        r"orientation or a --duration of at least [\d.]+ s",
        line,
    ), line
    goal = ",".join(f"{v:.12g}" for v in positions[-1])
    line = one_line_error(run_cli(*rollout, "--goal", goal))
    assert re.fullmatch(
        rf"hlcmp: error: --goal \S+, --duration 0.3: {turning}a --duration of at least [\d.]+ s",
        line,
    ), line
    assert not out.exists()


@pytest.mark.parametrize(
    "args, rollout, problem",
    [
        (["--dt", 0.3], "2 s at --dt 0.3 s", "8 samples; a demonstration needs at least 10"),
        (
            ["--dt", 0.5, "--duration", 10],
            "10 s at --dt 0.5 s",
            "its samples are 0.5 s apart (the median; t from 0 to 10 s): a demonstration is "
            "sampled more often than every 0.5 s",
        ),
        (  # the file's times have nine digits: 0.49999999999 is written 0.5
            ["--dt", 0.49999999999, "--duration", 5],
            "5 s at --dt 0.49999999999 s",
            "its samples are 0.5 s apart (the median; t from 0 to 5 s): a demonstration is "
            "sampled more often than every 0.5 s",
        ),
        (
            ["--dt", 0.1, "--duration", 3700],
            "3700 s at --dt 0.1 s",
            "it lasts 3700 s; a demonstration lasts at most 3600 s",
        ),
    ],
)
def test_a_rollout_the_demonstration_reader_would_refuse_is_not_written(
    tmp_path, smooth_demo, args, rollout, problem
):
    """rollout wrote trajectories that fit and learn then refused as a demonstration: too
    few samples, too far apart, too long. Refused in one line before anything is written."""
    demo = write_demo(tmp_path / "demo.csv", *smooth_demo)
    assert run_cli("fit", demo, "--out", tmp_path / "s.npz").returncode == 0
    out = tmp_path / "r.csv"
    line = one_line_error(run_cli("rollout", tmp_path / "s.npz", "--out", out, *args))
    assert line == (
        f"hlcmp: error: a rollout of {rollout} would not read back as a demonstration (fit "
        f"and learn refuse it): {problem}"
    )
    assert not out.exists()


def test_a_rollout_overshooting_beyond_where_a_demonstration_may_be_is_refused(tmp_path):
    """A goal within the bound whose path overshoots it beyond (the demonstration went
    twice as far as where it ended) is refused as the goal itself would be."""
    t = np.linspace(0.0, 2.0, 201)
    x = 0.2 * np.sin(np.pi * t / 2.0) ** 2 * (1 - t / 4.0) + 0.1 * (t / 2.0) ** 3
    demo = write_demo(tmp_path / "demo.csv", t, np.column_stack([x]), header="t,x")
    assert run_cli("fit", demo, "--out", tmp_path / "s.npz").returncode == 0
    out = tmp_path / "r.csv"
    args = ["rollout", tmp_path / "s.npz", "--out", out, "--goal", "90", "--duration", 3000]
    line = one_line_error(run_cli(*args, "--dt", 0.25))
    assert re.fullmatch(
        r"hlcmp: error: --goal 90, --duration 3000: the rolled-out path reaches x = 1\d\d\.?\d* m: "
        r"positions are in metres, within 100 m of the world origin",
        line,
    ), line
    assert not out.exists()


GOOD = "t,x\n" + "".join(f"{k * 0.1:.1f},{k * 0.01:.2f}\n" for k in range(12))


@pytest.mark.parametrize(
    "content, expected",
    [
        (None, "no such file"),
        ("", "the file is empty"),
        ("x,y\n1,2\n", ":1: the first column must be 't'"),
        ("t\n" + "".join(f"{k},\n" for k in range(12)), ":1: no position column"),
        ("t,x,w\n0,1,2\n", ":1: unknown column 'w'"),
        ("t,x,\n0,1,\n", ":1: column 3 has no name (a comma at the end of the line?)"),
        ("t,,x\n0,1,2\n", ":1: column 2 has no name"),
        ("t,z,x\n0,1,2\n", ":1: position columns must be in the order x, y, z"),
        (GOOD.replace("0.3,0.03", "0.3,abc"), ":5: column 'x' is not a number: 'abc'"),
        (GOOD.replace("0.3,0.03", "0.3,0.0_3"), ":5: column 'x' is not a number: '0.0_3'"),
        (GOOD.replace("0.3,0.03", "0.3,0.0\u0663"), ":5: column 'x' is not a number: '0.0\u0663'"),
        (GOOD.replace("0.3,0.03", "0.3,nan"), ":5: column 'x' is not finite"),
        (GOOD.replace("0.3,0.03", "0.3,inf"), ":5: column 'x' is not finite"),
        (
            GOOD.replace("0.3,0.03", "0.3,5e299"),
            ":5: column 'x' is 5e299: positions are in metres, within 100 m of the world origin",
        ),
        (GOOD.replace("0.3,0.03", "0.1,0.03"), ":5: time must increase strictly"),
        (GOOD.replace("0.3,0.03", "0.3"), ":5: expected 2 values (t,x), found 1"),
        (
            "t,x\n" + "".join(f"{k},{k}\n" for k in range(5)),
            "5 samples; a demonstration needs at least 10",
        ),
    ],
)
def test_bad_demonstrations_exit_2_with_one_line(tmp_path, content, expected):
    demo = tmp_path / "demo.csv"
    if content is not None:
        demo.write_text(content)
    result = run_cli("fit", demo, "--out", tmp_path / "skill.npz")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert expected in lines[0]
    assert str(demo) in lines[0] and "Traceback" not in result.stderr
    assert not (tmp_path / "skill.npz").exists()


def test_good_one_axis_demo_is_accepted(tmp_path):
    demo = tmp_path / "demo.csv"
    demo.write_text(GOOD)
    assert run_cli("fit", demo, "--out", tmp_path / "s.npz").returncode == 0


@pytest.mark.parametrize(
    "args, expected",
    [
        (["rollout", "SKILL", "--out", "T", "--goal", "1,2"], "--goal: the skill has 3 axes"),
        (
            ["rollout", "SKILL", "--out", "T", "--goal", "a,b,c"],
            "--goal: expected comma-separated numbers",
        ),
        (["rollout", "SKILL", "--out", "T", "--dt", "-1"], "must be a positive number"),
        (["rollout", "SKILL", "--out", "T", "--dt", "100"], "--dt 100 s: longer than the rollout"),
        (
            ["fit", "DEMO", "--out", "S", "--basis", "1"],
            "--basis: n_basis must be between 2 and 1000, got 1",
        ),
        (["rollout", "NOSKILL", "--out", "T"], "no such file"),
        (["run", "no_such_scenario"], "not a bundled scenario"),
        (["frobnicate"], "invalid choice"),
        (
            ["learn", "DEMO", "--scenario", "one_dof", "--out", "D"],
            "does not follow a demonstration",
        ),
        (
            ["learn", "DEMO", "--scenario", "insertion", "--out", "D", "--trials", "0"],
            "must be between 1 and 100",
        ),
    ],
)
def test_bad_arguments_exit_2_with_one_line(tmp_path, smooth_demo, args, expected):
    demo = write_demo(tmp_path / "demo.csv", *smooth_demo)
    assert run_cli("fit", demo, "--out", tmp_path / "skill.npz").returncode == 0
    names = {
        "SKILL": tmp_path / "skill.npz",
        "T": tmp_path / "t.csv",
        "D": tmp_path / "learned",
        "DEMO": demo,
        "S": tmp_path / "s2.npz",
        "NOSKILL": tmp_path / "missing.npz",
    }
    result = run_cli(*[names.get(a, a) for a in args])
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert expected in result.stderr


def test_existing_output_survives_a_failed_run(tmp_path):
    out = tmp_path / "skill.npz"
    out.write_bytes(b"previous result")
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x\n0,abc\n")
    assert run_cli("fit", bad, "--out", out).returncode == 2
    assert out.read_bytes() == b"previous result"


def test_drake_models_without_internet_is_one_clear_line(tmp_path):
    result = run_cli("run", "insertion", "--iiwa", "drake_models", "--out", tmp_path / "o")
    if result.returncode == 0:
        pytest.skip("drake_models could be downloaded here: the offline path cannot be checked")
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "drake_models" in result.stderr
    assert not result.stderr.strip().endswith(":")  # Drake's reason, not "All downloads failed:"
    assert not (tmp_path / "o").exists()


def test_debug_shows_the_traceback(tmp_path):
    result = run_cli("--debug", "fit", tmp_path / "missing.csv", "--out", tmp_path / "s.npz")
    assert result.returncode != 0
    assert (
        "Traceback" in result.stderr
        and "InputError" in result.stderr
        and "no such file" in result.stderr
    )


@pytest.mark.parametrize(
    "command",
    [
        ["run", "one_dof"],
        ["learn", "DEMO", "--scenario", "insertion"],
        ["probe", "insertion"],
        ["report"],
        ["bench"],
    ],
)
def test_an_output_folder_that_is_a_file_is_refused_before_any_work(tmp_path, command):
    import time

    blocker = tmp_path / "a_file"
    blocker.write_text("keep me")
    demo = write_demo(tmp_path / "demo.csv", np.linspace(0, 1, 20), np.linspace(0, 1, 20)[:, None])
    start = time.perf_counter()
    result = run_cli(*[demo if a == "DEMO" else a for a in command], "--out", blocker)
    assert result.returncode == 2 and time.perf_counter() - start < 10
    assert result.stderr.strip().splitlines() == [
        f"hlcmp: error: --out {blocker}: is a file, not a folder"
    ]
    assert blocker.read_text() == "keep me"


def test_fit_refuses_a_folder_as_its_output_file(tmp_path, smooth_demo):
    demo = write_demo(tmp_path / "demo.csv", *smooth_demo)
    result = run_cli("fit", demo, "--out", tmp_path)
    assert result.returncode == 2 and "is a folder, not a file" in result.stderr


def test_a_demonstration_with_a_byte_order_mark_is_read(tmp_path, smooth_demo):
    t, positions = smooth_demo
    plain = write_demo(tmp_path / "plain.csv", t, positions)
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    assert run_cli("fit", bom, "--out", tmp_path / "skill.npz").returncode == 0


def test_a_text_file_given_as_a_skill_gets_its_own_message(tmp_path):
    fake = tmp_path / "skill.npz"
    fake.write_text("t,x\n0,1\n")
    result = run_cli("rollout", fake, "--out", tmp_path / "t.csv")
    assert (
        result.returncode == 2
        and "not a skill file" in result.stderr
        and "allow_pickle" not in result.stderr
    )


def test_run_refuses_an_existing_file_as_out_within_seconds(tmp_path):
    blocker = tmp_path / "results"
    blocker.write_text("keep me")
    start = time.perf_counter()
    line = one_line_error(run_cli("run", "one_dof", "--out", blocker))
    assert time.perf_counter() - start < 10
    assert line == f"hlcmp: error: --out {blocker}: is a file, not a folder"
    assert blocker.read_text() == "keep me"


@pytest.mark.parametrize(
    "command, default",
    [
        (["run", "one_dof"], "out/one_dof"),
        (["probe", "insertion"], "out/probe_insertion"),
        (["sweep", "tiny"], "out/sweeps/tiny"),
    ],
)
def test_a_default_output_folder_is_checked_too(tmp_path, command, default):
    (tmp_path / default).parent.mkdir(parents=True)
    (tmp_path / default).write_text("not a folder")
    line = one_line_error(run_cli(*command, cwd=tmp_path))
    assert line == f"hlcmp: error: output folder {default}: is a file, not a folder"


def test_report_checks_each_scenario_folder(tmp_path):
    (tmp_path / "one_dof").write_text("not a folder")
    line = one_line_error(run_cli("report", "--out", tmp_path, "--scenarios", "one_dof"))
    assert line.endswith("one_dof: is a file, not a folder")


def test_fit_and_rollout_refuse_bad_output_files(tmp_path):
    demo = tmp_path / "demo.csv"
    demo.write_text(DEMO_CSV)
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    assert "is a file, not a folder" in one_line_error(
        run_cli("fit", demo, "--out", blocker / "skill.npz")
    )
    assert run_cli("fit", demo, "--out", tmp_path / "skill.npz").returncode == 0
    assert "is a folder, not a file" in one_line_error(
        run_cli("rollout", tmp_path / "skill.npz", "--out", tmp_path)
    )


def test_fit_and_rollout_refuse_to_write_over_their_input(tmp_path):
    demo = tmp_path / "demo.csv"
    demo.write_text(DEMO_CSV)
    line = one_line_error(run_cli("fit", demo, "--out", demo))
    assert line == f"hlcmp: error: --out {demo}: is the input demo; it would be overwritten"
    assert demo.read_text() == DEMO_CSV
    skill = tmp_path / "skill.npz"
    assert run_cli("fit", demo, "--out", skill).returncode == 0
    kept = skill.read_bytes()
    (tmp_path / "link.npz").symlink_to(skill)  # the same file by another name
    line = one_line_error(run_cli("rollout", skill, "--out", tmp_path / "link.npz"))
    assert line.endswith(": is the input skill; it would be overwritten")
    assert skill.read_bytes() == kept


@pytest.mark.slow  # eight fits and rollouts and a run, with their files (about 1.5 s)
def test_fit_and_rollout_refuse_an_output_file_of_another_kind(tmp_path):
    import dataclasses as dc

    from hlcmp_drake.io.skill import SkillWorld, load_skill, save_skill

    demo = tmp_path / "demo.csv"
    demo.write_text(DEMO_CSV)
    other_demo = tmp_path / "other_demo.csv"
    other_demo.write_text(DEMO_CSV)
    line = one_line_error(run_cli("fit", demo, "--out", other_demo))
    assert line == (
        f"hlcmp: error: --out {other_demo}: fit writes a skill file: give a path ending in .npz"
    )
    assert other_demo.read_text() == DEMO_CSV
    fitted = tmp_path / "fitted.npz"
    assert run_cli("fit", demo, "--out", fitted).returncode == 0
    assert run_cli("fit", demo, "--out", fitted).returncode == 0  # an earlier fit's is replaced
    learned = tmp_path / "learned.npz"  # as learn writes it: with the world it learned in
    save_skill(learned, dc.replace(load_skill(fitted), world=SkillWorld("one_dof", "k", "0" * 64)))
    kept = learned.read_bytes()
    for out in (learned, tmp_path / "trajectory"):
        line = one_line_error(run_cli("rollout", fitted, "--out", out))
        assert line == (
            f"hlcmp: error: --out {out}: rollout writes a trajectory CSV: give a path ending "
            "in .csv"
        )
    line = one_line_error(run_cli("fit", demo, "--out", learned))
    assert line == (
        f"hlcmp: error: --out {learned}: holds a learned skill, which fit would replace with "
        "one that has learned nothing: choose another path"
    )
    assert learned.read_bytes() == kept and not (tmp_path / "trajectory").exists()
    ran = tmp_path / "ran"  # a run's folder: its listed files are its own
    assert run_cli("run", *short_one_dof(0.1), "--out", ran, "--quiet").returncode == 0
    series = (ran / "timeseries.npz").read_bytes()
    line = one_line_error(run_cli("fit", demo, "--out", ran / "timeseries.npz"))
    assert line.endswith(
        "is a file of the output folder an earlier command wrote (its timeseries.npz); it "
        "would be overwritten: give a file outside it"
    )
    assert (ran / "timeseries.npz").read_bytes() == series
    assert run_cli("fit", demo, "--out", ran / "mine.npz").returncode == 0  # not listed


def test_a_dry_run_sweep_writes_nothing_so_needs_no_writable_folder(tmp_path):
    result = run_cli("sweep", "tiny", "--dry-run", "--out", "/proc/hlcmp_sweep")
    assert result.returncode == 0
    assert result.stderr.startswith("hlcmp: warning: the sweep itself could not run: --out")


def test_a_dry_run_sweep_checks_the_engine_as_the_sweep_would(tmp_path):
    line = one_line_error(run_cli("sweep", "tiny", "--dry-run", "--address", "auto"))
    assert line == "hlcmp: error: --address: joins a Ray cluster, so it needs --engine ray"


def test_the_cli_names_a_text_skill_in_one_line(tmp_path):
    text = tmp_path / "demo.csv"
    text.write_text(DEMO_CSV)
    line = one_line_error(
        run_cli("reproduce", text, "--scenario", "insertion", "--out", tmp_path / "o")
    )
    assert line == (
        f"hlcmp: error: {text}: not a skill file (a .npz written by hlcmp fit/learn); "
        "this is a demonstration CSV (hlcmp fit makes a skill of it)"
    )
    folder = one_line_error(run_cli("rollout", tmp_path, "--out", tmp_path / "t.csv"))
    assert "is a folder, not a skill file" in folder


def test_version_debug_anywhere_bench_default_and_bundled_names_in_help(tmp_path):
    assert re.fullmatch(r"hlcmp_drake \S+\n", run_cli("--version").stdout)
    late = run_cli("fit", tmp_path / "missing.csv", "--out", tmp_path / "s.npz", "--debug")
    assert "Traceback" in late.stderr and "no such file" in late.stderr
    assert "default out/bench" in run_cli("bench", "--help").stdout
    run_help = " ".join(run_cli("run", "--help").stdout.split())
    assert "(cutting, insertion, one_dof, peg_in_hole)" in run_help


@pytest.mark.slow  # a whole (short) one_dof run with its figures and recording: about 5 s
def test_run_with_meshcat_prints_its_url_and_closes_the_port(tmp_path):
    from hlcmp_drake.cli import main

    stdout = io.StringIO()
    gc.disable()  # as in a long test session where no collection happens to run before the probe
    try:
        with contextlib.redirect_stdout(stdout):
            status = main(
                [
                    "run",
                    "one_dof",
                    "--meshcat",
                    "--quiet",
                    "--set",
                    "duration_s=0.2",
                    "--out",
                    str(tmp_path),
                ]
            )
        assert status == 0
        url = re.search(r"^live view: (http://\S+)", stdout.getvalue(), re.M).group(1)
        port = int(url.rsplit(":", 1)[1].strip("/"))
        assert (tmp_path / "recording.html").exists()  # the offline recording as without the flag
        # Asked of this process's own sockets: another test's process may open a Meshcat on
        # the same port as soon as this one lets it go (a connection then succeeds).
        assert not _listening_here(port)
    finally:
        gc.enable()


def _listening_here(port: int) -> bool:
    """Whether this process holds a listening TCP socket on `port` (from /proc)."""
    inodes = set()
    for fd in Path("/proc/self/fd").iterdir():
        with contextlib.suppress(OSError):
            target = os.readlink(fd)
            if target.startswith("socket:["):
                inodes.add(target[len("socket:[") : -1])
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with contextlib.suppress(OSError):
            for line in Path(table).read_text().splitlines()[1:]:
                fields = line.split()  # local address:port, ..., state (0A: LISTEN), ..., inode
                listening = fields[3] == "0A" and int(fields[1].rsplit(":", 1)[1], 16) == port
                if listening and fields[9] in inodes:
                    return True
    return False


def test_every_positional_argument_has_help():
    from hlcmp_drake.cli import build_parser

    parser = build_parser()
    (commands,) = [a for a in parser._actions if a.dest == "command"]
    missing = [
        f"{name} {action.dest}"
        for name, sub in commands.choices.items()
        for action in sub._actions
        if not action.option_strings and not action.help
    ]
    assert missing == []


def test_drake_models_on_a_scenario_without_the_arm_is_one_line_and_runs_nothing(tmp_path):
    result = run_cli("run", "one_dof", "--iiwa", "drake_models", "--out", tmp_path / "o")
    assert one_line_error(result) == (
        "hlcmp: error: --iiwa drake_models: only applies to arm scenarios (with "
        "package://hlcmp_drake/models/iiwa14.sdf, e.g. insertion, cutting); 'one_dof' has no iiwa"
    )
    assert not (tmp_path / "o").exists()


def test_the_module_run_as_a_process_says_what_it_says_in_process(tmp_path):
    """The tests run `main` in the test process (conftest.run_cli); the entry point a user
    runs, in a process of its own, gives the same exit code and the same lines."""
    args = ("fit", tmp_path / "missing.csv", "--out", tmp_path / "s.npz")
    alone = run_cli(*args, separate_process=True)
    assert alone == run_cli(*args)
    assert alone.returncode == 2 and "no such file" in one_line_error(alone)


def test_fit_then_rollout_of_a_pose(tmp_path):
    t, positions, quaternions, truth = tilted_turn(3)
    demo = write_demo(
        tmp_path / "pose.csv", t, np.hstack([positions, quaternions]), "t,x,y,z,qw,qx,qy,qz"
    )
    fit = run_cli("fit", demo, "--out", tmp_path / "skill.npz")
    assert fit.returncode == 0, fit.stderr
    assert "and orientation DMP (turning" in fit.stdout
    out = tmp_path / "traj.csv"
    assert run_cli("rollout", tmp_path / "skill.npz", "--out", out, "--dt", 0.002).returncode == 0
    assert out.read_text().splitlines()[0] == "t,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz"
    t_r, _, _, q = read_demonstration(out, with_orientation=True)
    error = np.degrees(quat.geodesic_angle(q, truth(t_r)))
    assert np.sqrt(np.mean(error**2)) < 1.0 and error[-1] < 0.5
    goal = quat.multiply(quat.from_rotation_vector([0.0, 0.2, 0.0]), truth(t[-1:])[0])
    moved = tmp_path / "moved.csv"
    text = ",".join(f"{v:.12g}" for v in goal)
    roll = run_cli(
        "rollout",
        tmp_path / "skill.npz",
        "--out",
        moved,
        "--duration",
        2 * t[-1],
        "--goal-orientation",
        text,
    )
    assert roll.returncode == 0, roll.stderr
    q_moved = read_demonstration(moved, with_orientation=True)[3]
    assert np.degrees(quat.geodesic_angle(q_moved[-1], goal)) < 0.5


def test_pose_inputs_refused_with_one_line(tmp_path, smooth_demo):
    t, positions, quaternions, _ = tilted_turn(0, samples=30)
    quaternions[12] = [0.0, 0.0, 0.0, 0.0]
    rows = np.hstack([positions, quaternions])
    demo = write_demo(tmp_path / "pose.csv", t, rows, "t,x,y,z,qw,qx,qy,qz")
    out = tmp_path / "skill.npz"
    line = one_line_error(run_cli("fit", demo, "--out", out))
    assert line.endswith("pose.csv:14: the orientation (0,0,0,0) is zero, which is no rotation")
    assert not out.exists()
    plain = write_demo(tmp_path / "demo.csv", *smooth_demo)
    assert run_cli("fit", plain, "--out", out).returncode == 0
    line = one_line_error(
        run_cli("rollout", out, "--out", tmp_path / "t.csv", "--goal-orientation", "1,0,0,0")
    )
    assert line == "hlcmp: error: --goal-orientation: the skill has no orientation (positions only)"
    write_demo(
        tmp_path / "pose.csv",
        t,
        np.hstack([positions, np.tile([1.0, 0, 0, 0], (30, 1))]),
        "t,x,y,z,qw,qx,qy,qz",
    )
    assert run_cli("fit", demo, "--out", out).returncode == 0
    for value, problem in (
        ("1,0,0", "expected 4 values"),
        ("2,0,0,0", "norm 2; a unit quaternion"),
    ):
        line = one_line_error(
            run_cli("rollout", out, "--out", tmp_path / "t.csv", "--goal-orientation", value)
        )
        assert problem in line
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["run", "diagrams/sweeps/tiny.yaml"],
            "a sweep file (its keys labels, metrics), not a scenario file: give it to hlcmp sweep",
        ),
        (
            ["sweep", "diagrams/one_dof.yaml", "--dry-run"],
            "a scenario file (its keys directives, plant_config, simulator_config, task), not a "
            "sweep file: give it to hlcmp run",
        ),
        (
            ["library", "diagrams/sweeps/tiny.yaml", "--out", "L"],
            "a sweep file (its keys labels, metrics), not a library file: give it to hlcmp sweep",
        ),
        (
            ["sweep", "diagrams/libraries/insertion.yaml", "--dry-run"],
            "a library file (its key trials), not a sweep file: give it to hlcmp library",
        ),
    ],
)
def test_a_file_of_another_kind_is_named_as_such(tmp_path, args, message):
    args = [str(REPO_ROOT / a) if a.startswith("diagrams/") else a for a in args]
    args = [str(tmp_path / a) if a == "L" else a for a in args]
    result = run_cli(*args)
    assert result.returncode == 2 and result.stderr.strip().endswith(message), result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_output_into_a_closed_pipe_ends_quietly(tmp_path):
    """`hlcmp ... | head`: the reader gone, the command stops printing without a traceback
    and exits as a shell reports SIGPIPE; its files are written."""
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "hlcmp_drake.cli",
            "fit",
            str(INSERTION_DEMO),
            "--out",
            str(tmp_path / "s.npz"),
        ],  # fmt: skip
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    process.stdout.close()  # the reader leaves before the first line
    errors = process.stderr.read()
    assert process.wait(timeout=120) == 141 and errors == "", errors
    assert (tmp_path / "s.npz").is_file()


def test_a_demonstration_given_with_set_is_read_from_the_working_directory(tmp_path, monkeypatch):
    from hlcmp_drake.cli import build_parser
    from hlcmp_drake.config.loading import load_scenario

    (tmp_path / "mine.csv").write_bytes(INSERTION_DEMO.read_bytes())
    monkeypatch.chdir(tmp_path)
    args = build_parser().parse_args(
        ["run", "insertion", "--set", "reference.file=mine.csv", "--set", "duration_s=1"]
    )
    assert args.set[1] == "duration_s=1"  # other fields as typed
    scenario, _ = load_scenario(args.scenario, args.set)
    assert scenario.reference.file == str(tmp_path / "mine.csv")  # not beside insertion.yaml
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")  # the same text, another working directory
    again = build_parser().parse_args(["run", "insertion", "--set", "reference.file=mine.csv"])
    assert again.set == [f'reference.file="{tmp_path / "elsewhere" / "mine.csv"}"']
    monkeypatch.chdir(tmp_path)
    line = one_line_error(run_cli("run", "insertion", "--set", "reference.file=nope.csv"))
    assert line.startswith("hlcmp: error: override 'reference.file=nope.csv': ")  # as typed
    assert line.endswith(
        f"(looked for {tmp_path / 'nope.csv'}); a relative path given with --set is read from "
        "the working directory"
    )


@pytest.mark.parametrize(
    "typed",
    [
        "reference.file=package://hlcmp_drake/diagrams/demos/insertion_demo.csv",
        "reference.file=/abs/demo.csv",
        "controllers.hlcmp.q_k=[1,2,3]",
        "reference.file=[unclosed",
    ],
)
def test_set_leaves_urls_absolute_paths_and_other_fields_as_typed(typed):
    from hlcmp_drake.config.loading import command_line_override

    assert command_line_override(typed) == typed


def test_a_claim_not_judged_names_its_runs_whose_reasons_are_printed_once(capsys):
    from types import SimpleNamespace

    from hlcmp_drake.cli import print_summary
    from hlcmp_drake.present.tables import Table

    why = "did not go through the plank: the tool point stayed 119.7 mm above its top"
    runs = {"hlcmp": False, "const_500": False, "const_1000": True}
    metrics = {
        "status": "ok",
        "controllers": {n: {"task": {"done": d, "evidence": why}} for n, d in runs.items()},
        "claims": {
            "hlcmp": {
                "C1": {"holds": None, "evidence": f"const_500: {why}"},
                "C2": {"holds": None, "evidence": f"hlcmp: {why}; const_500: {why}"},
                "C3": {"holds": True, "evidence": "K rose 3x"},
            }
        },
    }
    print_summary(SimpleNamespace(metrics=metrics, table=Table(["a"], [["1"]]), out_dir="D"))
    lines = capsys.readouterr().out.splitlines()
    assert lines[-6:] == [
        f"task not done by hlcmp: {why}",
        f"task not done by const_500: {why}",
        "C1 [hlcmp]: not judged (task not done) -- const_500",
        "C2 [hlcmp]: not judged (task not done) -- hlcmp, const_500",
        "C3 [hlcmp]: reproduced -- K rose 3x",
        "status: ok; results in D",
    ]


def test_a_reading_that_rounds_to_zero_is_printed_without_a_minus_sign():
    from hlcmp_drake.cli import _rounded

    assert [_rounded(v, 2) for v in (-1e-4, -0.0, -0.006, 13.814)] == [
        "0.00",
        "0.00",
        "-0.01",
        "13.81",
    ]


def _learned_folder(folder):
    """A folder as `hlcmp learn` leaves it: skill.npz listed in the folder's manifest."""
    from hlcmp_drake.io import outputs

    with outputs.replacing_outputs(folder):
        outputs.write_text(folder / "skill.npz", "a learned skill")
        outputs.write_text(folder / "metrics.json", "{}")
    return folder / "skill.npz"


def test_a_command_that_would_remove_a_learned_skill_is_refused(tmp_path):
    skill = _learned_folder(tmp_path / "L")
    result = run_cli("run", *short_one_dof(0.1), "--out", tmp_path / "L")
    line = one_line_error(result)
    assert f"holds a learned skill ({skill})" in line and "which run would remove" in line
    assert skill.read_text() == "a learned skill"
    (tmp_path / "mine").mkdir()  # a skill the user put there, not in the manifest: not ours
    (tmp_path / "mine" / "skill.npz").write_text("my own")
    assert "holds" not in run_cli("run", *short_one_dof(0.1), "--out", tmp_path / "mine").stderr
    assert (tmp_path / "mine" / "skill.npz").read_text() == "my own"


def test_a_folder_another_command_is_writing_into_is_refused_until_it_ends(tmp_path):
    """Two commands into one --out at once left one's files mixed with the other's: while
    one holds the folder, the next stops before any simulation, naming the process; once
    it ends, the folder is free. The lock leaves nothing in the folder."""
    import os
    import tempfile
    from pathlib import Path

    from hlcmp_drake.io.outputs import folder_locked

    out = tmp_path / "o"
    with folder_locked(out):
        line = one_line_error(run_cli("run", *short_one_dof(0.1), "--out", out))
        assert line.endswith(
            f"--out {out}: another hlcmp command (process {os.getpid()}) is writing there "
            "now: wait for it to end, or give another --out"
        )
        assert not out.exists()
        assert run_cli("run", *short_one_dof(0.1), "--out", tmp_path / "p").returncode == 0
    assert run_cli("run", *short_one_dof(0.1), "--out", out, "--quiet").returncode == 0
    assert not [p for p in out.iterdir() if "lock" in p.name]
    # Nor outside it once the command has ended: the lock's own file, which names the
    # process holding it, goes with it.
    locks = Path(tempfile.gettempdir()) / "hlcmp-locks"

    def held_here():
        found = []
        for lock in locks.iterdir():
            with contextlib.suppress(FileNotFoundError):  # another worker's, just gone
                if lock.read_text() == str(os.getpid()):
                    found.append(lock)
        return found

    with folder_locked(out):
        mine = held_here()
        assert len(mine) == 1
    assert not mine[0].exists() and not held_here()


def test_an_input_under_a_name_the_command_writes_in_its_folder_is_refused(tmp_path):
    """Your own scenario.yaml run with --out its folder, or a demonstration called
    recording.html learned into its folder, would be written over: refused before any
    simulation, the file as it was. A run's own scenario.yaml runs again into its folder."""
    from hlcmp_drake.config.loading import dump_scenario, load_scenario

    mine = tmp_path / "project" / "scenario.yaml"
    mine.parent.mkdir()
    text = "# my notes\n" + dump_scenario(load_scenario("one_dof")[0])
    mine.write_text(text)
    line = one_line_error(run_cli("run", mine, "--set", "duration_s=0.1", "--out", mine.parent))
    assert line.endswith(
        f"holds the input {mine}, which run would write over with its own scenario.yaml: "
        "give another --out, or move the file"
    )
    assert mine.read_text() == text and sorted(mine.parent.iterdir()) == [mine]
    demo = tmp_path / "project" / "figures" / "demo.png"  # anything under figures/ too
    demo.parent.mkdir()
    demo.write_text(INSERTION_DEMO.read_text())
    learn = ["learn", demo, "--scenario", "insertion", "--out", mine.parent]
    assert "which learn would write over with its own figures/demo.png" in one_line_error(
        run_cli(*learn)
    )
    ran = tmp_path / "ran"
    assert run_cli("run", *short_one_dof(0.1), "--out", ran).returncode == 0
    again = run_cli("run", ran / "scenario.yaml", "--out", ran, "--quiet")
    assert again.returncode == 0, again.stderr


@pytest.mark.parametrize(
    "command, extra, refused",
    [
        ("reproduce", [], "would overwrite with the skill it learns: give another --out$"),
        (
            "reproduce",
            ["--freeze"],
            "and the results of the run that learned it, which the replay's would replace: "
            "give another --out$",
        ),
        ("learn", [], "would overwrite with the skill it learns: give another --out$"),
        ("serve", [], "which serve would remove"),
    ],
)
def test_a_skill_given_from_the_output_folder_is_never_written_over(
    tmp_path, command, extra, refused
):
    import argparse

    from hlcmp_drake.cli import _check_skill_not_lost
    from hlcmp_drake.io.errors import InputError

    skill = _learned_folder(tmp_path / "L")
    args = argparse.Namespace(command=command, skill=str(skill), freeze="--freeze" in extra)
    with pytest.raises(InputError, match=refused):
        _check_skill_not_lost(args, tmp_path / "L")


def test_a_skill_of_yours_in_the_output_folder_is_replayed_frozen_there(tmp_path):
    """A skill.npz no command of this tool left in the folder (not in its list) is no
    learning run's: reproduce --freeze keeps it and writes beside it, as the refusal of
    reproduce without --freeze suggests."""
    import argparse

    from hlcmp_drake.cli import _check_skill_not_lost
    from hlcmp_drake.io.errors import InputError

    skill = tmp_path / "mine" / "skill.npz"
    skill.parent.mkdir()
    skill.write_text("my own")
    replay = argparse.Namespace(command="reproduce", skill=str(skill), freeze=False)
    with pytest.raises(InputError, match="give another --out, or --freeze$"):
        _check_skill_not_lost(replay, skill.parent)
    replay.freeze = True
    _check_skill_not_lost(replay, skill.parent)


def test_a_frozen_replay_into_the_folder_learn_wrote_is_refused(tmp_path):
    """reproduce L/skill.npz --freeze --out L replaced the learning run's metrics, time
    series, recording and figures by the replay's and left the skill out of the folder's
    list, so that a later run there removed it: refused before any simulation, the
    folder as it was."""
    skill = _learned_folder(tmp_path / "L")
    listed = (tmp_path / "L" / ".hlcmp-outputs.json").read_text()
    result = run_cli(
        "reproduce", skill, "--scenario", "insertion", "--freeze", "--out", tmp_path / "L"
    )
    assert one_line_error(result) == (
        f"hlcmp: error: --out {tmp_path / 'L'}: holds the learned skill {skill} and the "
        "results of the run that learned it, which the replay's would replace: give "
        "another --out"
    )
    assert (tmp_path / "L" / "metrics.json").read_text() == "{}"
    assert (tmp_path / "L" / ".hlcmp-outputs.json").read_text() == listed


def test_fit_says_how_far_its_path_strays_and_warns_when_far(tmp_path):
    """The bundled insertion demonstration fits within a few mm; smoothed over 5 s of its
    8.5 s, the fit loses its shape (more than 10 cm), which fit says on stderr."""
    demo, out = REPO_ROOT / "diagrams" / "demos" / "insertion_demo.csv", tmp_path / "s.npz"
    fitted = run_cli("fit", demo, "--out", out)
    stray = float(re.search(r"keeps within ([\d.]+) mm of the demonstration", fitted.stdout)[1])
    assert 0 < stray < 10 and fitted.stderr == "", fitted.stderr
    smoothed = run_cli("fit", demo, "--smoothing", "5", "--out", out)
    far = float(re.search(r"keeps within ([\d.]+) mm", smoothed.stdout)[1])
    assert far > 100 and smoothed.returncode == 0
    assert smoothed.stderr.strip() == (
        f"hlcmp: warning: the fitted path strays {far:.1f} mm from the demonstration: a "
        "shorter --smoothing (now 5 s) or more --basis (now 30, up to 1000) keeps its shape"
    )


def test_fit_advises_fewer_basis_functions_when_more_than_its_samples(tmp_path):
    """201 samples over 2 s (with the settled end, 301 fit the weights) and N = 1000: the
    path strays tens of mm between samples, and more basis functions stray further; the
    smoothing, already 0, is no remedy to name. N = 30 to 300 keep within 0.1 mm."""
    t = np.linspace(0.0, 2.0, 201)
    x = 0.4 + 0.1 * (10 * (t / 2) ** 3 - 15 * (t / 2) ** 4 + 6 * (t / 2) ** 5)
    demo = write_demo(tmp_path / "good.csv", t, np.column_stack([x]), header="t,x")
    many = run_cli("fit", demo, "--out", tmp_path / "o.npz", "--basis", 1000, "--smoothing", 0)
    far = float(re.search(r"keeps within ([\d.]+) mm", many.stdout)[1])
    assert far > 10 and many.returncode == 0
    assert many.stderr.strip() == (
        f"hlcmp: warning: the fitted path strays {far:.1f} mm from the demonstration: fewer "
        "--basis (now 1000, for a fit of 301 samples) keeps its shape"
    )
    for basis in (30, 300):
        fitted = run_cli("fit", demo, "--out", tmp_path / "o.npz", "--basis", basis)
        assert float(re.search(r"keeps within ([\d.]+) mm", fitted.stdout)[1]) < 0.1
        assert fitted.stderr == ""


def test_fit_without_smoothing_advises_more_basis_functions_alone(tmp_path):
    """A path of three swings fitted with N = 2 and no smoothing: more basis functions
    (up to one fewer than the fit's samples) is the remedy, a shorter smoothing none."""
    t = np.linspace(0.0, 2.0, 201)
    x = 0.4 + 0.05 * np.sin(3 * np.pi * t) * np.sin(np.pi * t / 2) ** 2
    demo = write_demo(tmp_path / "swings.csv", t, np.column_stack([x]), header="t,x")
    few = run_cli("fit", demo, "--out", tmp_path / "o.npz", "--basis", 2, "--smoothing", 0)
    assert few.returncode == 0
    assert few.stderr.strip().endswith(
        "from the demonstration: more --basis (now 2, up to 300) keeps its shape"
    ), few.stderr


def test_a_skill_that_does_not_fit_the_scenario_is_named(tmp_path):
    """learn --skill with a skill of other axes than the scenario's: the one line names
    the skill's file, not only "the skill"."""
    demo, skill = tmp_path / "z.csv", tmp_path / "z.npz"
    demo.write_text("t,z\n" + "".join(f"{0.1 * k:.1f},{0.2 - 0.01 * k:.2f}\n" for k in range(20)))
    assert run_cli("fit", demo, "--out", skill).returncode == 0
    learn = ["learn", INSERTION_DEMO, "--scenario", "insertion", "--skill", skill]
    line = one_line_error(run_cli(*learn, "--out", tmp_path / "L"))
    assert line == (
        f"hlcmp: error: {skill}: the skill's axes (z) do not match the scenario 'insertion', "
        "which controls x,y,z"
    )


@pytest.mark.parametrize(
    "args",
    [
        ["run", "one_dof", "--out"],
        ["report", "--out"],
        ["bench", "--out"],
        ["learn", INSERTION_DEMO, "--scenario", "insertion", "--out"],
        ["reproduce", "skill.npz", "--scenario", "insertion", "--out"],
        ["probe", "insertion", "--out"],
        ["fit", INSERTION_DEMO, "--out"],
        ["rollout", "skill.npz", "--out"],
        ["sweep", "sweep.yaml", "--out"],
        ["serve", "insertion", "--lcm", "memq://", "--out"],
        ["library", "insertion", "--out"],
        ["generalize", "L", "--query", "a=1", "--out"],
        ["learn", INSERTION_DEMO, "--out", "L", "--scenario"],
        ["learn", INSERTION_DEMO, "--scenario", "insertion", "--out", "L", "--skill"],
        ["run", "one_dof", "--variant"],
        ["fit", "--out", "s.npz", "demo"],
        ["run", "scenario"],
    ],
)
def test_an_empty_path_is_refused_by_the_parser_before_any_work(tmp_path, args):
    """An unset shell variable (--out "$OUT") wrote into out/SCENARIO or the working
    directory, or was called a folder; every path argument (the last name here: an option,
    or a positional's) now refuses it alike."""
    *given, named = args
    result = run_cli(*given, *([named] if named.startswith("--") else []), "", cwd=tmp_path)
    assert one_line_error(result) == (
        f"hlcmp {args[0]}: error: argument {named}: an empty path (an unset shell variable?) "
        "(see --help)"
    )
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "command",
    [
        ["learn", INSERTION_DEMO, "--scenario", "insertion"],
        ["run", *short_one_dof(0.1)],
        ["probe", "insertion"],
    ],
)
@pytest.mark.parametrize("name", ["skill.npz", "traj.CSV", "metrics.json"])
def test_an_output_folder_named_like_a_file_is_refused(tmp_path, command, name):
    """learn --out skill.npz (fit's --out is a file) made a folder skill.npz holding
    skill.npz, which rollout and reproduce then called a folder: a folder command's new
    --out named with the suffix of a file this tool writes is refused before any work,
    with a folder's name to give instead."""
    out = tmp_path / name
    line = one_line_error(run_cli(*command, "--out", out))
    stem = out.with_suffix("")
    assert line == (
        f"hlcmp: error: --out {out}: {command[0]} writes a folder, not a {out.suffix} file: "
        f"give a folder's name, e.g. --out {stem}"
    )
    assert not out.exists()


def test_an_existing_folder_named_like_a_file_is_written_into(tmp_path):
    """A folder made earlier (or named with a final separator) is a folder already."""
    made = tmp_path / "made.npz"
    made.mkdir()
    assert run_cli("run", *short_one_dof(0.1), "--out", made, "--quiet").returncode == 0
    assert (made / "metrics.json").is_file()
    meant = f"{tmp_path / 'meant.csv'}/"
    assert run_cli("run", *short_one_dof(0.1), "--out", meant, "--quiet").returncode == 0
    assert (tmp_path / "meant.csv" / "metrics.json").is_file()
