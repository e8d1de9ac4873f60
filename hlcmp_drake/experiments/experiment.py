"""What an experiment module declares: its name and title, the world it runs in, and how
its runs become metrics, claims, a table and figures."""

from __future__ import annotations

import dataclasses as dc
from typing import TYPE_CHECKING, Any, Callable

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from hlcmp_drake.config.scenario import ControllerConfig, Scenario
    from hlcmp_drake.experiments.table import Table
    from hlcmp_drake.io.runs import RunResult


@dc.dataclass(frozen=True)
class Experiment:
    """One of the paper's experiments, as the registry knows it.

    Attributes
    ----------
    name : str
        What a scenario's `experiment` field names.
    title : str
        A heading for the report and README.
    paper_section : str
        Its section of the paper, e.g. "V-D"; experiments are listed in this order.
    paper_figures : str
        The paper's figures it reproduces, e.g. "Figs. 4-8".
    world : type
        The task config type its scenarios use (SliderTask, ArmTask).
    controller_metrics : callable(run, config, scenario) -> dict
        One controller's metrics from its RunResult and its config.
    claims : callable(metrics, scenario, runs) -> dict
        {claim: {"holds", "evidence", "paper_says", ...}} from every controller's metrics.
    table : callable(metrics) -> Table
        The controllers' metrics as rows.
    figures : callable(runs, scenario) -> dict
        {file name: matplotlib Figure}.
    task_done : callable(run, scenario) -> dict
        Whether the run did the experiment's task: {"done": bool, "evidence": str, ...};
        a claim about a run that did not is not judged.
    from_paper : bool
        Whether it is one of the paper's experiments (its claims the paper's, in the
        README's claims summary); an experiment beyond the paper shows its own claims in
        its section.
    model_frames : tuple of str
        The frames of the scenario's models that its metrics read ("model::frame"),
        checked when a run's scenario is loaded.
    needs_puncture : bool
        Whether its task is judged by a puncture's tear (the task's `puncture`): a
        scenario without one is refused at load, since none of its runs could be judged.
    """

    name: str
    title: str
    paper_section: str
    paper_figures: str
    world: type
    controller_metrics: Callable[[RunResult, ControllerConfig, Scenario], dict[str, Any]]
    claims: Callable[..., dict[str, dict[str, Any]]]
    table: Callable[[dict[str, dict[str, Any]]], Table]
    figures: Callable[[dict[str, RunResult], Scenario], dict[str, Figure]]
    task_done: Callable[[RunResult, Scenario], dict[str, Any]]
    from_paper: bool = True
    model_frames: tuple[str, ...] = ()
    needs_puncture: bool = False

    def metrics_of(
        self, run: RunResult, config: ControllerConfig, scenario: Scenario
    ) -> dict[str, Any]:
        """One controller's entry of metrics.json: its metrics and whether it did the task.

        Parameters
        ----------
        run : RunResult
        config : controller config
        scenario : Scenario

        Returns
        -------
        dict
            `controller_metrics`, and `task` (`task_done`).
        """
        return {
            **self.controller_metrics(run, config, scenario),
            "task": self.task_done(run, scenario),
        }
