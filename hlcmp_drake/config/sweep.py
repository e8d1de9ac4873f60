"""Sweep files: one scenario, the overrides to vary, the repetitions and the metrics to
tabulate, planned into tasks that each carry their whole scenario as YAML text.

A sweep file (``diagrams/sweeps/*.yaml``)::

    scenario: one_dof              # a bundled scenario, or a .yaml path relative to this file
    set:                           # fixed overrides, in every task
      duration_s: 10.0
    grid:                          # override key -> values: every combination is a task
      dmp.n_basis: [2, 10, 30]
      controllers.hlcmp.pi: [1.0, 5.0]
    cases:                         # explicit override sets, for values that move together
    - label: x10
      set: {controllers.hlcmp.q_k: [20000.0], controllers.hlcmp.q_d: [5000.0]}
    repetitions: 1
    controllers: [hlcmp]           # run only these (default: all); claims need every kind
    labels: {dmp.n_basis: N}       # column headers; the key `case` names the cases' column
    metrics:                       # the table's columns, from each task's run folder
    - {label: "x(10 s) [m]", path: controllers.hlcmp.position_at_10s_m, digits: 4}
    - {label: "max K_s [N/m]", series: hlcmp/Ks, reduce: max, digits: 0}

Values are YAML, exactly what follows the ``=`` of ``hlcmp run --set KEY=VALUE``; a value
given as a string is taken as that YAML text, so a tagged value is quoted:
``"!ConstantImpedanceConfig {...}"``. A relative path (``reference.file``) is read beside
the sweep file, as its ``scenario`` is, not from the working directory as after ``--set``.
Cases and grid multiply (every case with every grid point); each combination runs
`repetitions` times.

Planning loads every task's scenario with its overrides, so a bad key or value stops the
sweep before anything runs, naming the sweep file's line. Each task ships its scenario as
the YAML text `hlcmp_drake.config.loading.dump_scenario` writes (plain text, never a pickled
Drake object), with the controllers' order beside it (the dump sorts map keys).
"""

import dataclasses as dc
import hashlib
import itertools
import math
import re
from pathlib import Path
from typing import Optional, Protocol

import yaml
from pydrake.common.yaml import yaml_load_typed

from hlcmp_drake.config.loading import (
    check_file_kind,
    check_unique_keys,
    dump_scenario,
    line_of,
    load_scenario,
    override_read_from,
    resolve_scenario_path,
    resolve_yaml,
)
from hlcmp_drake.config.scenario import Fail
from hlcmp_drake.config.shapes import misshapen_value
from hlcmp_drake.config.world import inputs_digest
from hlcmp_drake.io.errors import InputError, located
from hlcmp_drake.io.paths import DIAGRAMS_DIR

# No `from __future__ import annotations` here: Drake's typed YAML reads the dataclasses'
# field types, which must be types, not strings.

SWEEPS_DIR = DIAGRAMS_DIR / "sweeps"
REDUCTIONS = ("max", "min", "max_abs", "mean", "final")
CASE = "case"  # the parameter key (and default column header) of a sweep's cases
_KEY = re.compile(r"[A-Za-z0-9_.\-]+")


@dc.dataclass
class SweepMetric:
    """One column of a sweep's table: a value from a task's metrics.json (`path`) or a
    reduction over time of one of its timeseries.npz arrays (`series`).

    Attributes
    ----------
    label : str
        The column's header, with units (default: the path's or series' name); none of
        sweep.csv's own columns (id, the swept keys, repetition, status, wall_s).
    path : str
        A dotted path into metrics.json, e.g. "controllers.hlcmp.position_at_10s_m" or
        "claims.hlcmp.C4.holds" (a label with dots, "vic_fd_0.5", is matched whole); a
        list's element by its index from 0, e.g. "controllers.hlcmp_6d.max_abs_torque_Nm.1".
    series : str
        Or a timeseries.npz array, "CONTROLLER/NAME", e.g. "hlcmp/Ks".
    reduce : str
        How a series becomes one number: max, min, max_abs, mean or final (over time,
        NaN samples of a stopped run ignored).
    column : int
        The series' column (its axis, 0-based).
    window_s : list of float
        [start, end] in s to reduce over (default: the whole run).
    scale : float
        The value is stored and shown as value * scale (1000: metres in mm).
    digits : int
        Decimals in the table.
    below : float, optional
        When given (finite), the cell is yes/no: whether the (scaled) value is below it.
    missing : str
        What the table shows for a null value (an event that never happened).
    """

    label: str = ""
    path: str = ""
    series: str = ""
    reduce: str = "max"
    column: int = 0
    window_s: list[float] = dc.field(default_factory=list)
    scale: float = 1.0
    digits: int = 2
    below: Optional[float] = None
    missing: str = "n/a"


