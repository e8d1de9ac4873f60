"""hlcmp_drake.present.recording: the offline recording (one self-contained HTML file that a
real browser draws, every run replayed under its label), each copy and its sign in view,
and the live view."""

import base64
import json
import re
import shutil
import subprocess

import numpy as np
import pytest
from pydrake.geometry import Meshcat

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import RecordingConfig
from hlcmp_drake.core.kernels import kernel_chosen
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.present.recording import LiveView, frame_copies, record_runs
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.worlds import arm

RUNS = {
    "one_dof_run": (
        ["hlcmp", "hlcmp_per_step", "vic_fd_0.5", "vic_fd_1.5", "vic_fd_5.0"],
        "body_visual",
    ),
    "insertion_run": (
        ["hlcmp", "hlcmp_per_step", "const_500", "const_1000", "const_2000"],
        "foam_visual",
    ),
}


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    pytest.skip(
        "no Chromium on this machine (install Debian's 'chromium' package; .ci/run tries to)"
    )


@pytest.mark.slow  # reads the recordings of whole bundled scenarios
@pytest.mark.parametrize("run", RUNS)
def test_recording_is_self_contained(request, run):
    html = (request.getfixturevalue(run) / "recording.html").read_text()
    assert not re.search(r"<script[^>]+src=[\"']https?:", html)
    assert not re.search(r"<link[^>]+href=[\"']https?:", html)


@pytest.mark.slow  # reads the recordings of whole bundled scenarios
@pytest.mark.parametrize("run", RUNS)
def test_recording_draws_every_run_offline_in_chromium(request, run, tmp_path):
    out_dir = request.getfixturevalue(run)
    controllers, geometry = RUNS[run]
    titles = _titles_in_chromium(out_dir / "recording.html", tmp_path)
    # The Meshcat scene tree lists the replayed runs and their geometry, and an animation.
    assert "runs" in titles, titles[:40]
    for name in controllers:
        assert name in titles
    assert titles.count(geometry) == len(controllers)
    assert "Animations" in titles


def _titles_in_chromium(page, tmp_path):
    """The titles of Meshcat's scene tree and controls once headless Chromium has drawn
    the recording `page` (skips without Chromium)."""
    browser = _chromium()
    result = subprocess.run(
        [
            browser,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            f"--user-data-dir={tmp_path / 'profile'}",
            "--virtual-time-budget=10000",
            "--dump-dom",
            page.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=180,
    )
    return re.findall(r'<li class="title">([^<]*)', result.stdout)


class _SceneCalls:
    """Records what frame_copies asks of a Meshcat."""

    def __init__(self):
        self.transforms, self.objects, self.colors, self.camera = {}, {}, {}, None

    def SetTransform(self, path, transform):
        self.transforms[path] = transform

    def SetObject(self, path, shape, rgba=None):
        self.objects[path], self.colors[path] = shape, rgba

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


def test_a_recording_replays_each_run_under_its_label():
    scenario, _ = load_scenario("one_dof")
    t = np.linspace(0.0, 0.5, 51)
    state = np.column_stack([-0.1 * t, -0.1 * np.ones_like(t)])  # q, v of the slider
    runs = {label: RunResult(label, t, {"plant_state": state}) for label in ("learner", "baseline")}
    meshcat = Meshcat()
    html = record_runs(scenario, runs, meshcat)
    assert html.startswith("<!DOCTYPE html>") and "embedded-json" in html
    for label in runs:
        assert meshcat.HasPath(f"/drake/runs/{label}")
    assert not meshcat.HasPath("/drake/runs/nobody")


def _commands(html):
    """The bytes of every Meshcat command a StaticHtml replays (msgpack, paths as text)."""
    return [
        base64.b64decode(payload)
        for payload in re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    ]


@pytest.fixture(scope="module")
def peg_recording():
    """The recording of short peg_in_hole runs: the 6-D Hl-CMP's and the translational one's."""
    scenario, _ = load_scenario("peg_in_hole", ["duration_s=0.05"])
    setup = arm.prepare(scenario)
    with kernel_chosen("numpy"):  # nothing here is about the tick's speed: no compiling
        runs = {
            name: simulate(arm.build(scenario, name, setup), scenario, name)
            for name in ("hlcmp_6d", "hlcmp")
        }
    return runs, record_runs(scenario, runs, Meshcat())


def test_an_arm_recording_draws_the_tool_frame_and_a_6d_run_its_desired_orientation(
    peg_recording,
):
    runs, html = peg_recording
    assert "q_tool_d" in runs["hlcmp_6d"].series and "q_tool_d" not in runs["hlcmp"].series
    commands = _commands(html)
    objects = b"".join(c for c in commands if b"set_object" in c[:40])
    (animation,) = [c for c in commands if b"set_animation" in c[:40]]
    for name in runs:  # the tool frame: Drake's triad on the peg's body, posed with it
        body = f"/drake/runs/{name}/peg_tool/tool".encode()
        for axis in (b"x-axis", b"y-axis", b"z-axis"):
            assert body + b"/_frames/tool_frame/" + axis in objects
        assert body in animation
    desired = b"/drake/runs/hlcmp_6d/tool_desired"
    for axis in (b"x-axis", b"y-axis", b"z-axis"):
        assert desired + b"/" + axis in objects
    assert desired in animation  # posed at every frame
    assert b"/drake/runs/hlcmp/tool_desired" not in objects + animation  # no orientation task


@pytest.mark.slow  # a real browser (about 2.5 s)
def test_the_tool_triads_are_drawn_offline_in_chromium(peg_recording, tmp_path):
    page = tmp_path / "recording.html"
    page.write_text(peg_recording[1])
    titles = _titles_in_chromium(page, tmp_path)
    assert titles.count("tool_frame") == 2  # each copy's tool frame
    assert titles.count("tool_desired") == 1  # the 6-D run's desired orientation
    assert titles.count("x-axis") == titles.count("y-axis") == titles.count("z-axis") == 3


def test_a_world_without_a_tool_draws_no_triad():
    scenario, _ = load_scenario("one_dof")
    commands = _commands(record_runs(scenario, _fake_runs(["learner"]), Meshcat()))
    assert not any(b"_frames" in c or b"tool_desired" in c for c in commands)


def test_the_desired_triad_lays_each_axis_from_the_origin_along_its_own_direction():
    from hlcmp_drake.present.recording import TRIAD_LENGTH_M, _add_triad

    calls = _SceneCalls()
    _add_triad(calls, "/triad", 0.001, 0.35)
    for k, axis in enumerate(("x-axis", "y-axis", "z-axis")):
        cylinder, pose = calls.objects[f"/triad/{axis}"], calls.transforms[f"/triad/{axis}"]
        assert cylinder.length() == TRIAD_LENGTH_M and cylinder.radius() == 0.001
        color = calls.colors[f"/triad/{axis}"]  # x red, y green, z blue
        np.testing.assert_array_equal([color.r(), color.g(), color.b()], np.eye(3)[k])
        assert color.a() == 0.35
        ends = pose.multiply(np.array([[0, 0, -0.5], [0, 0, 0.5]]).T * TRIAD_LENGTH_M).T
        np.testing.assert_allclose(ends, [np.zeros(3), TRIAD_LENGTH_M * np.eye(3)[k]], atol=1e-15)
