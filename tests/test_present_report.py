"""hlcmp_drake.present.report: the report page, generated from the runs' own metrics,
offline, every image and link local, and the README's claims summary."""

import html
import json
import re
import shutil
import subprocess

import pytest
from conftest import REPO_ROOT

from hlcmp_drake.experiments import EXPERIMENTS
from hlcmp_drake.present.report import ReportSection, report_page


@pytest.fixture(scope="session")
def report(one_dof_run, insertion_run, cutting_run):
    base = one_dof_run.parent  # the three run folders live in it
    assert insertion_run.parent == base == cutting_run.parent
    sections = [
        ReportSection(name, run, 1.0, EXPERIMENTS[name])
        for name, run in [
            ("one_dof", one_dof_run),
            ("insertion", insertion_run),
            ("cutting", cutting_run),
        ]
    ]
    page = base / "index.html"
    page.write_text(report_page(base, sections))
    return page, sections


@pytest.mark.slow  # reads the three bundled scenarios' whole runs
def test_every_local_link_and_image_resolves(report):
    page, _ = report
    text = page.read_text()
    targets = re.findall(r"(?:src|href)='([^'#][^']*)'", text)
    assert (
        len([t for t in targets if t.endswith(".png")]) == 1 + 6 + 2
    )  # Fig. 4 once per reading of Q
    assert sum(t.endswith("recording.html") for t in targets) == 3
    for target in targets:
        assert not target.startswith(("http:", "https:", "//")), target
        assert (page.parent / target).exists(), target


@pytest.mark.slow  # reads the three bundled scenarios' whole runs
def test_every_number_is_the_runs_own(report):
    page, sections = report
    text = page.read_text()
    for section in sections:
        metrics = json.loads((section.run_dir / "metrics.json").read_text())
        for claim in (c for by_claim in metrics["claims"].values() for c in by_claim.values()):
            assert html.escape(claim["evidence"]) in text


@pytest.mark.slow  # reads the three bundled scenarios' whole runs
def test_the_page_renders_in_chromium_with_every_image(report, tmp_path):
    browser = shutil.which("chromium")
    if browser is None:
        pytest.skip(
            "no Chromium on this machine (install Debian's 'chromium' package; .ci/run tries to)"
        )
    page, _ = report
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
            "--virtual-time-budget=5000",
            "--dump-dom",
            page.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert result.stdout.count("<img") == 9
    images = re.findall(r"<img[^>]*>", result.stdout)
    assert images and not [img for img in images if re.search(r'class="[^"]*missing', img)]
    assert result.stdout.count("<h2 id=") == 3


@pytest.mark.slow  # reads the three bundled scenarios' whole runs
def test_readme_claims_summary_comes_from_the_runs(one_dof_run, insertion_run, cutting_run):
    from hlcmp_drake.present.report import claims_summary_table
    from hlcmp_drake.present.tables import to_markdown

    runs = {"one_dof": one_dof_run, "insertion": insertion_run, "cutting": cutting_run}
    metrics = {name: json.loads((run / "metrics.json").read_text()) for name, run in runs.items()}
    readme = (REPO_ROOT / "README.md").read_text()
    block = readme.split("<!-- BEGIN claims summary -->\n")[1].split("<!-- END claims summary -->")[
        0
    ]
    assert block == to_markdown(claims_summary_table(metrics), code_first_column=False)


def test_a_variant_is_compared_row_by_row_and_claim_by_claim():
    from hlcmp_drake.present.report import robot_comparison

    def controller(error_mm, done):
        axes = {"x": 0.0, "y": 0.0, "z": 0.0}
        return {
            "mean_abs_position_error_m": {**axes, "z": error_mm / 1000},
            "mean_abs_force_N": axes,
            "force_smoothness_N": axes,
            "max_abs_force_N": axes,
            "task": {"done": done, "evidence": ""},
        }

    def run(error_mm, done, holds, unstable=False):
        return {
            "status": "unstable" if unstable else "ok",
            "controllers": {"hlcmp": controller(error_mm, done), "k": controller(1.0, True)},
            "learners": {"hlcmp": {"q_units": "per_second"}},
            "claims": {} if unstable else {"hlcmp": {"C1": {"holds": holds, "paper_says": ""}}},
            **({"instability": {"k": {"reason": "r", "time_s": 1.0}}} if unstable else {}),
        }

    metrics, claims = robot_comparison(
        run(2.0, True, True), run(5.0, False, None), "real_arm", EXPERIMENTS["insertion"]
    )
    assert [row[:3] for row in metrics.rows] == [
        ["hlcmp", "perfect", "yes"],
        ["hlcmp", "real_arm", "no"],
        ["k", "perfect", "yes"],
        ["k", "real_arm", "yes"],
    ]
    assert metrics.rows[1][3] == "0.00/0.00/5.00"
    assert claims.headers[2:] == ["perfect", "real_arm"]
    assert claims.rows == [
        ["C1", "hlcmp: Q per second (Eq. 31)", "yes", "not judged (task not done)"]
    ]
    metrics, claims = robot_comparison(
        run(2.0, True, True),
        run(5.0, True, None, unstable=True),
        "real_arm",
        EXPERIMENTS["insertion"],
    )
    assert metrics.rows[3][2] == "unstable" and claims.rows[0][3] == "–"


@pytest.mark.parametrize(
    "changes, says, never",
    [
        (["robot_imperfection.noise_seed"], "No gain changed", "Not the robot alone"),
        (
            ["controllers.const_500.stiffness_N_per_m", "task.max_contact_force_N"],
            "the variant changes <code>controllers.const_500.stiffness_N_per_m</code>, "
            "<code>task.max_contact_force_N</code>; controller gains among them.",
            "No gain changed",
        ),
        (
            ["robot_imperfection.noise_seed", "task.max_contact_force_N"],
            "changes <code>task.max_contact_force_N</code> and the robot (robot_imperfection); "
            "no controller gain changed.",
            "No gain changed",
        ),
    ],
)
def test_a_variant_section_says_what_the_variant_changes(tmp_path, changes, says, never):
    """The page said "No gain changed" under every variant, one that set a controller's
    gains too; the page now says it only of a variant of the robot alone."""
    axes = {"x": 0.0, "y": 0.0, "z": 0.0}
    controller = {
        key: axes
        for key in (
            "mean_abs_position_error_m",
            "mean_abs_force_N",
            "force_smoothness_N",
            "max_abs_force_N",
        )
    }
    metrics = {"status": "ok", "controllers": {"const_500": controller}, "claims": {}}
    for folder in ("perfect", "varied"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "metrics.json").write_text(json.dumps(metrics))
    section = ReportSection(
        "insertion",
        tmp_path / "perfect",
        1.0,
        EXPERIMENTS["insertion"],
        variants={"mine": tmp_path / "varied"},
        variant_changes={"mine": changes},
    )
    page = report_page(tmp_path, [section])
    assert says in page and never not in page