@dc.dataclass
class SweepCase:
    """An explicit set of overrides, applied together.

    Attributes
    ----------
    label : str
        The case's name in the table and its task ids (default: its 1-based number).
    set : dict of str to str
        Override key -> YAML value text.
    """

    label: str = ""
    set: dict[str, str] = dc.field(default_factory=dict)


@dc.dataclass
class SweepConfig:
    """What a sweep file holds (see the module's docstring for an example).

    Attributes
    ----------
    scenario : str
        A bundled scenario's name, or a .yaml path relative to the sweep file.
    set : dict of str to str
        Fixed overrides, every task.
    grid : dict of str to list of str
        Override key -> values; every combination is a task.
    cases : list of SweepCase
        Explicit override sets; multiplied with the grid.
    repetitions : int
        Runs of each combination.
    controllers : list of str
        Run only these of the scenario's controllers, in this order (default: all). The
        experiment's claims compare controllers of different kinds, so they are evaluated
        only when every kind of the scenario's controllers is among these.
    labels : dict of str to str
        Column headers by parameter key (`case` for the cases' column).
    metrics : list of SweepMetric
        The table's columns.
    """

    scenario: str = ""
    set: dict[str, str] = dc.field(default_factory=dict)
    grid: dict[str, list[str]] = dc.field(default_factory=dict)
    cases: list[SweepCase] = dc.field(default_factory=list)
    repetitions: int = 1
    controllers: list[str] = dc.field(default_factory=list)
    labels: dict[str, str] = dc.field(default_factory=dict)
    metrics: list[SweepMetric] = dc.field(default_factory=list)


@dc.dataclass
class Sweep:
    """A loaded and checked sweep file.

    Attributes
    ----------
    path : Path
        The sweep file.
    text : str
        Its text (for the lines errors name).
    config : SweepConfig
        Its content, values as YAML text, every case labelled, every metric labelled.
    scenario_path : Path
        The scenario file the tasks override.
    parameters : list of str
        The swept keys, in column order: "case" first when there are cases, then the
        grid's keys in file order.
    """

    path: Path
    text: str
    config: SweepConfig
    scenario_path: Path
    parameters: list


@dc.dataclass
class SweepTask:
    """One run of a sweep: plain strings, lists and dicts only, so that it travels to a
    worker process or a Ray node as it is.

    Attributes
    ----------
    id : str
        Stable and readable, from the swept values, e.g. "n_basis=2,pi=1.0"; the name of
        its run folder.
    parameters : dict of str to str
        Swept key -> YAML value text (the case's label under "case").
    repetition : int
        1-based.
    overrides : list of str
        Every ``key=value`` applied over the scenario file, in order (set, case, grid).
    scenario_yaml : str
        The whole scenario after the overrides (`dump_scenario`).
    scenario_path : str
        The scenario file it came from (for messages and a relative demonstration).
    controllers : list of str
        The controllers to run, in order (the YAML dump sorts them by label).
    claims : bool
        Evaluate the experiment's claims (False when the sweep drops every controller of
        some kind, which the claims compare with).
    run_dir : str
        The task's run folder, OUT/tasks/ID.
    inputs_digest : str
        `config.world.inputs_digest` of its scenario: the model files' and the
        demonstration's contents, which its text names only by path.
    """

    id: str
    parameters: dict
    repetition: int
    overrides: list
    scenario_yaml: str
    scenario_path: str
    controllers: list
    claims: bool
    run_dir: str
    inputs_digest: str


