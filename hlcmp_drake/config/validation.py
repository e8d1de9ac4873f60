"""Semantic checks of a loaded scenario that the YAML schema cannot express: every value,
before any simulation, and the names of models, frames and bodies against the scenario's
models, parsed once."""

from __future__ import annotations

import dataclasses as dc
import math
import sys
from collections import OrderedDict
from functools import partial
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import GetIntegrationSchemes, SimulatorConfig
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.models import (
    DIRECTIVE_KINDS,
    bundled_models_version,
    frame_problem,
    loading_problem,
    missing_model,
    process_directives,
    tool_mount,
)
from hlcmp_drake.config.scenario import (
    ArmTask,
    DemonstrationConfig,
    Fail,
    RotationChecks,
    Scenario,
    StepReferenceConfig,
    check_number,
)
from hlcmp_drake.io.demos import MAX_DURATION_S, replay_speed_problem
from hlcmp_drake.io.paths import DATA_ROOT, MODELS_DIR, PACKAGE_NAME, data_file, data_url

# MultibodyPlantConfig's names that Drake reads as one of a list of options.
PLANT_OPTIONS = (
    "contact_model",
    "discrete_contact_approximation",
    "contact_surface_representation",
)


def model_file_exists(file: str) -> bool:
    """Whether a directive's model file exists.

    Our package:// models and file:// paths are checked; other packages (drake_models,
    downloaded by Drake on first use) are left to Drake. (A plain path is no URL, which
    Drake refuses: `check_directives` says so first.)

    Parameters
    ----------
    file : str
        The `add_model` directive's file: a package:// URL, a file:// URL or a path.

    Returns
    -------
    bool
        False only when a file of ours or a file:// (or plain) path is missing.
    """
    prefix = f"package://{PACKAGE_NAME}/models/"
    if file.startswith(prefix):
        return (MODELS_DIR / file[len(prefix) :]).is_file()
    if file.startswith("package://"):
        return True
    return Path(file.removeprefix("file://")).is_file()


@dc.dataclass(frozen=True)
class ExperimentNeeds:
    """What an experiment needs of a scenario: the task class its world is built from, and
    the frames of the scenario's models its metrics read ("model::frame", e.g. the peg
    world's hole), looked up at load so that a missing one stops before any simulation; and
    whether it judges its task by a puncture's tear (`task.puncture`), without which no run
    of the scenario could be judged."""

    task: type
    frames: tuple[str, ...] = ()
    puncture: bool = False


# What replaying the reference in a duration [s] would do wrong, or None (`io.demos`'s
# replay_speed_problem for a demonstration file).
ReplayProblem = Callable[[float], str | None]


