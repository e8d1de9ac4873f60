"""hlcmp_drake.run.report (hlcmp report): the command runs the scenarios and writes the page."""

import sys

import pytest


@pytest.mark.slow
def test_report_command_runs_the_scenarios(tmp_path):
    from hlcmp_drake.cli import main

    assert main(["report", "--out", str(tmp_path), "--scenarios", "one_dof", "--quiet"]) == 0
    text = (tmp_path / "index.html").read_text()
    assert "one_dof/recording.html" in text and (tmp_path / "one_dof" / "metrics.json").exists()


def _own_scenario(folder, name="my_one_dof", duration=0.3):
    """The bundled 1-DOF scenario saved as one's own YAML, renamed and cut short."""
    from hlcmp_drake.io.paths import DIAGRAMS_DIR

    text = (DIAGRAMS_DIR / "one_dof.yaml").read_text()
    text = text.replace("name: one_dof", f"name: {name}", 1)
    path = folder / f"{name}.yaml"
    path.write_text(text.replace("duration_s: 20.0", f"duration_s: {duration}", 1))
    return path


def test_a_report_of_ones_own_scenario_file(tmp_path):
    from hlcmp_drake.cli import main

    own = _own_scenario(tmp_path)
    out = tmp_path / "report"
    assert main(["report", "--out", str(out), "--scenarios", str(own), "--quiet"]) == 0
    text = (out / "index.html").read_text()
    assert "my_one_dof/recording.html" in text and (out / "my_one_dof" / "metrics.json").exists()
    assert "1-DOF comparison with a variable-impedance controller: my_one_dof" in text
    # Each scenario's folder is a run's: its scenario.yaml reruns it to the same metrics.
    again = tmp_path / "again"
    assert main(["run", str(out / "my_one_dof" / "scenario.yaml"), "--out", str(again),
                 "--quiet"]) == 0  # fmt: skip
    for name in ("metrics.json", "timeseries.npz"):
        assert (again / name).read_bytes() == (out / "my_one_dof" / name).read_bytes(), name


def test_report_scenarios_are_all_checked_before_the_first_runs(tmp_path):
    from conftest import one_line_error, run_cli

    from hlcmp_drake.io.errors import InputError
    from hlcmp_drake.io.outputs import MANIFEST
    from hlcmp_drake.run.report import report_folders

    own = _own_scenario(tmp_path)
    assert report_folders(tmp_path / "r", [str(own), "one_dof"]) == {
        str(own): tmp_path / "r" / "my_one_dof",
        "one_dof": tmp_path / "r" / "one_dof",
    }
    with pytest.raises(InputError, match="has the name of one_dof"):
        report_folders(tmp_path / "r", ["one_dof", str(_own_scenario(tmp_path, "one_dof"))])
    with pytest.raises(InputError, match="one_dof: is given twice"):
        report_folders(tmp_path / "r", ["one_dof", "one_dof"])
    for file in ("index.html", MANIFEST):  # the page and the manifest beside the folders
        with pytest.raises(InputError, match=f"its name '{file}' is a file the report writes"):
            report_folders(tmp_path / "r", [str(_own_scenario(tmp_path, file))])
    out = tmp_path / "out"
    result = run_cli("report", "--out", out, "--scenarios", "one_dof", tmp_path / "nowhere.yaml")
    one_line_error(result)
    assert "nowhere.yaml" in result.stderr and not out.exists()
    for variants, expected in (
        (["nope"], "nope"),
        (["real_arm"], "--variants real_arm: only arm scenarios run under a variant, and none"),
    ):
        result = run_cli("report", "--out", out, "--scenarios", "one_dof", "--variants", *variants)
        assert expected in one_line_error(result) and not out.exists()


def test_a_reports_unstable_runs_say_why_on_the_terminal_and_on_the_page(tmp_path):
    """As `hlcmp run` does: each unstable run's reason and time, one line each, and the
    page beside the status; it says why the experiment then has no claims nor figures."""
    import html
    import json

    from conftest import run_cli

    from hlcmp_drake.present.report import UNSTABLE_NOTE

    own = _own_scenario(tmp_path, "runaway")
    own.write_text(own.read_text() + "max_abs_position_m: 0.005  # the body goes 0.15 m\n")
    out = tmp_path / "report"
    result = run_cli("report", "--out", out, "--scenarios", own, "--jobs", "1", "--quiet")
    assert result.returncode == 3, result.stderr
    instability = json.loads((out / "runaway" / "metrics.json").read_text())["instability"]
    assert instability
    logs = out / "runaway" / "timeseries.npz"
    page = (out / "index.html").read_text()
    for label, problem in instability.items():
        why = f"{problem['reason']} at t = {problem['time_s']:.3f} s"
        assert (
            f"UNSTABLE {label}: {why} (stopped there; its logs up to then are in {logs})"
            in result.stdout.splitlines()
        ), result.stdout
        assert f"<code>{label}</code>: {html.escape(why)}" in page
    assert UNSTABLE_NOTE in page