# Beside a task's scenario.yaml: the digest of the files it names (`SweepTask.inputs_digest`).
INPUTS_FILE = "inputs.sha256"


def resolve_sweep_path(name_or_path: str | Path) -> Path:
    """The file of a bundled sweep (diagrams/sweeps/NAME.yaml) or of a path.

    Parameters
    ----------
    name_or_path : str or Path
        See `hlcmp_drake.config.loading.resolve_yaml`.
    """
    return resolve_yaml(name_or_path, SWEEPS_DIR, "sweep")


def _yaml_text(value: object) -> str:
    """A value as the YAML text an override takes: strings as they are, anything else in
    flow style on one line."""
    if isinstance(value, str):
        return value
    return (
        yaml.safe_dump(value, default_flow_style=True, width=math.inf)
        .strip()
        .removesuffix("...")
        .strip()
    )


def _normalized(raw: dict, fail) -> dict:
    """The parsed document with every override value, case label and header as text, so
    that the typed schema (strings) accepts numbers and lists written plainly."""
    raw = dict(raw)

    def texts(mapping, where):
        if mapping is None:
            return {}
        if not isinstance(mapping, dict):
            fail(where, f"{where.split('.')[-1]}: expected a map of override key -> value")
        return {str(k): _yaml_text(v) for k, v in mapping.items()}

    if "set" in raw:
        raw["set"] = texts(raw["set"], "set")
    if "labels" in raw:
        raw["labels"] = texts(raw["labels"], "labels")
    if "grid" in raw:
        grid = raw["grid"] or {}
        if not isinstance(grid, dict):
            fail("grid", "grid: expected a map of override key -> list of values")
        for key, values in grid.items():
            if not isinstance(values, list) or not values:
                fail(f"grid.{key}", f"grid: '{key}' needs a non-empty list of values")
        raw["grid"] = {str(k): [_yaml_text(v) for v in values] for k, values in grid.items()}
    # An empty list would read as "none", where leaving the key out means its default.
    for key, instead in (
        ("cases", "leave cases out to sweep the grid alone"),
        ("controllers", "leave controllers out to run all of the scenario's"),
    ):
        if raw.get(key) == []:
            fail(key, f"{key}: the list is empty ({instead})")
    if "cases" in raw:
        cases = raw["cases"]
        if not isinstance(cases, list):
            fail("cases", "cases: expected a list of {label, set}")
        raw["cases"] = [
            dict(
                case,
                **({"label": _yaml_text(case["label"])} if "label" in case else {}),
                **({"set": texts(case["set"], "cases")} if "set" in case else {}),
            )
            if isinstance(case, dict)
            else case
            for case in cases
        ]
    if isinstance(raw.get("metrics"), list):
        raw["metrics"] = [
            dict(m, label=_yaml_text(m["label"])) if isinstance(m, dict) and "label" in m else m
            for m in raw["metrics"]
        ]
    return raw


def _schema_error(path: Path, text: str, error: Exception) -> InputError:
    """`file:line: problem` for what the typed loader raised."""
    message = " ".join(str(error).split())
    field = re.search(r"\['([^']+)'|for '([^']+)'", message)
    name = next((g for g in field.groups() if g), None) if field else None
    return located(path, line_of(text, name) if name and name != "_" else None, message)


def _key_line(text: str, key: str, outside: tuple[str, ...] = ()) -> int | None:
    """The first line that sets `key` (block or flow style), for override keys, skipping the
    top-level sections named in `outside` (a `labels:` entry names a key, it sets none)."""
    pattern = re.compile(rf"(^|[\s{{,]){re.escape(key)}\s*:")
    section = None
    for n, row in enumerate(text.splitlines(), 1):
        row = row.split("#")[0]
        top = re.match(r"([A-Za-z_]\w*)\s*:", row)
        if top:
            section = top.group(1)
        if section not in outside and pattern.search(row):
            return n
    return None


