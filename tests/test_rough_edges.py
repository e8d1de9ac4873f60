"""The rough edges a new user hits first: output paths refused before any work, a CSV with
a byte-order mark, a text file given as a skill, the small CLI conveniences, and seeing
the runs (signs and framing in the recording, the live Meshcat of `hlcmp run --meshcat`)."""

import contextlib
import gc
import io
import json
import os
import re
import socket
import subprocess
import sys
import time

import numpy as np
import pytest
from pydrake.geometry import Meshcat

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import RecordingConfig
from hlcmp_drake.io.demos import read_demonstration
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.outputs import check_output_file, check_output_folder
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.io.skill import load_skill
from hlcmp_drake.present.recording import LiveView, frame_copies, record_runs


def hlcmp(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "hlcmp_drake.cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=120,
    )


def one_error_line(result):
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("hlcmp: error: "), result.stderr
    return lines[0]


DEMO = "t,x,y,z\n" + "".join(
    f"{0.1 * k:.1f},{0.01 * k:.2f},0,{0.2 - 0.01 * k:.2f}\n" for k in range(20)
)


# --- 1. output paths are checked before any work -------------------------------------


def test_output_folders_that_can_be_written_pass_and_nothing_is_created(tmp_path):
    assert check_output_folder(tmp_path) == tmp_path  # exists: its files are replaced
    new = tmp_path / "a" / "b"
    assert check_output_folder(new) == new and not (tmp_path / "a").exists()
    assert check_output_file(tmp_path / "c" / "skill.npz").name == "skill.npz"
    (tmp_path / "old.npz").write_bytes(b"x")
    check_output_file(tmp_path / "old.npz")  # an existing file is replaced
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.npz"]  # the probe file is gone