def validate_scenario(
    scenario: Scenario,
    folder: Path,
    fail: Fail,
    experiments: Mapping[str, ExperimentNeeds] | None = None,
    replay_problem: ReplayProblem | None = None,
) -> None:
    """Raise InputError (through `fail(key, problem)`) for the first problem found.

    Every value is checked (finite numbers in their ranges, vectors of the right length,
    names of options), then the models are parsed once and the frames, bodies and models
    that the scenario names are looked up in them.

    Parameters
    ----------
    scenario : Scenario
        As loaded (the demonstration's file still relative to `folder`).
    folder : Path
        The scenario file's folder, against which the demonstration is looked up.
    fail : callable(key, problem)
        Raises the InputError that names where `key` (a dotted path such as
        "controllers.hlcmp.q_k", or "directives.3.add_weld" for a list's item) was set:
        file:line, or the override that set it.
    experiments : mapping of str to ExperimentNeeds, optional
        The experiments a run may name, each to what it needs; given, `experiment` must
        be one of them, fit the task, and find its frames in the models.
    replay_problem : callable(duration_s) -> str or None, optional
        What replaying the reference the runs follow in `reference.duration_s` does
        wrong, where that is not the scenario's demonstration file (learn's own
        demonstration, a skill's DMP); default: the file's (`replay_speed_problem`).

    Raises
    ------
    InputError
        Through `fail`, for the first problem found.
    """
    if not scenario.name:
        fail("name", "must be given")
    if Path(scenario.name).name != scenario.name or scenario.name in (".", ".."):
        # run, report, sweep and learn write into a folder of this name, inside theirs
        fail("name", f"must be a plain folder name (no '/', not . or ..), got '{scenario.name}'")
    check_directives(scenario, fail)
    for key in ("duration_s", "log_period_s", "max_abs_position_m"):
        check_number(getattr(scenario, key), key, fail, "> 0")
    if scenario.duration_s > MAX_DURATION_S:
        fail(
            "duration_s",
            f"must be at most {MAX_DURATION_S:g} s, got {scenario.duration_s:g}: the references "
            "are sampled every few ms over the whole run, in memory",
        )
    shortest = scenario.duration_s / MAX_LOG_SAMPLES
    if scenario.log_period_s < shortest:
        fail(
            "log_period_s",
            f"must be at least {shortest:.3g} s for a {scenario.duration_s:g} s run, got "
            f"{scenario.log_period_s:g}: at most {MAX_LOG_SAMPLES:.0e} samples are logged",
        )
    if scenario.log_period_s > MAX_LOG_PERIOD_S:
        fail(
            "log_period_s",
            f"must be at most {MAX_LOG_PERIOD_S:g} s, got {scenario.log_period_s:g}: the "
            "metrics (peaks, reach times, smoothness) are read from the logged samples",
        )
    check_plant_config(scenario.plant_config, fail)
    check_simulator_config(scenario.simulator_config, fail)
    try:
        scenario.dmp.check()
    except ValueError as error:  # "FIELD must ..."
        field, _, rule = str(error).partition(" ")
        fail(f"dmp.{field}", rule)
    _check_reference(scenario, folder, fail, replay_problem)
    scenario.task.check_scenario(scenario, fail)
    if not scenario.controllers:
        fail("controllers", "at least one controller is needed")
    for name, config in scenario.controllers.items():
        config.check(name, scenario.n_axes, fail)
        config.check_reference(name, scenario.reference, fail)
        if isinstance(config, RotationChecks) and not (
            isinstance(scenario.task, ArmTask) and scenario.task.control_path == "fast"
        ):
            fail(
                f"controllers.{name}",
                f"controller '{name}' acts on the tool's orientation: it needs an !ArmTask "
                "on the fast path (task.control_path: fast)",
            )
    scenario.recording.check(fail)
    scenario.probe.check(fail)
    scenario.iiwa_driver.check(fail)
    scenario.robot_imperfection.check(fail)
    scenario.robot_imperfection.check_scenario(scenario, fail)
    if scenario.probe.given and not isinstance(scenario.task, ArmTask):
        fail("probe.start_m", "a probe carries an arm's tool: it needs an !ArmTask task")
    needs = None if experiments is None else experiments.get(scenario.experiment)
    if experiments is not None:
        if needs is None:
            fail(
                "experiment",
                f"must be one of {', '.join(experiments)}, got '{scenario.experiment}'",
            )
        if not isinstance(scenario.task, needs.task):
            fail(
                "experiment",
                f"'{scenario.experiment}' needs a !{needs.task.__name__} task, the scenario has "
                f"!{type(scenario.task).__name__}",
            )
        if needs.puncture and not (
            isinstance(scenario.task, ArmTask) and scenario.task.puncture.object_frame
        ):
            fail(
                "experiment",
                f"'{scenario.experiment}' judges a run by the tear of the punctured object: "
                "it needs task.puncture (task.puncture.object_frame is empty)",
            )
    plant = scenario_plant(scenario, fail)
    for frame in needs.frames if needs else ():
        problem = frame_problem(plant, frame)
        if problem:
            fail(
                "experiment",
                f"'{scenario.experiment}' reads the frame '{frame}' of the scenario's "
                f"models: {problem}",
            )
    scenario.task.check_models(plant, fail)
    scenario.robot_imperfection.check_models(plant, fail)
    if scenario.probe.given:
        arm = scenario.probe.arm_model
        problem = missing_model(plant, arm) or (
            None
            if tool_mount(scenario.directives, arm)
            else f"no tool is welded to model '{arm}' (an add_weld with parent '{arm}::...')"
        )
        if problem:
            fail("probe.arm_model", problem)


# The most samples a run logs: each is a row of every logged series (about 50 doubles),
# and the simulator steps at least as often as it logs.
MAX_LOG_SAMPLES = 1_000_000
# The longest log period [s]: every metric (a peak, a reach time, the force's smoothness) and
# the run's own length are read from the logged samples, so a coarser log misstates them
# (a 20 s run logged every 7 s "ran 14 s").
MAX_LOG_PERIOD_S = 0.1


