"""hlcmp_drake.present.recording: the offline recording (one self-contained HTML file that a
real browser draws, every run replayed under its label), each copy and its sign in view,
and the live view."""

import json
import re
import shutil
import subprocess

import numpy as np
import pytest
from pydrake.geometry import Meshcat

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import RecordingConfig
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.present.recording import LiveView, frame_copies, record_runs

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
    browser = _chromium()
    out_dir = request.getfixturevalue(run)
    controllers, geometry = RUNS[run]
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
            (out_dir / "recording.html").as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=180,
    )
    titles = re.findall(r'<li class="title">([^<]*)', result.stdout)
    # The Meshcat scene tree lists the replayed runs and their geometry, and an animation.
    assert "runs" in titles, titles[:40]
    for name in controllers:
        assert name in titles
    assert titles.count(geometry) == len(controllers)
    assert "Animations" in titles


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
