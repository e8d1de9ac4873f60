"""Skill-library files: one scenario, the task parameters to learn a skill at, and the
learning trials per skill; planned into tasks that each carry their whole scenario as YAML
text, as a sweep's tasks do (`hlcmp_drake.config.sweep`).

A library file (``diagrams/libraries/*.yaml``)::

    scenario: insertion      # a bundled scenario, or a .yaml path relative to this file
    trials: 3                # learning trials per skill, as `hlcmp learn --trials`
    demo_force: false        # start each skill's feed-forward from the demonstration's
                             #   force, as `hlcmp learn --demo-force` (default false)
    set:                     # fixed overrides, every skill
      controllers.hlcmp.q_units: per_step
    grid:                    # task parameter (any --set key) -> numbers; every combination
      task.puncture.depth_m: [0.010, 0.0125, 0.015]       #   is one skill of the library
      task.puncture.hole_friction_N_per_m: [60.0, 120.0]

A grid key is a task parameter of the library (a query key of `hlcmp generalize`): it
takes at least two values, each a finite number (read as a sweep's grid reads it, 1e-2
included), since a skill is regressed on them. (So reference.duration_s takes no 0, which stands
for the demonstration's own duration; and no key of `dmp` is one: the skills regressed
together share one DMP's settings, which `set` may give.)
A relative path (reference.file) is read beside the library file, as a sweep file's is.
Planning loads every skill's scenario with its overrides, so a bad key or value stops the
library before anything runs, naming the library file's line.
"""

import dataclasses as dc
import itertools
import math
from pathlib import Path

from hlcmp_drake.config.loading import dump_scenario, resolve_yaml
from hlcmp_drake.config.sweep import (
    _KEY,
    _key_line,
    _load_task_scenario,
    _scenario_path,
    read_typed_file,
    task_id,
    task_overrides,
    yaml_number,
)
from hlcmp_drake.config.world import inputs_digest
from hlcmp_drake.io.errors import located
from hlcmp_drake.io.paths import DIAGRAMS_DIR

# No `from __future__ import annotations` here: Drake's typed YAML reads the dataclasses'
# field types, which must be types, not strings.

LIBRARIES_DIR = DIAGRAMS_DIR / "libraries"
MAX_TRIALS = 100  # as `hlcmp learn --trials`
SKILLS_DIR = "skills"  # in the library's folder: one folder per skill
# The DMP's tau: its 0 is no duration but "as demonstrated", which a regression over the
# grid's numbers would take for the number 0.
AS_DEMONSTRATED_AT_0 = "reference.duration_s"
# The DMP's settings (n_basis, alpha, beta, alpha_s, smoothing_s): a skill's weights are
# read on its own basis and gains, so `hlcmp generalize` regresses only skills that share
# them all, and a grid over one would be learned in full and then refused.
DMP_SETTINGS = "dmp"


@dc.dataclass
class LibraryConfig:
    """What a library file holds (see the module's docstring for an example).

    Attributes
    ----------
    scenario : str
        A bundled scenario's name, or a .yaml path relative to the library file; it must
        follow a demonstration and have a learning controller (an Hl-CMP).
    trials : int
        Learning trials per skill, each starting from the theta the previous one ended
        with (the first from theta = 0), as `hlcmp learn --trials`.
    demo_force : bool
        Start each skill's first trial's feed-forward from the demonstration's force, as
        `hlcmp learn --demo-force` (the demonstration must carry force columns).
    controller : str
        The label of the learning controller that learns every skill, as `hlcmp learn
        --controller` (default: the scenario's first learner, in its file's order).
    set : dict of str to str
        Fixed overrides, every skill (YAML value text).
    grid : dict of str to list of str
        Task parameter (an override key) -> at least two numbers (YAML text); every
        combination is one skill.
    """

    scenario: str = ""
    trials: int = 3
    demo_force: bool = False
    controller: str = ""
    set: dict[str, str] = dc.field(default_factory=dict)
    grid: dict[str, list[str]] = dc.field(default_factory=dict)