def load_sweep(name_or_path: str | Path) -> Sweep:
    """Read and check a sweep file (not yet its tasks' scenarios: see `plan_tasks`).

    Parameters
    ----------
    name_or_path : str or Path
        A bundled sweep's name or a sweep file.

    Returns
    -------
    Sweep

    Raises
    ------
    InputError
        ``file:line: problem`` for a YAML error, an unknown key, a wrong type, a
        parameter set twice, an unknown reduction and the like.
    """
    path = resolve_sweep_path(name_or_path)
    text, config, fail = read_typed_file(path, SweepConfig)
    _check(config, fail)
    scenario_path = _scenario_path(config.scenario, path, fail)
    parameters = ([CASE] if config.cases else []) + list(config.grid)
    return Sweep(path, text, config, scenario_path, parameters)


def read_typed_file(path: Path, schema: type) -> tuple:
    """Read a sweep's or a skill library's YAML file into its typed config, every
    override value as text (`_normalized`).

    Parameters
    ----------
    path : Path
        The file.
    schema : type
        Its config dataclass (SweepConfig, LibraryConfig).

    Returns
    -------
    (str, config, Fail)
        The file's text, the config, and `fail(key, problem)`, which raises an InputError
        naming the line that sets `key` (dotted, as in the file).

    Raises
    ------
    InputError
        ``file:line: problem`` for a file that cannot be read, a YAML error, an unknown
        key or a wrong type.
    """
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: cannot be read as text ({error.__class__.__name__})") from None

    def fail(key: str, problem: str):
        section, _, rest = key.partition(".")
        line = (
            line_of(text, key)
            or _key_line(text, key)
            or (rest and _key_line(text, rest))
            or line_of(text, section)
        )
        raise located(path, line, problem)

    check_file_kind(path, text, schema.__name__.removesuffix("Config").lower())
    check_unique_keys(path, text)
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None) or getattr(error, "context_mark", None)
        problem = " ".join(
            filter(None, [getattr(error, "context", None), getattr(error, "problem", None)])
        )
        raise located(path, mark.line + 1 if mark else None, problem or str(error)) from None
    if not isinstance(raw, dict):
        raise located(path, None, "expected a map with at least `scenario`")
    # The sections `_normalized` rewrites are checked as rewritten (their lines found by
    # key); every other value where the file gives it.
    misshapen = misshapen_value(text, schema, REWRITTEN)
    if misshapen:
        line, key, problem = misshapen
        raise located(path, line, f"{key}: {problem}")
    normalized = yaml.safe_dump(_normalized(raw, fail), sort_keys=False)
    misshapen = misshapen_value(normalized, schema)
    if misshapen:
        fail(misshapen[1], f"{misshapen[1]}: {misshapen[2]}")
    try:
        config = yaml_load_typed(schema=schema, data=normalized)
    except InputError:
        raise
    except Exception as error:  # Drake's typed loader raises RuntimeError and TypeError
        raise _schema_error(path, text, error) from None
    return text, config, fail


# The sections of a sweep or library file whose values `_normalized` turns into YAML text.
REWRITTEN = ("set", "labels", "grid", "cases")


# A YAML 1.2 float, as Drake's loader reads an override's value: PyYAML (YAML 1.1) reads
# one with an exponent but no dot or no exponent sign (1e-2, 1.0e7) as text.
_YAML_12_NUMBER = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")


def number_of(value: object) -> float | None:
    """The number a parsed YAML value stands for as Drake reads it, or None (a bool, a
    list, text that is no number).

    Parameters
    ----------
    value : object
        What `yaml.safe_load` returned for a value's text.

    Returns
    -------
    float or None
        Possibly infinite or NaN (.inf, .nan).
    """
    if isinstance(value, str) and _YAML_12_NUMBER.fullmatch(value):
        return float(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value)


def yaml_number(text: str) -> float | None:
    """The number an override value's YAML text holds (`number_of`), or None.

    Parameters
    ----------
    text : str

    Returns
    -------
    float or None
    """
    try:
        return number_of(yaml.safe_load(text))
    except yaml.YAMLError:
        return None