def _reports_agree(tmp_path, other: dict):
    """Two scenarios of one's own, one after the other in this process and as `other`
    says (run_report's keywords): the same files (the folder's manifest lists them all),
    metrics.json and the time series byte for byte, the page the same but for each
    section's wall time."""
    import re

    from hlcmp_drake.io.outputs import MANIFEST
    from hlcmp_drake.run.report import run_report

    own = [str(_own_scenario(tmp_path, name, duration=0.5)) for name in ("first", "second")]
    pages = {}
    for label, options in (("serial", {"jobs": 1}), ("other", other)):
        result = run_report(tmp_path / label, own, **options)
        assert result.all_ok and [s.name for s in result.sections] == ["first", "second"]
        pages[label] = re.sub(r"ran in \d+ s", "ran in N s", result.page.read_text())
    one, two = tmp_path / "serial", tmp_path / "other"
    assert (one / MANIFEST).read_text() == (two / MANIFEST).read_text()
    for name in ("first", "second"):
        for file in ("metrics.json", "timeseries.npz"):
            assert (one / name / file).read_bytes() == (two / name / file).read_bytes()
    assert pages["serial"] == pages["other"]


def _short_insertion(folder, name="short_insertion"):
    """The bundled insertion saved as one's own YAML, renamed and cut to 0.3 s."""
    from hlcmp_drake.io.paths import DIAGRAMS_DIR

    text = (DIAGRAMS_DIR / "insertion.yaml").read_text()
    text = text.replace("name: insertion", f"name: {name}", 1)
    text = text.replace("file: demos/", f"file: {DIAGRAMS_DIR}/demos/", 1)
    path = folder / f"{name}.yaml"
    path.write_text(text.replace("duration_s: 9.5", "duration_s: 0.3", 1))
    return path


def test_a_report_whose_runs_would_share_a_folder_is_refused_before_any_run(tmp_path):
    from conftest import one_line_error, run_cli

    from hlcmp_drake.io.paths import DIAGRAMS_DIR

    own = _short_insertion(tmp_path)
    named_like_its_variant = _short_insertion(tmp_path, "short_insertion_real_arm")
    out = tmp_path / "out"
    for scenarios, variants, expected in (
        ([own], ["real_arm", "real_arm"], "--variants real_arm: is given twice"),
        (
            [own],
            ["real_arm", DIAGRAMS_DIR / "variants" / "real_arm.yaml"],
            f"the runs of {own} under real_arm and of {own} under "
            f"{DIAGRAMS_DIR / 'variants' / 'real_arm.yaml'} would both go in "
            f"{out / 'short_insertion_real_arm'}",
        ),
        (
            [own, named_like_its_variant],
            ["real_arm"],
            f"the runs of {own} under real_arm and of {named_like_its_variant} would both go",
        ),
    ):
        result = run_cli(
            "report",
            "--out",
            out,
            "--jobs",
            "1",
            "--scenarios",
            *scenarios,
            "--variants",
            *variants,
        )
        assert expected in one_line_error(result) and not out.exists()


@pytest.mark.slow  # an insertion of 0.3 s, on the perfect robot and on the real arm
def test_a_report_shows_an_arm_on_the_real_arm_beside_the_perfect_one(tmp_path):
    import json

    from hlcmp_drake.run.report import _report_work, run_report

    own = _short_insertion(tmp_path)
    out = tmp_path / "report"
    result = run_report(out, [str(own)], jobs=1, variants=["real_arm"])
    assert result.all_ok and len(result.statuses) == 2
    section = result.sections[0]
    assert section.variants == {"real_arm": out / "short_insertion_real_arm"}
    perfect = json.loads((out / "short_insertion" / "metrics.json").read_text())
    real = json.loads((out / "short_insertion_real_arm" / "metrics.json").read_text())
    assert real["scenario"] == "short_insertion_real_arm"
    assert set(real["controllers"]) == set(perfect["controllers"])
    page = result.page.read_text()
    assert "The same controllers on another robot: real_arm" in page
    assert "short_insertion_real_arm/metrics.json" in page
    # one row per controller and robot, in the comparison
    assert page.count("<td>real_arm</td>") == len(perfect["controllers"])
    # without variants, only the runs (a task per controller) and the probe
    work = _report_work(str(own), out / "short_insertion", [])
    assert [task.variant for task in work] == [None] * len(work)
    assert [task.controller for task in work if not task.probe] == list(perfect["controllers"])
    assert [task.probe for task in work] == [False] * len(perfect["controllers"]) + [True]


@pytest.mark.slow  # the report twice, once in a process pool (about 3.0 s)
def test_a_report_in_processes_writes_what_the_serial_one_writes(tmp_path):
    _reports_agree(tmp_path, {"jobs": 2})


@pytest.mark.slow
@pytest.mark.xdist_group("ray")  # one local Ray instance at a time
def test_a_report_on_ray_writes_what_the_serial_one_writes(tmp_path):
    pytest.importorskip("ray")
    _reports_agree(tmp_path, {"jobs": 2, "engine": "ray"})


def test_a_report_on_ray_without_ray_says_how_to_install_it(tmp_path, monkeypatch):
    from conftest import one_line_error, run_cli

    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails as if not installed
    out = tmp_path / "out"
    result = run_cli("report", "--out", out, "--scenarios", "one_dof", "--engine", "ray")
    one_line_error(result)
    assert "--engine ray needs Ray, which is not installed" in result.stderr
    assert not out.exists()
