"""Bad input, instability, interrupts, determinism and progress: what a user meets when
something is off."""

import io
import json
import random
import subprocess
import sys

import numpy as np
import pytest
from conftest import INSERTION_DEMO

from hlcmp_drake.cli import main
from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.demos import read_demonstration, write_trajectory
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.paths import DIAGRAMS_DIR
from hlcmp_drake.present.progress import Progress


def run_cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "hlcmp_drake.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
    )


def one_line_error(result, code=2):
    assert result.returncode == code, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


@pytest.mark.parametrize(
    "change, expected",
    [
        (
            lambda t, p: (t, p + np.array([1.5, 0.0, 0.0])),
            "the tool cannot reach (2.050, -0.050, 0.450)",
        ),
        (lambda t, p: (t / 20, p), "following the demonstration needs joint"),
    ],
)
def test_unfollowable_demonstrations_stop_before_simulating(tmp_path, change, expected):
    t, positions, axes = read_demonstration(INSERTION_DEMO)
    bad = write_trajectory(tmp_path / "bad.csv", *change(t, positions), axes)
    line = one_line_error(run_cli("learn", bad, "--scenario", "insertion", "--out", tmp_path / "o"))
    assert line.startswith(f"hlcmp: error: {bad}:") and expected in line
    assert not (tmp_path / "o").exists()


def test_missing_model_file_names_the_line(tmp_path):
    text = (
        (DIAGRAMS_DIR / "insertion.yaml").read_text().replace("foam_plank.sdf", "no_such_plank.sdf")
    )
    path = tmp_path / "s.yaml"
    path.write_text(text.replace("file: demos/insertion_demo.csv", f"file: {INSERTION_DEMO}"))
    line = one_line_error(run_cli("run", path, "--out", tmp_path / "o"))
    number = next(n for n, row in enumerate(text.splitlines(), 1) if "no_such_plank" in row)
    assert (
        f"{path}:{number}: file: model file "
        "'package://hlcmp_drake/models/no_such_plank.sdf' does not exist" in line
    )


@pytest.mark.slow
def test_absurd_gains_end_unstable_with_logs_kept(tmp_path):
    result = run_cli(
        "run",
        "insertion",
        "--set",
        "duration_s=1.0",
        "--set",
        "controllers.hlcmp.gain_l=[1.0e7, 1.0e7, 1.0e7]",
        "--out",
        tmp_path / "o",
        "--quiet",
    )
    assert result.returncode == 3, result.stderr
    metrics = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert metrics["status"] == "unstable"
    problem = metrics["instability"]["hlcmp"]
    assert "saturated" in problem["reason"] and 0 < problem["time_s"] < 1.0
    data = np.load(tmp_path / "o" / "timeseries.npz")
    stopped = np.isnan(data["hlcmp/x"][:, 0])
    assert (
        stopped.any() and not stopped[: int(problem["time_s"] / 0.01)].any()
    )  # logs up to the stop
    assert not np.isnan(data["const_1000/x"]).any()  # the others ran on
    assert "UNSTABLE hlcmp" in result.stdout


def short_one_dof(seconds=3.0):
    """The `run` arguments of the 1-DOF scenario cut short."""
    return ["one_dof", "--set", f"duration_s={seconds}"]


@pytest.mark.slow
def test_same_command_twice_gives_identical_metrics(tmp_path):
    for out in ("a", "b"):
        assert main(["run", *short_one_dof(), "--out", str(tmp_path / out), "--quiet"]) == 0
    assert (tmp_path / "a" / "metrics.json").read_bytes() == (
        tmp_path / "b" / "metrics.json"
    ).read_bytes()


