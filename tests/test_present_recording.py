"""The offline recording: one self-contained HTML file that a real browser draws."""

import re
import shutil
import subprocess

import pytest

pytestmark = pytest.mark.slow  # both read the recordings of whole bundled scenarios

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


@pytest.mark.parametrize("run", RUNS)
def test_recording_is_self_contained(request, run):
    html = (request.getfixturevalue(run) / "recording.html").read_text()
    assert not re.search(r"<script[^>]+src=[\"']https?:", html)
    assert not re.search(r"<link[^>]+href=[\"']https?:", html)


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