def _as_compared(text: str) -> tuple:
    """A grid value as two values are compared: a number by its value (1, 1.0 and 1e0 are
    one value, 0 and false are not), anything else (a tagged config, a list) by its text."""
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:  # e.g. a tag: the safe loader constructs none
        return ("text", text)
    if isinstance(value, bool):
        return ("bool", value)
    number = number_of(value)
    return ("text", text) if number is None else ("number", number)


def _scenario_path(scenario: str, sweep_path: Path, fail: Fail) -> Path:
    if not scenario:
        fail("scenario", "scenario: must be given (a bundled scenario's name or a .yaml path)")
    candidate = Path(scenario)
    if candidate.suffix in (".yaml", ".yml") and not candidate.is_absolute():
        candidate = sweep_path.parent / candidate
    try:
        return resolve_scenario_path(
            candidate if candidate.suffix in (".yaml", ".yml") else scenario
        )
    except InputError as error:
        fail("scenario", f"scenario: {error}")


def _check(config: SweepConfig, fail) -> None:
    """The rules the schema cannot say; labels and case labels filled in."""
    if not 1 <= config.repetitions <= 1000:
        fail("repetitions", f"repetitions: must be between 1 and 1000, got {config.repetitions}")
    owner = {}
    for key in config.set:
        owner[key] = "set"
    for key, values in config.grid.items():
        if key in owner:
            fail(f"grid.{key}", f"grid: '{key}' is also in {owner[key]}")
        owner[key] = "grid"
        read = [_as_compared(value) for value in values]
        if len(set(read)) != len(read):
            fail(f"grid.{key}", f"grid: '{key}' lists a value twice: {values}")
    case_keys = set()
    unlabelled = set()
    for k, case in enumerate(config.cases, 1):
        if not case.label:
            unlabelled.add(k)
            case.label = str(k)
        for key in case.set:
            if key in owner:
                fail(key, f"cases: '{key}' is also in {owner[key]}")
            case_keys.add(key)
    labels = [case.label for case in config.cases]
    for label in labels:
        sharing = [k for k, other in enumerate(labels, 1) if other == label]
        if len(sharing) > 1:
            named = [
                f"case {k}" + (" (no label given: labelled by its number)" * (k in unlabelled))
                for k in sharing
            ]
            fail("cases", f"cases: {' and '.join(named)} share the label '{label}'")
    for key in [*config.set, *config.grid, *case_keys]:
        if not _KEY.fullmatch(key):
            fail(key, f"'{key}': an override key is dotted, e.g. controllers.hlcmp.pi")
    for key in config.labels:
        if key not in config.grid and not (key == CASE and config.cases):
            fail(
                f"labels.{key}",
                f"labels: '{key}' is not a swept parameter "
                f"({', '.join(([CASE] if config.cases else []) + list(config.grid)) or 'none'})",
            )
    if len(set(config.controllers)) != len(config.controllers):
        fail("controllers", f"controllers: a label is listed twice: {config.controllers}")
    for k, metric in enumerate(config.metrics):
        where = f"metrics: entry {k + 1}"
        if bool(metric.path) == bool(metric.series):
            fail(
                "metrics",
                f"{where}: give either `path` (into metrics.json) or `series` (timeseries.npz)",
            )
        if metric.series and metric.reduce not in REDUCTIONS:
            fail(
                "reduce",
                f"{where}: reduce must be one of {', '.join(REDUCTIONS)}, got '{metric.reduce}'",
            )
        if metric.series and "/" not in metric.series:
            fail(
                "series",
                f"{where}: series is CONTROLLER/NAME, e.g. hlcmp/Ks, got '{metric.series}'",
            )
        if metric.window_s and (
            len(metric.window_s) != 2 or not metric.window_s[0] < metric.window_s[1]
        ):
            fail(
                "window_s",
                f"{where}: window_s is [start, end] with start < end, got {metric.window_s}",
            )
        if metric.below is not None and not math.isfinite(metric.below):
            fail("below", f"{where}: below must be a finite number, got {metric.below}")
        if metric.column < 0 or not 0 <= metric.digits <= 12 or not math.isfinite(metric.scale):
            fail(
                "metrics",
                f"{where}: column >= 0, 0 <= digits <= 12 and a finite scale are required",
            )
        metric.label = (
            metric.label or metric.path or f"{metric.reduce} {metric.series}[{metric.column}]"
        )
    names = [m.label for m in config.metrics]
    if len(set(names)) != len(names):
        fail("metrics", f"metrics: two columns share a label: {names}")
    own = ["id", *([CASE] if config.cases else []), *config.grid, "repetition", "status", "wall_s"]
    for k, name in enumerate(names):
        if name in own:
            fail(
                "metrics",
                f"metrics: entry {k + 1}: label '{name}' is one of sweep.csv's own columns "
                f"({', '.join(own)}): give it another",
            )