def test_a_file_where_a_folder_is_needed_and_the_reverse(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("keep")
    with pytest.raises(InputError, match=r"^--out .*a_file: is a file, not a folder$"):
        check_output_folder(blocker)
    with pytest.raises(
        InputError, match=rf"^--out .*: {re.escape(str(blocker))} is a file, not a folder$"
    ):
        check_output_folder(blocker / "sub" / "deeper")
    with pytest.raises(InputError, match=rf"{re.escape(str(blocker))} is a file, not a folder"):
        check_output_file(blocker / "skill.npz")
    with pytest.raises(InputError, match="is a folder, not a file"):
        check_output_file(tmp_path)
    with pytest.raises(InputError, match="is a folder, not a file"):
        check_output_file(f"{tmp_path / 'new'}/")
    assert blocker.read_text() == "keep"


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc")
def test_a_folder_nobody_can_write_in_is_refused():
    with pytest.raises(InputError, match=r"cannot write in /proc \("):
        check_output_folder("/proc/hlcmp_out")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root may write anywhere")
def test_a_read_only_parent_is_refused(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(InputError, match="cannot write in"):
            check_output_folder(locked / "out")
    finally:
        locked.chmod(0o700)


def test_run_refuses_an_existing_file_as_out_within_seconds(tmp_path):
    blocker = tmp_path / "results"
    blocker.write_text("keep me")
    start = time.perf_counter()
    line = one_error_line(hlcmp("run", "one_dof", "--out", blocker))
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
    line = one_error_line(hlcmp(*command, cwd=tmp_path))
    assert line == f"hlcmp: error: output folder {default}: is a file, not a folder"


def test_report_checks_each_scenario_folder(tmp_path):
    (tmp_path / "one_dof").write_text("not a folder")
    line = one_error_line(hlcmp("report", "--out", tmp_path, "--scenarios", "one_dof"))
    assert line.endswith("one_dof: is a file, not a folder")


def test_fit_and_rollout_refuse_bad_output_files(tmp_path):
    demo = tmp_path / "demo.csv"
    demo.write_text(DEMO)
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    assert "is a file, not a folder" in one_error_line(
        hlcmp("fit", demo, "--out", blocker / "skill.npz")
    )
    assert hlcmp("fit", demo, "--out", tmp_path / "skill.npz").returncode == 0
    assert "is a folder, not a file" in one_error_line(
        hlcmp("rollout", tmp_path / "skill.npz", "--out", tmp_path)
    )


def test_a_dry_run_sweep_writes_nothing_so_needs_no_writable_folder(tmp_path):
    assert hlcmp("sweep", "tiny", "--dry-run", "--out", "/proc/hlcmp_sweep").returncode == 0


# --- 2. a CSV with a byte-order mark ------------------------------------------------


def test_a_byte_order_mark_is_invisible_to_the_reader(tmp_path):
    plain, bom = tmp_path / "plain.csv", tmp_path / "bom.csv"
    plain.write_text(DEMO)
    bom.write_bytes(b"\xef\xbb\xbf" + DEMO.encode())
    for got, expected in zip(read_demonstration(bom), read_demonstration(plain)):
        np.testing.assert_array_equal(got, expected)
    bad = tmp_path / "bad.csv"
    bad.write_bytes(b"\xef\xbb\xbfx,y\n1,2\n")  # a real header problem is still named plainly
    with pytest.raises(InputError, match=r":1: the first column must be 't' .*, found 'x';"):
        read_demonstration(bad)


# --- 3. a file that is not a skill --------------------------------------------------


@pytest.mark.parametrize(
    "content, extra",
    [
        (
            DEMO.encode(),
            "; this is a text file (a demonstration CSV becomes a skill with hlcmp fit)",
        ),
        (b"\x93NUMPY\x01\x00" + b"\x00" * 40, ""),  # a .npy, not a .npz
        (b"", ""),
    ],
)
def test_a_non_skill_file_gets_its_own_message(tmp_path, content, extra):
    path = tmp_path / "skill.npz"
    path.write_bytes(content)
    with pytest.raises(InputError) as error:
        load_skill(path)
    message = str(error.value)
    assert message == (
        f"{path}: "
        + ("the file is empty, " if not content else "")
        + "not a skill file (a .npz written by hlcmp fit/learn)"
        + extra
    )
    assert "pickle" not in message


def test_the_cli_names_a_text_skill_in_one_line(tmp_path):
    text = tmp_path / "demo.csv"
    text.write_text(DEMO)
    line = one_error_line(
        hlcmp("reproduce", text, "--scenario", "insertion", "--out", tmp_path / "o")
    )
    assert line == (
        f"hlcmp: error: {text}: not a skill file (a .npz written by hlcmp fit/learn); "
        "this is a text file (a demonstration CSV becomes a skill with hlcmp fit)"
    )
    folder = one_error_line(hlcmp("rollout", tmp_path, "--out", tmp_path / "t.csv"))
    assert "is a folder, not a skill file" in folder


# --- 4. the small conveniences still work ------------------------------------------


def test_version_debug_anywhere_bench_default_and_bundled_names_in_help(tmp_path):
    assert re.fullmatch(r"hlcmp_drake \S+\n", hlcmp("--version").stdout)
    late = hlcmp("fit", tmp_path / "missing.csv", "--out", tmp_path / "s.npz", "--debug")
    assert "Traceback" in late.stderr and "no such file" in late.stderr
    assert "default out/bench" in hlcmp("bench", "--help").stdout
    run_help = " ".join(hlcmp("run", "--help").stdout.split())
    assert "(cutting, insertion, one_dof)" in run_help


# --- 5. seeing the runs -----------------------------------------------------------


class _SceneCalls:
    """Records what frame_copies asks of a Meshcat."""

    def __init__(self):
        self.transforms, self.objects, self.camera = {}, {}, None

    def SetTransform(self, path, transform):
        self.transforms[path] = transform

    def SetObject(self, path, shape, rgba=None):
        self.objects[path] = shape

    def SetCameraPose(self, camera, target):
        self.camera = (np.asarray(camera), np.asarray(target))


def _in_view(points, camera, target, fov_deg=75.0, aspect=4.0 / 3.0):
    forward = (target - camera) / np.linalg.norm(target - camera)
    right = np.cross(forward, [0, 0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    r = points - camera
    depth = r @ forward
    tan_v = np.tan(np.radians(fov_deg / 2))
    return (
        (depth > 0)
        & (np.abs(r @ up) <= depth * tan_v + 1e-9)
        & (np.abs(r @ right) <= depth * tan_v * aspect + 1e-9)
    )


def _sign_corners(calls, label):
    """The world corners of a label's sign, from its glTF quad and the transforms."""
    gltf = json.loads(
        calls.objects[f"/drake/runs/{label}/label"].source().in_memory().mesh_file.contents()
    )
    (x0, y0, _), (x1, y1, _) = gltf["accessors"][0]["min"], gltf["accessors"][0]["max"]
    local = np.array([[x, 0.0, y] for x in (x0, x1) for y in (y0, y1)])  # glTF y-up is Drake's z
    sign = calls.transforms[f"/drake/runs/{label}/label"]
    copy = calls.transforms[f"/drake/runs/{label}"]
    return (copy.multiply(sign)).multiply(local.T).T


@pytest.mark.parametrize(
    "config, extent",
    [
        # the insertion's own settings: five arms 1.2 m apart, looked at from the -y side
        (
            RecordingConfig(
                spacing_m=1.2, camera_position_m=[1.9, -2.2, 1.2], camera_target_m=[0.5, 0.0, 0.4]
            ),
            ([-0.3, -0.3, 0.0], [0.9, 0.3, 1.3]),
        ),
        (RecordingConfig(), ([-0.1, -0.1, -0.1], [0.1, 0.1, 0.1])),  # the defaults, a small world
    ],
)
def test_every_copy_and_its_sign_is_in_view(config, extent):
    labels = ["hlcmp", "hlcmp_per_step", "const_500", "const_1000", "const_2000"]
    calls = _SceneCalls()
    frame_copies(calls, config, labels, (np.array(extent[0]), np.array(extent[1])))
    camera, target = calls.camera
    lo, hi = np.array(extent[0]), np.array(extent[1])
    for k, label in enumerate(labels):
        np.testing.assert_allclose(
            calls.transforms[f"/drake/runs/{label}"].translation(), [0, k * config.spacing_m, 0]
        )
        corners = np.array(
            [
                [x, y + k * config.spacing_m, z]
                for x in (lo[0], hi[0])
                for y in (lo[1], hi[1])
                for z in (lo[2], hi[2])
            ]
        )
        assert _in_view(corners, camera, target).all(), label
        sign = _sign_corners(calls, label)
        assert _in_view(sign, camera, target).all(), label
        assert sign[:, 2].min() > hi[2]  # above its copy
        assert np.ptp(sign[:, :2], axis=0).max() < config.spacing_m  # no wider than the spacing


def _fake_runs(labels):
    t = np.linspace(0.0, 0.5, 51)
    state = np.column_stack([-0.1 * t, -0.1 * np.ones_like(t)])  # q, v of the slider
    return {label: RunResult(label, t, {"plant_state": state}) for label in labels}


def test_the_recording_signs_every_run():
    scenario, _ = load_scenario("one_dof")
    runs = _fake_runs(["learner", "baseline"])
    meshcat = Meshcat()
    html = record_runs(scenario, runs, meshcat)
    for label in runs:
        assert meshcat.HasPath(f"/drake/runs/{label}/label")
    assert not meshcat.HasPath("/drake/runs/nobody/label")
    assert html.startswith("<!DOCTYPE html>")


def test_a_live_view_draws_each_run_and_signs_them_all():
    scenario, _ = load_scenario("one_dof")
    meshcat = Meshcat()
    live = LiveView(scenario, meshcat)
    first = next(iter(scenario.controllers))
    live.show(first, 0.0, np.array([-0.1]))
    for label in scenario.controllers:  # every controller is signed from the start
        assert meshcat.HasPath(f"/drake/runs/{label}/label")
    live.show(first, 0.1, np.array([np.nan]), final=True)  # a diverged state is not drawn
    live.show("extra", 0.0, np.array([-0.1]))
    assert meshcat.HasPath("/drake/runs/extra")


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
        with socket.socket() as probe, pytest.raises(ConnectionRefusedError):
            probe.connect(("localhost", port))
    finally:
        gc.enable()