def _check_reference(
    scenario: Scenario, folder: Path, fail: Fail, replay_problem: ReplayProblem | None
) -> None:
    """The set-points (times from 0, increasing; rows of one length; all finite) or the
    demonstration (its file, a finite duration >= 0, and a replay in that duration of what
    the runs follow -- the file, or what `replay_problem` checks -- no faster than a
    demonstration may move)."""
    reference = scenario.reference
    if isinstance(reference, StepReferenceConfig):
        if not reference.times_s:
            fail("reference.times_s", "needs at least one set-point (t = 0), got none")
        if len(reference.times_s) != len(reference.positions_m):
            fail(
                "reference",
                f"times_s needs one entry per row of positions_m: {len(reference.times_s)} "
                f"time(s), {len(reference.positions_m)} row(s)",
            )
        if not all(math.isfinite(t) for t in reference.times_s):
            fail("reference.times_s", f"every time must be finite, got {reference.times_s}")
        if reference.times_s[0] != 0 or any(
            b <= a for a, b in zip(reference.times_s, reference.times_s[1:])
        ):
            fail("reference.times_s", "must start at 0 and increase")
        if len({len(row) for row in reference.positions_m}) != 1:
            fail("reference.positions_m", "every row needs the same number of axes")
        if not np.all(np.isfinite(reference.positions_m)):
            fail(
                "reference.positions_m",
                f"every position must be finite, got {reference.positions_m}",
            )
    if isinstance(reference, DemonstrationConfig):
        demo = data_file(reference.file, Path(folder))
        if reference.file and demo.is_dir():
            where = "" if str(demo.resolve()) == reference.file else f" ({demo.resolve()})"
            fail(
                "reference.file",
                f"'{reference.file}'{where} is a folder, not a demonstration file (a CSV)",
            )
        if not reference.file or not demo.is_file():
            bundled = DATA_ROOT / "diagrams" / "demos" / Path(reference.file).name
            fail(
                "reference.file",
                f"demonstration file '{reference.file}' not found (looked for "
                f"{demo.resolve()})"
                + (f"; the bundled one is {data_url(bundled)}" if bundled.is_file() else ""),
            )
        if not (math.isfinite(reference.duration_s) and reference.duration_s >= 0):
            fail(
                "reference.duration_s",
                "the demonstration's duration_s must be finite and >= 0 (0: as demonstrated), "
                f"got {reference.duration_s}",
            )
        if reference.duration_s > 0:
            problem = (replay_problem or partial(replay_speed_problem, demo))(reference.duration_s)
            if problem:
                fail("reference.duration_s", problem)


def check_directives(scenario: Scenario, fail: Fail) -> None:
    """What is checked before the models are parsed: the rules of Drake's
    ModelDirective::IsValid (which ProcessModelDirectives does not apply, and which log
    rather than raise), the model files exist, and every pose (a weld's X_PC, a frame's
    X_PF, a model's default free-body poses) and default joint position is finite.

    Parameters
    ----------
    scenario : Scenario
        Its `directives`.
    fail : callable(key, problem)
        Raises the InputError for "directives.K.KIND" (the K-th directive, 0-based).

    Raises
    ------
    InputError
        Through `fail`, for the first problem found.
    """
    for k, directive in enumerate(scenario.directives):
        kinds = [n for n in DIRECTIVE_KINDS if getattr(directive, n) is not None]
        if len(kinds) != 1:
            fail(
                f"directives.{k}",
                f"a directive is one of {', '.join(DIRECTIVE_KINDS)}, got "
                f"{', '.join(kinds) or 'none'}",
            )
        kind, item = kinds[0], getattr(directive, kinds[0])
        key = f"directives.{k}.{kind}"
        required = {
            "add_model": ("file", "name"),
            "add_model_instance": ("name",),
            "add_frame": ("name",),
            "add_weld": ("parent", "child"),
            "add_collision_filter_group": ("name",),
            "add_directives": ("file",),
        }[kind]
        for field in required:
            if not getattr(item, field):
                fail(f"{key}.{field}", f"{kind} needs a non-empty {field}")
        if kind in ("add_model", "add_directives") and "://" not in item.file:
            fail(
                f"{key}.file",
                f"'{item.file}' is a plain path; Drake reads a model file from a URL: "
                "package://PACKAGE/... or file:///absolute/path",
            )
        file = getattr(item, "file", "")
        if file.startswith("file://") and not file.startswith("file:///"):
            # Drake reads file:// as absolute; this check would look where the command runs.
            fail(
                f"{key}.file",
                f"'{file}': a file:// URL takes an absolute path, file:///absolute/path "
                f"(three slashes)",
            )
        if kind == "add_model" and not model_file_exists(item.file):
            fail(f"{key}.file", f"model file '{item.file}' does not exist")
        if kind == "add_collision_filter_group" and not (item.members or item.member_groups):
            fail(f"{key}.members", "a collision filter group needs members or member_groups")
        poses = {  # (field, what the message calls the pose): the pose
            "add_weld": {("X_PC", ""): getattr(item, "X_PC", None)},
            "add_frame": {("X_PF", ""): getattr(item, "X_PF", None)},
            "add_model": {
                ("default_free_body_pose", f"body '{body}': "): pose
                for body, pose in getattr(item, "default_free_body_pose", {}).items()
            },
        }.get(kind, {})
        for (field, which), pose in poses.items():
            rule = {"add_frame": "required", "add_weld": "forbidden"}.get(kind, "any")
            problem = _pose_problem(pose, rule)
            if problem:
                fail(f"{key}.{field}", f"{which}{problem}")
        for joint, values in getattr(item, "default_joint_positions", {}).items():
            if not np.all(np.isfinite(values)):
                fail(
                    f"{key}.default_joint_positions",
                    f"joint '{joint}': every position must be finite, got "
                    f"{[float(v) for v in values]}",
                )