@dc.dataclass
class LibrarySpec:
    """A loaded and checked library file.

    Attributes
    ----------
    path : Path
        The library file.
    text : str
        Its text (for the lines errors name).
    config : LibraryConfig
    scenario_path : Path
        The scenario file the skills override.
    parameters : list of str
        The grid's keys, in file order: the library's task parameters.
    values : dict of str to list of float
        Each parameter's grid values.
    """

    path: Path
    text: str
    config: LibraryConfig
    scenario_path: Path
    parameters: list
    values: dict


@dc.dataclass
class LibraryTask:
    """One skill of a library to learn: plain values only, so that it travels to a worker
    process or a Ray node as it is.

    Attributes
    ----------
    id : str
        Stable and readable, from the query (`hlcmp_drake.config.sweep.task_id`), e.g.
        "depth_m=0.01,hole_friction_N_per_m=60.0"; the name of its folder.
    query : dict of str to float
        Task parameter -> its value at this skill.
    overrides : list of str
        Every ``key=value`` applied over the scenario file, in order (set, grid).
    scenario_yaml : str
        The whole scenario after the overrides (`dump_scenario`).
    scenario_path : str
        The scenario file it came from (for messages and a relative demonstration).
    trials : int
        Learning trials.
    demo_force : bool
        The feed-forward starts from the demonstration's force (`LibraryConfig`).
    run_dir : str
        The skill's folder, OUT/skills/ID.
    inputs_digest : str
        `config.world.inputs_digest` of its scenario (its model files and demonstration
        by content).
    controller : str
        The learner's label ("": not yet chosen; `hlcmp_drake.run.library` chooses it, by
        the controller registry, before any skill is learned).
    """

    id: str
    query: dict
    overrides: list
    scenario_yaml: str
    scenario_path: str
    trials: int
    demo_force: bool
    run_dir: str
    inputs_digest: str
    controller: str = ""


def resolve_library_path(name_or_path: str | Path) -> Path:
    """The file of a bundled library (diagrams/libraries/NAME.yaml) or of a path.

    Parameters
    ----------
    name_or_path : str or Path
        See `hlcmp_drake.config.loading.resolve_yaml`.

    Returns
    -------
    Path
    """
    return resolve_yaml(name_or_path, LIBRARIES_DIR, "library")


def load_library_spec(name_or_path: str | Path) -> LibrarySpec:
    """Read and check a library file (not yet its skills' scenarios: see
    `plan_library_tasks`).

    Parameters
    ----------
    name_or_path : str or Path
        A bundled library's name or a library file.

    Returns
    -------
    LibrarySpec

    Raises
    ------
    InputError
        ``file:line: problem`` for a YAML error, an unknown key, a wrong type, a parameter
        set twice or with fewer than two values, a value that is not a finite number, and
        the like.
    """
    path = resolve_library_path(name_or_path)
    text, config, fail = read_typed_file(path, LibraryConfig)
    values = _check(config, fail)
    scenario_path = _scenario_path(config.scenario, path, fail)
    return LibrarySpec(path, text, config, scenario_path, list(config.grid), values)


def _number(text: str) -> float | None:
    """The finite number a YAML value text holds (as a sweep reads it: `yaml_number`), or
    None."""
    value = yaml_number(text)
    return value if value is not None and math.isfinite(value) else None