def metric_line(sweep: Sweep, index: int) -> int | None:
    """The line of the sweep file that gives metric `index`'s path or series.

    Parameters
    ----------
    sweep : Sweep
    index : int
        0-based, in `sweep.config.metrics`.

    Returns
    -------
    int or None
        1-based; the `metrics` line when the entry's own line is not found.
    """
    metrics = sweep.config.metrics
    metric = metrics[index]
    field, value = ("path", metric.path) if metric.path else ("series", metric.series)
    earlier = sum(1 for m in metrics[:index] if getattr(m, field) == value)  # the same twice
    pattern = re.compile(rf"\b{field}\s*:\s*['\"]?{re.escape(value)}['\"]?\s*(,|}}|#|$)")
    rows = [n for n, row in enumerate(sweep.text.splitlines(), 1) if pattern.search(row)]
    return rows[earlier] if earlier < len(rows) else line_of(sweep.text, "metrics")


def short_names(keys: list) -> dict:
    """A short name per parameter key: its last dotted part, or the whole key where two
    keys share their last part.

    Parameters
    ----------
    keys : list of str
        Dotted override keys (and "case").

    Returns
    -------
    dict of str to str
    """
    leaves = [key.split(".")[-1] for key in keys]
    return {key: leaf if leaves.count(leaf) == 1 else key for key, leaf in zip(keys, leaves)}


def _id_value(text: str) -> str:
    """A value's text made safe for a folder name: brackets, quotes and spaces dropped,
    inner commas as '_', anything else unusual as '-'."""
    text = re.sub(r"[\[\]{}()'\"\s]", "", text).replace(",", "_")
    return re.sub(r"[^A-Za-z0-9._+\-]", "-", text) or "-"


def task_id(parameters: dict, repetition: int = 1, repetitions: int = 1) -> str:
    """The stable, readable id of a task: ``short=value`` per swept parameter, joined by
    commas, and ``rep=K`` when a sweep repeats. It depends only on the swept keys and
    values, so adding a value to a grid leaves every other task's id (and its finished run)
    as it was. Ids over 100 characters are cut and end in a hash of the whole.

    Parameters
    ----------
    parameters : dict of str to str
        Swept key -> YAML value text (the case's label under "case"), in column order.
    repetition : int
        1-based.
    repetitions : int
        The sweep's repetitions (``rep=K`` only when more than 1).

    Returns
    -------
    str
        e.g. "n_basis=2,pi=1.0,gain_l=1.0", or "run" when nothing is swept.
    """
    names = short_names(list(parameters))
    parts = [f"{names[key]}={_id_value(value)}" for key, value in parameters.items()]
    if repetitions > 1:
        parts.append(f"rep={repetition}")
    full = ",".join(parts) or "run"
    if len(full) > 100:
        full = f"{full[:80]}-{hashlib.sha1(full.encode()).hexdigest()[:10]}"
    return full


