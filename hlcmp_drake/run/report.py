"""`hlcmp report`: run bundled scenarios and write one offline page linking their runs."""

from __future__ import annotations

import dataclasses as dc
import time
from pathlib import Path

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.io.outputs import replacing_outputs, write_text
from hlcmp_drake.io.paths import bundled_scenarios
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.present.report import ReportSection, report_page
from hlcmp_drake.run.probe import run_probe
from hlcmp_drake.run.runner import run_scenario


@dc.dataclass
class ReportResult:
    """The page written, each scenario's section and status, and the total wall time [s]."""

    page: Path
    sections: list
    statuses: list
    wall_s: float

    @property
    def all_ok(self) -> bool:
        """Whether every scenario's runs ended "ok"."""
        return all(status == "ok" for status in self.statuses)


def run_report(
    out_dir: str | Path, scenarios: list[str] | None = None, reporter: Progress = SILENT
) -> ReportResult:
    """Run each bundled scenario into out_dir/<name> and write out_dir/index.html, a page
    that works offline.

    Parameters
    ----------
    out_dir : str or Path
    scenarios : list of str, optional
        Bundled scenario names, in page order (default: every bundled scenario, in the
        order of the paper's sections).
    reporter : Progress, optional
    """
    out_dir = Path(out_dir)
    if scenarios is None:
        scenarios = sorted(
            bundled_scenarios(), key=lambda n: experiment_of(load_scenario(n)[0]).paper_section
        )
    sections, statuses, start = [], [], time.perf_counter()
    with replacing_outputs(out_dir):  # a scenario left out this time leaves no old folder
        for name in scenarios:
            reporter.say(f"running {name} ...")
            began = time.perf_counter()
            result = run_scenario(name, out_dir / name, reporter=reporter)
            probe_dir = None
            if result.scenario.probe.push_m:  # the world alone, no controller (hlcmp probe)
                probe_dir = run_probe(name, out_dir / name / "probe").out_dir
            sections.append(
                ReportSection(
                    name, result.out_dir, time.perf_counter() - began, result.experiment, probe_dir
                )
            )
            statuses.append(result.metrics["status"])
        page = write_text(out_dir / "index.html", report_page(out_dir, sections))
    return ReportResult(page, sections, statuses, time.perf_counter() - start)