def test_interrupt_leaves_previous_results(tmp_path, monkeypatch, capsys):
    import hlcmp_drake.run.runner as runner

    out = tmp_path / "o"
    out.mkdir()
    (out / "metrics.json").write_text('{"previous": true}')

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(runner, "simulate", interrupted)
    assert main(["run", *short_one_dof(), "--out", str(out)]) == 130
    assert (out / "metrics.json").read_text() == '{"previous": true}'
    assert sorted(p.name for p in out.iterdir()) == ["metrics.json"]
    assert "interrupted; nothing was written" in capsys.readouterr().err


def test_progress_only_on_a_terminal(tmp_path):
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    terminal, pipe = Terminal(), io.StringIO()
    for stream in (terminal, pipe):
        progress = Progress(stream=stream)
        progress.step("hlcmp", 2.0, 9.5, 1.6)
        progress.say("hlcmp: done")
    assert "hlcmp:   2.0 / 9.5 s simulated (1.25x real time)" in terminal.getvalue()
    assert pipe.getvalue() == ""
    assert Progress(quiet=True, stream=Terminal()).enabled is False
    result = run_cli("run", *short_one_dof(1.0), "--out", tmp_path / "o")
    assert result.returncode == 0 and result.stderr == ""  # stderr is a pipe here


# ---------------------------------------------------------------------------------------
# Fuzzing the loaders: whatever the bytes, a clean InputError (exit 2) or a valid result.
# ---------------------------------------------------------------------------------------


def _mutations(text, rng, count):
    pieces = [
        "",
        ",",
        "\n",
        "nan",
        "-",
        "1e999",
        "abc",
        "t",
        ":",
        "[",
        "]",
        "{",
        "!",
        "#",
        " ",
        "\t",
        "0",
        "-1",
        "\x00",
        "é",
        "'",
        '"',
        "x,y",
    ]
    for _ in range(count):
        chars = list(text)
        for _ in range(rng.randint(1, 4)):
            where = rng.randrange(len(chars) + 1)
            action = rng.random()
            if action < 0.4 and chars:
                del chars[min(where, len(chars) - 1)]
            elif action < 0.8:
                chars.insert(where, rng.choice(pieces))
            else:
                cut = rng.randrange(len(chars) + 1)
                chars = chars[:cut]
        yield "".join(chars)


def test_fuzzed_demonstrations_never_crash(tmp_path):
    rng = random.Random(1234)
    good = "t,x,y,z\n" + "".join(
        f"{k * 0.1:.1f},{0.5 + k * 0.01:.3f},0.0,{0.4 - k * 0.005:.4f}\n" for k in range(15)
    )
    path = tmp_path / "demo.csv"
    outcomes = {"ok": 0, "error": 0}
    for text in _mutations(good, rng, 300):
        data = text.encode()
        if rng.random() < 0.1:  # now and then a byte that is not UTF-8 at all
            cut = rng.randrange(len(data) + 1)
            data = data[:cut] + b"\xff" + data[cut:]
        path.write_bytes(data)
        try:
            t, positions, axes = read_demonstration(path)
            assert np.all(np.diff(t) > 0) and np.all(np.isfinite(positions)) and len(t) >= 10
            outcomes["ok"] += 1
        except InputError as error:
            assert "\n" not in str(error) and str(error).startswith(str(path))
            outcomes["error"] += 1
    assert outcomes["ok"] > 0 and outcomes["error"] > 0


def test_fuzzed_scenarios_never_crash(tmp_path):
    rng = random.Random(4321)
    good = (DIAGRAMS_DIR / "one_dof.yaml").read_text()
    path = tmp_path / "scenario.yaml"
    outcomes = {"ok": 0, "error": 0}
    for text in _mutations(good, rng, 150):
        data = text.encode()
        if rng.random() < 0.1:
            cut = rng.randrange(len(data) + 1)
            data = data[:cut] + b"\xff" + data[cut:]
        path.write_bytes(data)
        try:
            load_scenario(path)
            outcomes["ok"] += 1
        except InputError as error:
            assert "\n" not in str(error) and str(error).startswith(str(path))
            outcomes["error"] += 1
    assert outcomes["ok"] > 0 and outcomes["error"] > 0
