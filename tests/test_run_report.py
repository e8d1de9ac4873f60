"""hlcmp_drake.run.report (hlcmp report): the command runs the scenarios and writes the page."""

import pytest


@pytest.mark.slow
def test_report_command_runs_the_scenarios(tmp_path):
    from hlcmp_drake.cli import main

    assert main(["report", "--out", str(tmp_path), "--scenarios", "one_dof", "--quiet"]) == 0
    text = (tmp_path / "index.html").read_text()
    assert "one_dof/recording.html" in text and (tmp_path / "one_dof" / "metrics.json").exists()
