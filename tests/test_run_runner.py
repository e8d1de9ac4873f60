"""hlcmp_drake.run.runner (`hlcmp run`): an unstable run keeps its logs, the same command
gives the same metrics, a run's scenario.yaml runs it again, an interrupt writes nothing, a
live Meshcat shows the runs."""

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_output_names, run_cli, short_one_dof
from pydrake.geometry import Meshcat

from hlcmp_drake.cli import main
from hlcmp_drake.config.loading import dump_scenario, load_scenario


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


@pytest.mark.slow
def test_same_command_twice_gives_identical_metrics(tmp_path):
    for out in ("a", "b"):
        assert main(["run", *short_one_dof(), "--out", str(tmp_path / out), "--quiet"]) == 0
    assert (tmp_path / "a" / "metrics.json").read_bytes() == (
        tmp_path / "b" / "metrics.json"
    ).read_bytes()


def test_a_runs_scenario_yaml_runs_it_again_to_the_same_files(tmp_path):
    """The scenario as it ran, its overrides applied and its controllers in its own order
    (not the sorted order a YAML dump of a mapping has), is the run's scenario.yaml."""
    scenario, _ = load_scenario("one_dof")
    order = ["vic_fd_1.5", "hlcmp"]
    scenario.controllers = {label: scenario.controllers[label] for label in order}
    mine = tmp_path / "mine.yaml"
    mine.write_text(dump_scenario(scenario, controllers_in_order=True))
    first, again = tmp_path / "first", tmp_path / "again"
    gain = "controllers.hlcmp.q_k=[1500.0]"
    assert main(["run", str(mine), "--set", "duration_s=0.5", "--set", gain, "--out", str(first),
                 "--quiet"]) == 0  # fmt: skip
    recorded, _ = load_scenario(first / "scenario.yaml")
    assert list(recorded.controllers) == order
    assert recorded.duration_s == 0.5 and list(recorded.controllers["hlcmp"].q_k) == [1500.0]
    assert main(["run", str(first / "scenario.yaml"), "--out", str(again), "--quiet"]) == 0
    assert_output_names(again)
    figures = sorted(p.relative_to(first) for p in (first / "figures").iterdir())
    for name in ("metrics.json", "timeseries.npz", "scenario.yaml", "recording.html", *figures):
        assert (first / name).read_bytes() == (again / name).read_bytes(), name


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


def test_a_live_meshcat_shows_each_run_while_it_simulates(tmp_path):
    from hlcmp_drake.run.runner import run_scenario

    meshcat = Meshcat()
    run_scenario("one_dof", tmp_path, overrides=["duration_s=0.3"], meshcat=meshcat)
    for label in ("hlcmp", "hlcmp_per_step", "vic_fd_0.5"):
        assert meshcat.HasPath(f"/drake/runs/{label}")
    assert (tmp_path / "recording.html").exists()  # the offline recording is still written


@pytest.mark.slow  # two runs with all their files (about 1.6 s)
def test_a_reused_out_folder_loses_the_previous_runs_files_and_keeps_the_users(
    tmp_path, monkeypatch
):
    """The first run writes an insertion figure too (fig4, as `hlcmp run insertion` would);
    the second, the plain 1-DOF run into the same folder, leaves only its own files and the
    user's."""
    import dataclasses as dc

    import hlcmp_drake.run.runner as runner
    from hlcmp_drake.experiments import experiment_of

    def with_fig4(scenario, path=None):
        experiment = experiment_of(scenario, path)

        def figures(runs, scenario):
            made = experiment.figures(runs, scenario)
            return {**made, "fig4_profiles_z.png": next(iter(made.values()))}

        return dc.replace(experiment, figures=figures)

    out = tmp_path / "o"
    monkeypatch.setattr(runner, "experiment_of", with_fig4)
    assert main(["run", *short_one_dof(0.3), "--out", str(out), "--quiet"]) == 0
    assert (out / "figures" / "fig4_profiles_z.png").exists()
    (out / "figures" / "my_sketch.png").write_text("the user's")
    (out / "notes.txt").write_text("the user's")
    monkeypatch.undo()
    assert main(["run", *short_one_dof(0.3), "--out", str(out), "--quiet"]) == 0
    assert sorted(p.name for p in (out / "figures").iterdir()) == ["my_sketch.png", "one_dof.png"]
    assert {"notes.txt", "metrics.json", "timeseries.npz", "recording.html"} <= {
        p.name for p in out.iterdir()
    }


def test_a_run_records_a_bundled_demonstration_by_its_package_url(tmp_path):
    """So that the record runs wherever the package is installed; a demonstration of one's
    own keeps its absolute path."""
    from hlcmp_drake.run.runner import scenario_record

    scenario, _ = load_scenario("insertion")
    text = scenario_record(scenario)
    assert "file: package://hlcmp_drake/diagrams/demos/insertion_demo.csv" in text
    record = tmp_path / "scenario.yaml"
    record.write_text(text)
    assert load_scenario(record)[0].reference.file == scenario.reference.file
    mine = tmp_path / "mine.csv"
    mine.write_bytes(Path(scenario.reference.file).read_bytes())
    scenario.reference.file = str(mine)
    assert f"file: {mine}" in scenario_record(scenario)