def _pose_problem(pose: Any, base_frame: str) -> str | None:
    """What is wrong with a directive's pose (a schema Transform), or None: it must be
    deterministic and finite, and have a base frame as `base_frame` says: "required"
    (add_frame's X_PF), "forbidden" (a weld's X_PC is in its parent frame) or "any"."""
    if pose is None:
        return None
    if base_frame == "required" and not pose.base_frame:
        return "needs a base_frame, the frame it is given in"
    if base_frame == "forbidden" and pose.base_frame:
        return f"must not have a base_frame (got '{pose.base_frame}'): it is in the parent frame"
    if not pose.IsDeterministic():
        return "must be one pose, not a random distribution"
    try:
        matrix = pose.GetDeterministicValue().GetAsMatrix4()
    except RuntimeError:  # a NaN in a rotation's angles
        matrix = np.full((4, 4), np.nan)
    if not np.all(np.isfinite(matrix)):
        return "the pose (translation and rotation) must be finite"
    return None


def check_plant_config(config: MultibodyPlantConfig, fail: Fail) -> None:
    """The plant config's numbers, before Drake sees them (it aborts the process on some):
    time_step finite and >= 0 (0: continuous), penetration_allowance and
    stiction_tolerance finite and > 0, sap_near_rigid_threshold finite and >= 0. Its
    options are checked by Drake when the models are parsed (`scenario_plant`).

    Parameters
    ----------
    config : MultibodyPlantConfig
        The scenario's `plant_config`.
    fail : callable(key, problem)
        Raises the InputError that names where the key was set.

    Raises
    ------
    InputError
        Through `fail`, for the first problem found.
    """
    for key, rule in (
        ("time_step", ">= 0"),
        ("penetration_allowance", "> 0"),
        ("stiction_tolerance", "> 0"),
        ("sap_near_rigid_threshold", ">= 0"),
    ):
        check_number(getattr(config, key), f"plant_config.{key}", fail, rule)


def check_simulator_config(config: SimulatorConfig, fail: Fail) -> None:
    """The simulator config: a known integration scheme, max_step_size and accuracy finite
    and > 0, target_realtime_rate finite and >= 0 (0: as fast as it goes), start_time 0
    (every run starts at t = 0).

    Parameters
    ----------
    config : SimulatorConfig
        The scenario's `simulator_config`.
    fail : callable(key, problem)
        Raises the InputError that names where the key was set.

    Raises
    ------
    InputError
        Through `fail`, for the first problem found.
    """
    schemes = GetIntegrationSchemes()
    if config.integration_scheme not in schemes:
        fail(
            "simulator_config.integration_scheme",
            f"must be one of {', '.join(schemes)}, got '{config.integration_scheme}'",
        )
    check_number(config.max_step_size, "simulator_config.max_step_size", fail, "> 0")
    check_number(config.accuracy, "simulator_config.accuracy", fail, "> 0")
    check_number(config.target_realtime_rate, "simulator_config.target_realtime_rate", fail, ">= 0")
    if config.start_time != 0:
        fail(
            "simulator_config.start_time",
            f"must be 0 (every run starts at t = 0), got {config.start_time}",
        )


# The plants `_parsed` made last, by what they were made of: a sweep, a library or a
# session loads many variants of one scenario, most with its models unchanged, and each
# parse builds the foam's hydroelastic mesh again (a third of a load's time).
_PARSED: OrderedDict[tuple, MultibodyPlant] = OrderedDict()
PARSED_KEPT = 8


