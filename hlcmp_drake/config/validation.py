"""Semantic checks of a loaded scenario that the YAML schema cannot express."""

import math
from pathlib import Path
from typing import Callable

from hlcmp_drake.config.scenario import (
    DemonstrationConfig,
    Fail,
    Scenario,
    StepReferenceConfig,
)
from hlcmp_drake.io.paths import MODELS_DIR, PACKAGE_NAME


def model_file_exists(file: str) -> bool:
    """Whether a directive's model file exists.

    Our package:// models and plain (or file://) paths are checked; other packages
    (drake_models, downloaded by Drake on first use) are left to Drake.

    Parameters
    ----------
    file : str
        The `add_model` directive's file: a package:// URL, a file:// URL or a path.

    Returns
    -------
    bool
        False only when a file of ours or a plain path is missing.
    """
    prefix = f"package://{PACKAGE_NAME}/models/"
    if file.startswith(prefix):
        return (MODELS_DIR / file[len(prefix) :]).is_file()
    if file.startswith("package://"):
        return True
    return Path(file.removeprefix("file://")).is_file()


def validate_scenario(
    scenario: Scenario, folder: Path, fail: Fail, fail_model: Callable[[str], None]
) -> None:
    """Raise InputError (through `fail(key, problem)`) for the first problem found.

    Parameters
    ----------
    scenario : Scenario
        As loaded (the demonstration's file still relative to `folder`).
    folder : Path
        The scenario file's folder, against which the demonstration is looked up.
    fail : callable(key, problem)
        Raises the InputError that names where `key` (a dotted path such as
        "controllers.hlcmp.q_k") was set: file:line, or the override that set it.
    fail_model : callable(file)
        Raises the InputError for a model file that does not exist.

    Raises
    ------
    InputError
        Through `fail` or `fail_model`, for the first problem found.
    """
    if not scenario.name:
        fail("name", "must be given")
    for directive in scenario.directives:
        if directive.add_model is not None and not model_file_exists(directive.add_model.file):
            fail_model(directive.add_model.file)
    for key in ("duration_s", "log_period_s"):
        value = getattr(scenario, key)
        if not (math.isfinite(value) and value > 0):
            fail(key, f"must be a positive number, got {value}")
    try:
        scenario.dmp.check()
    except ValueError as error:
        fail(f"dmp.{str(error).split()[0]}", str(error))
    reference = scenario.reference
    if isinstance(reference, StepReferenceConfig):
        if len(reference.times_s) != len(reference.positions_m) or not reference.times_s:
            fail("reference.times_s", "needs one entry per row of positions_m")
        if reference.times_s[0] != 0 or any(
            b <= a for a, b in zip(reference.times_s, reference.times_s[1:])
        ):
            fail("reference.times_s", "must start at 0 and increase")
        if len({len(row) for row in reference.positions_m}) != 1:
            fail("reference.positions_m", "every row needs the same number of axes")
    if isinstance(reference, DemonstrationConfig):
        demo = Path(folder) / reference.file
        if not reference.file or not demo.is_file():
            fail(
                "reference.file",
                f"demonstration file '{reference.file}' not found (looked for {demo})",
            )
        if not reference.duration_s >= 0:
            fail(
                "reference.duration_s",
                "the demonstration's duration_s must be >= 0 (0: as demonstrated)",
            )
    scenario.task.check_scenario(scenario, fail)
    if not scenario.controllers:
        fail("controllers", "at least one controller is needed")
    for name, config in scenario.controllers.items():
        config.check(name, scenario.n_axes, fail)