def _check(config: LibraryConfig, fail) -> dict:
    """The rules the schema cannot say; returns each parameter's values as numbers."""
    if not 1 <= config.trials <= MAX_TRIALS:
        fail("trials", f"trials: must be between 1 and {MAX_TRIALS}, got {config.trials}")
    if not config.grid:
        fail(
            "grid",
            "grid: a library needs at least one task parameter (an override key -> numbers)",
        )
    values = {}
    for key, texts in config.grid.items():
        if key in config.set:
            fail(f"grid.{key}", f"grid: '{key}' is also in set")
        if not _KEY.fullmatch(key):
            fail(f"grid.{key}", f"'{key}': an override key is dotted, e.g. task.puncture.depth_m")
        if key.split(".")[0] == DMP_SETTINGS:
            fail(
                f"grid.{key}",
                f"grid: '{key}': the DMP's settings are no task parameter: generalize "
                "regresses the weights of skills that share one DMP (its basis, gains and "
                "smoothing); give it under set, one value for every skill",
            )
        numbers = [_number(text) for text in texts]
        bad = [text for text, number in zip(texts, numbers) if number is None]
        if bad:
            fail(f"grid.{key}", f"grid: '{key}': every value must be a finite number, got {bad[0]}")
        if len(numbers) < 2:
            fail(
                f"grid.{key}",
                f"grid: '{key}' needs at least two values (a skill is regressed on it)",
            )
        if len(set(numbers)) != len(numbers):
            fail(f"grid.{key}", f"grid: '{key}' lists a value twice: {texts}")
        if key == AS_DEMONSTRATED_AT_0 and 0.0 in numbers:
            fail(
                f"grid.{key}",
                f"grid: '{key}': 0 means as demonstrated, not a duration the skills can be "
                "regressed on: give the demonstration's duration in seconds",
            )
        values[key] = numbers
    for key in config.set:
        if not _KEY.fullmatch(key):
            fail(key, f"'{key}': an override key is dotted, e.g. controllers.hlcmp.q_units")
    return values


def _check_demonstration_force(spec: LibrarySpec, scenario) -> None:
    """`demo_force: true` needs a demonstration with force columns (fx,fy,fz)."""
    from hlcmp_drake.io.demos import read_demonstration

    reference = scenario.reference
    *_, force = read_demonstration(reference.file, with_orientation=True, with_force=True)
    if force is None:
        line = _key_line(spec.text, "demo_force")
        raise located(
            spec.path,
            line,
            f"demo_force: the demonstration {reference.file} has no force columns "
            "(fx,fy,fz) to start the feed-forward from",
        )


def plan_library_tasks(spec: LibrarySpec, out_dir: str | Path) -> list[LibraryTask]:
    """Every skill of a library, each scenario loaded with its overrides (so every bad
    value is found before anything runs) and dumped as YAML text.

    Parameters
    ----------
    spec : LibrarySpec
        From `load_library_spec`.
    out_dir : str or Path
        The library's folder; skill ID is learned in OUT/skills/ID.

    Returns
    -------
    list of LibraryTask
        In grid order (first key slowest).

    Raises
    ------
    InputError
        Naming the library file's line for a bad override (with the problem the scenario
        loader found) or two skills whose ids collide.
    """
    config = spec.config
    numbers = {key: dict(zip(texts, spec.values[key])) for key, texts in config.grid.items()}
    tasks: list[LibraryTask] = []
    seen: set[str] = set()
    for point in itertools.product(*config.grid.values()):
        texts = dict(zip(config.grid, point))
        overrides = task_overrides(spec, [*config.set.items(), *texts.items()])
        scenario = _load_task_scenario(spec, overrides, texts, len(config.set))
        if config.demo_force and not tasks:  # one demonstration for every skill
            _check_demonstration_force(spec, scenario)
        identifier = task_id(texts)
        if identifier in seen:
            raise located(spec.path, None, f"two skills would share the id '{identifier}'")
        seen.add(identifier)
        tasks.append(
            LibraryTask(
                identifier,
                {key: numbers[key][text] for key, text in texts.items()},
                overrides,
                dump_scenario(scenario),
                str(spec.scenario_path),
                config.trials,
                config.demo_force,
                str(Path(out_dir) / SKILLS_DIR / identifier),
                inputs_digest(scenario),
            )
        )
    return tasks