def _parsed(
    config: MultibodyPlantConfig, directives: list, by_drake: bool = False
) -> MultibodyPlant:
    """A finalized plant (with a SceneGraph, so that collision filters are resolved) of
    `config` and `directives`; Drake's RuntimeError when it cannot be made (by_drake:
    every directive processed by Drake, `process_directives`). The plant is shared by the
    loads of the same config and directives while the bundled models' files are unchanged
    (`_parsed_key`): its users only read it."""
    key = _parsed_key(config, directives, by_drake)
    if key is not None and key in _PARSED:
        _PARSED.move_to_end(key)
        return _PARSED[key]
    plant, scene_graph = AddMultibodyPlant(config, DiagramBuilder())
    process_directives(plant, directives, scene_graph, by_drake)
    plant.Finalize()
    if key is not None:
        _PARSED[key] = plant
        if len(_PARSED) > PARSED_KEPT:
            _PARSED.popitem(last=False)
    return plant


def _parsed_key(config: MultibodyPlantConfig, directives: list, by_drake: bool) -> tuple | None:
    """Everything `_parsed` reads, as a key: the config and the directives to the last bit
    of every number (`repr` with numpy's shortest exact floats) and the bundled models'
    files (`bundled_models_version`); None where a directive reads another file or holds
    a value that `repr` does not spell out."""
    models = bundled_models_version(directives)
    if models is None:
        return None
    with np.printoptions(floatmode="unique", threshold=sys.maxsize):
        texts = repr(config), tuple(map(repr, directives))
    # A value without a repr of its own (a schema's !DeterministicVector) shows its address,
    # which another value may take once it is freed.
    if " object at 0x" in str(texts):
        return None
    return *texts, by_drake, models


def _refused_directive(scenario: Scenario, problem: str) -> int:
    """The index of the directive Drake refuses with `problem`: the scenario's whole list
    of directives fails with it, an empty one (the plant config alone) loads, and the
    answer k is where the first k directives do not fail so and the first k + 1 do.

    A shorter list may fail for another reason, which is not this problem: a collision
    filter group may ignore a group that a later directive makes, or name a body that a
    later one adds. So the lists are bisected by whether they fail at all, each parsed as
    the worlds parse it (`process_directives`, about a fifteenth of Drake's own parse of
    the bundled models), and the answer is checked by Drake's own parse; only where that
    disagrees is every try Drake's."""

    def fails(count: int, so: bool) -> bool:
        try:
            _parsed(scenario.plant_config, scenario.directives[:count], by_drake=so)
        except RuntimeError as error:
            return not so or loading_problem(error) == problem
        return False

    count = len(scenario.directives)
    first = _shortest(count, lambda n: fails(n, so=False))
    if first == count or fails(first, so=True):
        return first - 1
    return _shortest(count, lambda n: fails(n, so=True)) - 1


def _shortest(count: int, fails: Callable[[int], bool]) -> int:
    """The n in 1..count where fails(n) and not fails(n - 1), bisected: fails(count) and
    not fails(0) are given."""
    loads, refused = 0, count
    while refused - loads > 1:
        middle = (loads + refused) // 2
        if fails(middle):
            refused = middle
        else:
            loads = middle
    return refused


def scenario_plant(scenario: Scenario, fail: Fail) -> MultibodyPlant:
    """The scenario's models parsed into a finalized plant of its plant config: what
    Drake says about an option of the config or a directive, as the config's or the
    directive's problem.

    Parameters
    ----------
    scenario : Scenario
        Its `plant_config` (its numbers already checked: `check_plant_config`) and
        `directives` (their files, names and poses already checked: `check_directives`).
    fail : callable(key, problem)
        Raises the InputError that names where the key was set; a directive's key is
        "directives.K.KIND".

    Returns
    -------
    MultibodyPlant
        Finalized, with every model of the scenario.

    Raises
    ------
    InputError
        Through `fail`: an unknown option of the plant config, or a directive Drake
        refuses (a weld's frame, a collision filter's body or group that is not there...).
    """
    try:
        _parsed(scenario.plant_config, [])
    except RuntimeError as error:
        for key in PLANT_OPTIONS:  # which option Drake does not know
            alone = MultibodyPlantConfig()
            setattr(alone, key, getattr(scenario.plant_config, key))
            try:
                _parsed(alone, [])
            except RuntimeError:
                fail(f"plant_config.{key}", loading_problem(error))
        fail("plant_config", loading_problem(error))
    try:
        return _parsed(scenario.plant_config, scenario.directives)
    except RuntimeError:
        pass
    # Refused: what Drake's own processing of every directive says, and of which.
    try:
        return _parsed(scenario.plant_config, scenario.directives, by_drake=True)
    except RuntimeError as error:
        problem = loading_problem(error)
    k = _refused_directive(scenario, problem)
    directive = scenario.directives[k]
    kind = next((n for n in DIRECTIVE_KINDS if getattr(directive, n) is not None), "")
    fail(f"directives.{k}.{kind}".rstrip("."), problem)