def plan_tasks(sweep: Sweep, out_dir: str | Path) -> list[SweepTask]:
    """Every task of a sweep, each scenario loaded with its overrides (so every bad value
    is found before anything runs) and dumped as YAML text.

    Parameters
    ----------
    sweep : Sweep
        From `load_sweep`.
    out_dir : str or Path
        The sweep's output folder; task ID runs in OUT/tasks/ID.

    Returns
    -------
    list of SweepTask
        In table order: cases, then the grid (first key slowest), then repetitions.

    Raises
    ------
    InputError
        Naming the sweep file's line for an unknown controller, a bad override (with the
        problem the scenario loader found) or two tasks whose ids collide.
    """
    config = sweep.config
    cases: list[SweepCase | None] = list(config.cases) or [None]
    tasks: list = []
    seen: dict = {}
    for case, point in itertools.product(cases, itertools.product(*config.grid.values())):
        parameters = ({CASE: case.label} if case else {}) | dict(zip(config.grid, point))
        overrides = task_overrides(
            sweep,
            [*config.set.items(), *(case.set.items() if case else ()), *zip(config.grid, point)],
        )
        scenario = _load_task_scenario(sweep, overrides, parameters, len(config.set))
        unknown = [label for label in config.controllers if label not in scenario.controllers]
        if unknown:
            raise located(
                sweep.path,
                line_of(sweep.text, "controllers"),
                f"controllers: {', '.join(unknown)} not in the scenario "
                f"({', '.join(scenario.controllers)})",
            )
        keep = config.controllers or list(scenario.controllers)
        # The claims compare controllers of different kinds (the Hl-CMP with the baselines):
        # they are judged only when every kind of the scenario is still there.
        kinds = {type(c) for c in scenario.controllers.values()}
        claims = {type(scenario.controllers[label]) for label in keep} == kinds
        scenario = dc.replace(
            scenario, controllers={label: scenario.controllers[label] for label in keep}
        )
        text = dump_scenario(scenario)
        digest = inputs_digest(scenario)
        for repetition in range(1, config.repetitions + 1):
            identifier = task_id(parameters, repetition, config.repetitions)
            if identifier in seen:
                raise located(
                    sweep.path,
                    None,
                    f"two tasks would share the id '{identifier}': "
                    f"{seen[identifier]} and {parameters}; make the values differ "
                    "in more than brackets, quotes and spaces",
                )
            seen[identifier] = parameters
            tasks.append(
                SweepTask(
                    identifier,
                    dict(parameters),
                    repetition,
                    overrides,
                    text,
                    str(sweep.scenario_path),
                    list(keep),
                    claims,
                    str(Path(out_dir) / "tasks" / identifier),
                    digest,
                )
            )
    return tasks


class _ScenarioFile(Protocol):
    """What loading a task's scenario needs of a sweep (or a skill library): its file, its
    text (for the lines errors name) and the scenario file it overrides."""

    path: Path
    text: str
    scenario_path: Path


def task_overrides(sweep: _ScenarioFile, values: list) -> list[str]:
    """A task's overrides, KEY=VALUE for each (key, value text) of a sweep's (or a skill
    library's) file: a relative path (`reference.file`) is read beside that file, as its
    `scenario` is, wherever the command runs.

    Parameters
    ----------
    sweep : the sweep or library spec
        Its `path` is the file.
    values : list of (str, str)
        The override keys and their YAML value texts, in the order they apply.

    Returns
    -------
    list of str
    """
    why = f"a relative path in {sweep.path.name} is read beside it"
    return [override_read_from(f"{k}={v}", sweep.path.parent, why) for k, v in values]


def _load_task_scenario(sweep: _ScenarioFile, overrides: list, parameters: dict, fixed: int = 0):
    """A task's scenario with its overrides, the first `fixed` of them the file's `set`
    (every task's); InputError naming the file's line and the task (every task when the
    fixed overrides alone bring the same problem)."""
    try:
        scenario, _ = load_scenario(sweep.scenario_path, overrides)
    except InputError as error:
        message = str(error)
        key = re.match(r"override '([^=']+)=", message)
        line = _key_line(sweep.text, key.group(1), outside=("labels",)) if key else None
        values = ", ".join(f"{k}={v}" for k, v in parameters.items())
        every = not values or (fixed > 0 and _problem_of(sweep, overrides[:fixed]) == message)
        where = "every task" if every else f"the task where {values}"
        raise located(sweep.path, line, f"{message} (in {where})") from None
    return scenario


def _problem_of(sweep: _ScenarioFile, overrides: list) -> str | None:
    """What loading the scenario with `overrides` alone refuses, or None."""
    try:
        load_scenario(sweep.scenario_path, overrides)
    except InputError as error:
        return str(error)
    return None
