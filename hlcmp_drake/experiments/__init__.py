"""The experiments registry: every module of this package that declares an `EXPERIMENT`
(see `experiment.Experiment`) is an experiment a scenario can name. Adding one: its YAML
in diagrams/, its models or demonstration, and one module here.

Each experiment turns runs into metrics, the paper's claims, a table and figures."""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

from hlcmp_drake.config.loading import scenario_error
from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.experiments.experiment import Experiment


def _discover() -> dict[str, Experiment]:
    found = {}
    for module_info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{__name__}.{module_info.name}")
        experiment = getattr(module, "EXPERIMENT", None)
        if isinstance(experiment, Experiment):
            found[experiment.name] = experiment
    return dict(sorted(found.items(), key=lambda item: item[1].paper_section))


EXPERIMENTS: dict[str, Experiment] = _discover()


def experiment_of(scenario: Scenario, path: str | Path | None = None) -> Experiment:
    """The experiment a scenario names, checked to fit the scenario's world.

    Parameters
    ----------
    scenario : Scenario
    path : str or Path, optional
        The scenario's file, whose `experiment` line an error names.

    Returns
    -------
    Experiment

    Raises
    ------
    InputError
        Naming the scenario file's `experiment` line when the name is unknown or the
        experiment runs in another kind of world.
    """
    experiment = EXPERIMENTS.get(scenario.experiment)
    where = path or scenario.name
    if experiment is None:
        raise scenario_error(
            where,
            "experiment",
            f"must be one of {', '.join(EXPERIMENTS)}, got '{scenario.experiment}'",
        )
    if not isinstance(scenario.task, experiment.world):
        raise scenario_error(
            where,
            "experiment",
            f"'{scenario.experiment}' does not fit a {type(scenario.task).__name__}",
        )
    return experiment


def claim_names(experiment: Experiment) -> list[str] | None:
    """The names of the claims an experiment judges (its module's `CLAIMS`), in order.

    Parameters
    ----------
    experiment : Experiment

    Returns
    -------
    list of str or None
        None when its module declares no `CLAIMS`.
    """
    module = importlib.import_module(experiment.claims.__module__)
    claims = getattr(module, "CLAIMS", None)
    return None if claims is None else [claim.name for claim in claims]
