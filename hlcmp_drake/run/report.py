"""`hlcmp report`: run bundled scenarios and write one offline page linking their runs."""

from __future__ import annotations

import dataclasses as dc
import time
from pathlib import Path

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.io.errors import InputError
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


def report_folders(out_dir: str | Path, scenarios: list[str] | None = None) -> dict[str, Path]:
    """Each scenario of a report and the folder its runs go in, out_dir/<scenario name>,
    every scenario loaded (and so checked) first.

    Parameters
    ----------
    out_dir : str or Path
    scenarios : list of str, optional
        Bundled scenario names or scenario .yaml paths, in page order (default: every
        bundled scenario, in the order of the paper's sections).

    Returns
    -------
    dict of str to Path
        {the scenario as given: its folder}, in page order.

    Raises
    ------
    InputError
        A scenario that does not load (its file and line), one given twice, two with the
        same name (they would share a folder), or a name that is not a plain folder name.
    """
    if scenarios is None:
        scenarios = sorted(
            bundled_scenarios(), key=lambda n: experiment_of(load_scenario(n)[0]).paper_section
        )
    folders: dict[str, Path] = {}
    given: dict[str, str] = {}
    for entry in scenarios:
        scenario, path = load_scenario(entry)
        experiment_of(scenario, path)  # an experiment that does not fit stops here too
        name = scenario.name
        if Path(name).name != name or name in (".", ".."):
            raise InputError(
                f"--scenarios {entry}: its name '{name}' cannot name a folder of the report"
            )
        if name in given:
            twice = "is given twice" if given[name] == entry else f"has the name of {given[name]}"
            raise InputError(
                f"--scenarios {entry}: {twice} ('{name}'); each scenario's runs go in "
                f"{Path(out_dir) / name}"
            )
        given[name] = entry
        folders[entry] = Path(out_dir) / name
    return folders


def run_report(
    out_dir: str | Path, scenarios: list[str] | None = None, reporter: Progress = SILENT
) -> ReportResult:
    """Run each scenario into out_dir/<its name> and write out_dir/index.html, a page that
    works offline.

    Parameters
    ----------
    out_dir : str or Path
    scenarios : list of str, optional
        Bundled scenario names or scenario .yaml paths (your own), in page order (default:
        every bundled scenario, in the order of the paper's sections). All are loaded and
        checked before the first runs (`report_folders`).
    reporter : Progress, optional
    """
    out_dir = Path(out_dir)
    folders = report_folders(out_dir, scenarios)
    sections, statuses, start = [], [], time.perf_counter()
    with replacing_outputs(out_dir):  # a scenario left out this time leaves no old folder
        for entry, folder in folders.items():
            reporter.say(f"running {entry} ...")
            began = time.perf_counter()
            result = run_scenario(entry, folder, reporter=reporter)
            probe_dir = None
            if result.scenario.probe.push_m:  # the world alone, no controller (hlcmp probe)
                probe_dir = run_probe(entry, folder / "probe").out_dir
            sections.append(
                ReportSection(
                    folder.name,
                    result.out_dir,
                    time.perf_counter() - began,
                    result.experiment,
                    probe_dir,
                )
            )
            statuses.append(result.metrics["status"])
        page = write_text(out_dir / "index.html", report_page(out_dir, sections))
    return ReportResult(page, sections, statuses, time.perf_counter() - start)
