"""Loading a scenario: a bundled name or a YAML file, layered with overrides, validated.

Overrides are layered the way Drake's own `LoadScenario` does it: the file is read with
`yaml_load_typed`, then each override is read with the result so far as `defaults`, so
an override changes only what it names. An override is ``dotted.key=YAML value``, e.g.
``controllers.hlcmp.q_k=[300,300,300]`` or ``duration_s=4``; a dict of YAML-able values
works too. Every problem is one InputError naming the file and line, or the override.
"""

from __future__ import annotations

import copy
import dataclasses as dc
import difflib
import functools
import json
import re
import typing
from pathlib import Path
from typing import Any, Mapping, NoReturn, Sequence, Union

import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from hlcmp_drake.config.scenario import ControllerConfig, DemonstrationConfig, Scenario
from hlcmp_drake.config.shapes import composed, misshapen_value
from hlcmp_drake.config.validation import ExperimentNeeds, ReplayProblem, validate_scenario
from hlcmp_drake.io.errors import InputError, located
from hlcmp_drake.io.file_kinds import FILE_KINDS, top_level_keys
from hlcmp_drake.io.paths import DIAGRAMS_DIR, VARIANTS_DIR, data_file


def resolve_yaml(name_or_path: str | Path, folder: Path, kind: str) -> Path:
    """The YAML file a user names: a path ending in .yaml/.yml as it is, else a bundled
    file `folder`/NAME.yaml.

    Parameters
    ----------
    name_or_path : str or Path
    folder : Path
        Where the bundled files of this kind live.
    kind : str
        What they are ("scenario", "sweep"), for the message.

    Returns
    -------
    Path
        The file, which exists.

    Raises
    ------
    InputError
        When the path is not a file, or the name is no bundled file (the message lists them).
    """
    path = Path(name_or_path)
    if path.suffix in (".yaml", ".yml"):
        if not path.is_file():
            raise InputError(f"{path}: no such {kind} file")
        return path
    bundled = folder / f"{name_or_path}.yaml"
    if bundled.is_file():
        return bundled
    names = ", ".join(sorted(p.stem for p in folder.glob("*.yaml")))
    raise InputError(f"{name_or_path}: not a bundled {kind} ({names}) nor a .yaml file")


def resolve_variant_path(name_or_path: str | Path) -> Path:
    """The YAML file of a bundled variant name (diagrams/variants/NAME.yaml) or of a path.

    Parameters
    ----------
    name_or_path : str or Path
        See `resolve_yaml`.
    """
    return resolve_yaml(name_or_path, VARIANTS_DIR, "variant")


def resolve_scenario_path(name_or_path: str | Path) -> Path:
    """The YAML file of a bundled scenario name (diagrams/NAME.yaml) or of a path.

    Parameters
    ----------
    name_or_path : str or Path
        See `resolve_yaml`.
    """
    return resolve_yaml(name_or_path, DIAGRAMS_DIR, "scenario")


def check_unique_keys(path: str | Path, text: str) -> None:
    """Refuse a YAML text that gives one key twice in a map: the parsers keep the last one
    without a word (a controller's label given twice would drop the first controller).

    Parameters
    ----------
    path : str or Path
        The file, for the message.
    text : str
        Its YAML; a text that does not parse is left to the loader's own message.

    Raises
    ------
    InputError
        ``PATH:LINE: 'KEY' is given twice in the same map (first at line N)``.
    """
    import yaml

    root = composed(text)
    nodes = [] if root is None else [root]
    twice = []  # (line, key, its first line)
    visited = set()  # an alias is the node it names: each is walked once
    while nodes:
        node = nodes.pop()
        if id(node) in visited:
            continue
        visited.add(id(node))
        if isinstance(node, yaml.MappingNode):
            seen: dict[str, int] = {}
            for key, value in node.value:
                if isinstance(key, yaml.ScalarNode) and key.value != "<<":
                    line = key.start_mark.line + 1
                    if key.value in seen:
                        twice.append((line, key.value, seen[key.value]))
                    seen.setdefault(key.value, line)
                nodes.append(value)
        elif isinstance(node, yaml.SequenceNode):
            nodes.extend(node.value)
    if twice:
        line, key, first = min(twice)
        raise located(path, line, f"'{key}' is given twice in the same map (first at line {first})")


def line_of(text: str, dotted_key: str) -> int | None:
    """The 1-based line where the YAML `text` sets `dotted_key`.

    Each part of the key is looked for after the line of the part before it; a label with
    dots in it ("vic_fd_0.5") is matched whole; a number after a key is the index of an
    item of the block list under it ("directives.3.add_weld": the fourth directive's
    add_weld).

    Parameters
    ----------
    text : str
        The YAML file's text.
    dotted_key : str
        A dotted path such as "controllers.hlcmp.q_k" or "directives.3.add_weld".

    Returns
    -------
    int or None
        The line number, or None if some part is not found.
    """
    lines = text.splitlines()
    parts = dotted_key.split(".")
    start, found, i = 0, None, 0
    while i < len(parts):
        if parts[i].isdigit() and found is not None:  # an item of the list under the key
            found = _list_item(lines, found + 1, int(parts[i]))
            if found is None:
                return None
            start, i = found, i + 1  # the item's line may hold its first key ("- add_weld:")
            continue
        for j in range(len(parts), i, -1):  # the longest run of parts that names a key
            pattern = re.compile(rf"\s*(-\s+)?{re.escape('.'.join(parts[i:j]))}\s*:")
            found = next((n for n in range(start, len(lines)) if pattern.match(lines[n])), None)
            if found is not None:
                start, i = found + 1, j
                break
        else:
            return None
    return None if found is None else found + 1


def _list_item(lines: list[str], start: int, index: int) -> int | None:
    """The 0-based line of item `index` of the block list that begins at or after `start`
    ("- ..." lines of one indentation; the list ends at a line indented no deeper that is
    not one of its items)."""
    indent, count = None, -1
    for n in range(start, len(lines)):
        row = lines[n]
        stripped = row.lstrip()
        if not stripped or stripped.startswith("#"):
            continue
        depth = len(row) - len(stripped)
        is_item = stripped == "-" or stripped.startswith("- ")
        if indent is None:
            if not is_item:
                return None
            indent = depth
        if depth < indent or (depth == indent and not is_item):
            return None
        if depth == indent:
            count += 1
            if count == index:
                return n
    return None


def _leaf(dotted_key: str) -> str:
    """The last part of a dotted key that is a name (not a list index)."""
    return next((p for p in reversed(dotted_key.split(".")) if not p.isdigit()), dotted_key)


class _Source:
    """Where the scenario's values came from: the file's text, a variant's and the
    overrides."""

    def __init__(
        self,
        path: Path,
        text: str,
        overrides: list[tuple[str, str]],
        variant: tuple[Path, str] | None = None,
        notes: Mapping[str, str] | None = None,
    ):
        self.path, self.text, self.overrides, self.variant = path, text, overrides, variant
        self.notes = dict(notes or {})  # by override label: why its path was read where it was

    def blamed(self, label: str, problem: str) -> InputError:
        """`override 'k=v': problem` (or the option an `OptionOverride` stands for), with
        the override's note when it has one."""
        note = self.notes.get(label)
        return InputError(f"{_named(label)}: {problem}" + (f"; {note}" if note else ""))

    def overrides_of(self, dotted_key: str) -> list[tuple[str, str]]:
        """The overrides (label, key) that set `dotted_key`, a field in it or a section
        holding it, in the order given."""
        return [
            (label, key)
            for label, key in self.overrides
            if key == dotted_key
            or key.startswith(dotted_key + ".")
            or dotted_key.startswith(key + ".")
        ]

    def where(self, dotted_key: str) -> str:
        """`file:line` of the variant's file when it sets the key, else of the scenario's
        (the file alone when the line cannot be found)."""
        if self.variant is not None:
            variant_path, variant_text = self.variant
            line = line_of(variant_text, dotted_key)
            if line:
                return f"{variant_path}:{line}"
        line = line_of(self.text, dotted_key) or line_of(self.text, _leaf(dotted_key))
        return f"{self.path}:{line}" if line else f"{self.path}"

    def error(self, dotted_key: str, problem: str) -> InputError:
        """`override 'k=v': key: problem` when an override set the key, else
        `file:line: key: problem` (`where`)."""
        leaf = _leaf(dotted_key)
        matching = self.overrides_of(dotted_key)
        # A problem of a whole section names its fields: blame an override of one of those
        # (the last), not whichever override of the section came last.
        named = [
            (label, key)
            for label, key in matching
            if re.search(rf"\b{re.escape(_leaf(key))}\b", problem)
        ]
        if matching:
            label = (named or matching)[-1][0]
            return self.blamed(label, f"{leaf}: {problem}")
        return InputError(f"{self.where(dotted_key)}: {leaf}: {problem}")

    def fail(self, dotted_key: str, problem: str) -> NoReturn:
        raise self.error(dotted_key, problem)


class _Problem(Exception):
    """The first problem a validation found: args (dotted key, problem)."""


def _first_problem(
    scenario: Scenario,
    folder: Path,
    experiments: Mapping[str, ExperimentNeeds] | None,
    replay_problem: ReplayProblem | None = None,
) -> tuple[str, str] | None:
    """(dotted key, problem) of the first problem `validate_scenario` finds, or None."""

    def record(dotted_key: str, problem: str) -> NoReturn:
        raise _Problem(dotted_key, problem)

    try:
        validate_scenario(scenario, folder, record, experiments, replay_problem)
    except _Problem as found:
        return found.args
    return None


def _yaml_error(path, text, error) -> InputError:
    """One line `file:line: problem` for whatever the YAML parser or the schema raised."""
    mark = getattr(error, "problem_mark", None) or getattr(error, "context_mark", None)
    if mark is not None:  # a YAML syntax error: PyYAML knows the line
        problem = " ".join(
            filter(None, [getattr(error, "context", None), getattr(error, "problem", None)])
        )
        return InputError(f"{path}:{mark.line + 1}: {problem}")
    message = " ".join(str(error).split())
    line = None
    field = re.search(r"\['([^']+)'|for '([^']+)'|options for '([^']+)'", message)
    value = re.search(r": '([^']*)'$", message)
    if field:
        line = line_of(text, next(g for g in field.groups() if g))
    elif value:  # a value of the wrong type: find the line that holds it
        line = next(
            (
                n
                for n, row in enumerate(text.splitlines(), 1)
                if re.search(rf":\s*{re.escape(value.group(1))}\s*(#.*)?$", row)
            ),
            None,
        )
    return InputError(f"{path}:{line}: {message}" if line else f"{path}: {message}")


def _union_members(owner_type, field_name) -> tuple:
    """The dataclasses a field may hold through a tagged union (its own type, or a dict's
    value type); empty when the field is not a union."""
    hint = typing.get_type_hints(owner_type).get(field_name)
    if typing.get_origin(hint) is dict:
        hint = typing.get_args(hint)[1]
    return typing.get_args(hint) if typing.get_origin(hint) is Union else ()


def _split_key(node, parts, i):
    """(key, next index) of the field or map entry that parts[i:] starts with: for a map,
    the longest run of parts that is one of its keys (labels may hold dots), else the
    whole rest (a new entry)."""
    if isinstance(node, dict):
        for j in range(len(parts), i, -1):
            if ".".join(parts[i:j]) in node:
                return ".".join(parts[i:j]), j
        return ".".join(parts[i:]), len(parts)
    return parts[i], i + 1


def override_yaml(scenario: Scenario, dotted_key: str, value_yaml: str) -> str:
    """The YAML text that sets `dotted_key` to `value_yaml` over `scenario`.

    One nested mapping per part, with the type tag of every tagged-union value on the way
    (so that an override of `controllers.const_500.pi` stays a !ConstantImpedanceConfig).

    Parameters
    ----------
    scenario : Scenario
        The scenario so far, which the override is read over (as `defaults`).
    dotted_key : str
        The field to set, e.g. "controllers.hlcmp.q_k"; a map key may hold dots.
    value_yaml : str
        The new value as YAML text, e.g. "[300,300,300]".

    Returns
    -------
    str
        The YAML document, ending in a newline.

    Raises
    ------
    KeyError
        With the part that names no field of a dataclass, and the fields there are.
    InputError
        When the key goes into a controller the scenario does not have (a whole new
        controller, ``controllers.NAME=!Kind {...}``, is fine).
    """
    parts = dotted_key.split(".")
    lines: list[str] = []
    node: Any = scenario
    i, depth = 0, 0
    while i < len(parts):
        owner = node
        key, i = _split_key(owner, parts, i)
        if isinstance(owner, dict):
            if owner is scenario.controllers and key not in owner:
                _check_new_controller(scenario, key, value_yaml)
            node = owner.get(key)
            members = (
                _union_members(type(scenario), "controllers")
                if owner is scenario.controllers
                else ()
            )
        elif owner is not None and hasattr(owner, "__dataclass_fields__"):
            if key not in owner.__dataclass_fields__:
                raise KeyError(key, list(owner.__dataclass_fields__))
            node = getattr(owner, key)
            members = _union_members(type(owner), key)
        elif owner is not None and hasattr(type(owner), "__fields__"):  # Drake's config structs
            names = [field.name for field in type(owner).__fields__]
            if key not in names:
                raise KeyError(key, names)
            node, members = getattr(owner, key), ()
        else:
            raise KeyError(key, [])
        last = i == len(parts)
        if last and re.fullmatch(r"\{\s*\}", value_yaml) and _merged_into(node, members):
            raise InputError(
                f"{key}: an empty map changes nothing: a map is merged into the scenario's "
                "values, as Drake's LoadYamlFile merges (set the fields, or give a whole "
                "!Tag config)"
            )
        # A union's value keeps its kind: its tag leads Drake into it (a map given for it is
        # then merged field by field, as for any section); untagged, Drake would read the
        # map as a new value of the union's first kind.
        into = not last or re.match(r"\s*\{", value_yaml)
        tag = f" !{type(node).__name__}" if members and type(node) in members and into else ""
        lines.append("  " * depth + f"{_yaml_key(key)}:{tag}" + (f" {value_yaml}" if last else ""))
        depth += 1
    return "\n".join(lines) + "\n"


def _merged_into(node: Any, members: tuple) -> bool:
    """Whether an untagged map given for `node` is merged into it field by field (a map of
    controllers, a section), rather than read as a new value (a union's default member)."""
    return isinstance(node, dict) or (dc.is_dataclass(node) and type(node) not in members)


def _check_new_controller(scenario: Scenario, key: str, value_yaml: str) -> None:
    """A key into `controllers` that is no label of it adds a controller, which takes a
    whole tagged config (``controllers.NAME=!HlcmpConfig {...}``); anything else names a
    controller that is not there (an InputError that says which there are)."""
    if value_yaml.lstrip().startswith("!"):
        return
    fields = {
        f.name for member in _union_members(Scenario, "controllers") for f in dc.fields(member)
    }
    name, _, field = key.rpartition(".")
    name = name if name and field in fields else key
    raise InputError(
        f"no controller '{name}' (the scenario has: {', '.join(scenario.controllers) or 'none'}); "
        "a new one takes a whole config, e.g. controllers.NAME=!HlcmpConfig {q_k: [...], ...}"
    )


def _yaml_key(key: str) -> str:
    """A map key as YAML reads it back as the same string (quoted when it looks like a number)."""
    return f"'{key}'" if re.fullmatch(r"[0-9.eE+-]+", key) else key


def _parse_override(override) -> list[tuple[str, str, str]]:
    """[(label, dotted key, YAML value)] from 'a.b=value' or a dict {dotted key: value}."""
    if isinstance(override, dict):
        import yaml

        return [
            (
                f"{k}={v}",
                k,
                yaml.safe_dump(v, default_flow_style=True).strip().removesuffix("...").strip(),
            )
            for k, v in override.items()
        ]
    key, sep, value = str(override).partition("=")
    if not sep or not key.strip() or not re.fullmatch(r"[A-Za-z0-9_.\-]+", key.strip()):
        raise InputError(
            f"override '{override}': expected KEY=VALUE with a dotted KEY, "
            "e.g. controllers.hlcmp.q_k=[300,300,300]"
        )
    label = getattr(override, "typed", str(override))
    if isinstance(override, OptionOverride):
        label = _OptionLabel(label)
    return [(label, key.strip(), value.strip())]


# Scenario fields that name a file: a relative path in a scenario's file is read beside that
# file; typed with --set, it is read from the working directory.
PATH_FIELDS = ("reference.file",)


def command_line_override(override: str) -> str:
    """KEY=VALUE as typed after `--set`: a relative path given to a field of PATH_FIELDS
    made absolute from the working directory, as a shell's user means it (not read beside
    the scenario's file, where it would be in a scenario's own text); anything else as
    typed.

    Parameters
    ----------
    override : str
        KEY=VALUE, the value in YAML.

    Returns
    -------
    str
    """
    return override_read_from(
        override, Path.cwd(), "a relative path given with --set is read from the working directory"
    )


def override_read_from(override: str, folder: Path, why: str) -> str:
    """KEY=VALUE with a relative path given to a field of PATH_FIELDS made absolute from
    `folder`, as a `TypedOverride` that keeps the text as given and `why` (for a message
    that says where the file was looked for); anything else as given.

    Parameters
    ----------
    override : str
        KEY=VALUE, the value in YAML.
    folder : Path
        Where a relative path is read from.
    why : str
        Why there, for messages, e.g. "a relative path in sweep.yaml is read beside it".

    Returns
    -------
    str
    """
    import yaml

    key, sep, value = override.partition("=")
    if not sep or key.strip() not in PATH_FIELDS:
        return override
    try:
        path = yaml.safe_load(value)
    except yaml.YAMLError:
        return override  # load_scenario says what is wrong with it
    if not isinstance(path, str) or not path or "://" in path or Path(path).is_absolute():
        return override
    absolute = (Path(folder) / path).resolve()
    return TypedOverride(f"{key.strip()}={json.dumps(str(absolute))}", override, why)


class TypedOverride(str):
    """An override that `override_read_from` rewrote, which keeps the text as it was
    typed (`typed`) and why a relative path in it was read where it was (`why`), for
    messages."""

    typed: str
    why: str

    def __new__(cls, text: str, typed: str, why: str = "") -> TypedOverride:
        override = super().__new__(cls, text)
        override.typed = typed
        override.why = why
        return override

    def __reduce__(self):  # pickled into a sweep's or a report's workers as it is
        return (type(self), (str(self), self.typed, self.why))


class OptionOverride(TypedOverride):
    """An override that a command's own option stands for, e.g. `hlcmp serve --duration
    1e9` for ``duration_s=1000000000.0``: a message names the option as it was typed
    (`typed`, "--duration 1e9"), not an override the user never typed."""


class _OptionLabel(str):
    """The label of an `OptionOverride`: the option as typed."""


def _named(label: str) -> str:
    """How a message names an override by its label: `override 'KEY=VALUE'` as typed
    after --set, or the option an `OptionOverride` stands for as typed."""
    return str(label) if isinstance(label, _OptionLabel) else f"override '{label}'"


def load_scenario(
    name_or_path: str | Path,
    overrides: Sequence[str | dict] = (),
    experiments: Mapping[str, ExperimentNeeds] | None = None,
    variant: str | Path | None = None,
    replay_problem: ReplayProblem | None = None,
) -> tuple[Scenario, Path]:
    """Load, override and validate a scenario.

    Parameters
    ----------
    name_or_path : str or Path
        A bundled scenario's name (e.g. "insertion") or a path to a YAML file.
    overrides : sequence of str or dict
        Each ``dotted.key=YAML value`` (or a dict of them), layered in order over the
        file, e.g. ``["duration_s=4", "controllers.hlcmp.q_k=[300,300,300]"]``.
    experiments : mapping of str to ExperimentNeeds, optional
        The experiments the scenario may name, each to the task class its world needs and
        the frames its metrics read (what a run evaluates with: `hlcmp_drake.experiments`);
        given, `experiment` is checked against them.
    variant : str or Path, optional
        A bundled variant's name (e.g. "real_arm": diagrams/variants/real_arm.yaml) or a
        YAML file, layered over the scenario's file before the overrides; the scenario's
        name gets "_" and the variant's name appended (its runs go to their own folder),
        unless it already ends so (a run's record of that variant).
    replay_problem : callable(duration_s) -> str or None, optional
        For runs that follow another reference than the scenario's demonstration file
        (learn's own demonstration, a skill's DMP): what replaying that one in
        `reference.duration_s` does wrong, checked instead of the file's replay.

    Returns
    -------
    (Scenario, Path)
        The scenario (its demonstration file resolved to an absolute path) and the file.

    Raises
    ------
    InputError
        One line naming the file and line, or the override, and what is wrong.
    """
    path = resolve_scenario_path(name_or_path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: cannot be read as text ({error.__class__.__name__})") from None
    layer = None
    if variant is not None:
        variant_path = resolve_variant_path(variant)
        try:
            layer = (variant_path, variant_path.read_text())
        except (OSError, UnicodeDecodeError) as error:
            raise InputError(
                f"{variant_path}: cannot be read as text ({error.__class__.__name__})"
            ) from None
    return _load_text(text, path, overrides, experiments, layer, replay_problem), path


class _NoController:
    """No controller config is one: first in the dump's Union, it makes every controller
    be written with its class's tag."""


def _dump_schema() -> type:
    """Scenario's schema for dumping: its controllers' Union with each class before its
    bases (a longer MRO first), after a member that matches none."""
    by_depth = sorted(typing.get_args(ControllerConfig), key=lambda c: -len(c.__mro__))
    tagged = Union.__getitem__((_NoController, *by_depth))
    fields = [
        (field.name, dict[str, tagged] if field.name == "controllers" else field.type)  # type: ignore[valid-type]
        for field in dc.fields(Scenario)
    ]
    return dc.make_dataclass("Scenario", fields)


_DUMP_SCHEMA = _dump_schema()


def dump_scenario(scenario: Scenario, *, controllers_in_order: bool = False) -> str:
    """The scenario as the YAML text `load_scenario_text` reads back as it is.

    `yaml_dump_typed` alone writes a Union's value as the first of the Union's types it
    is an instance of, untagged when that is the first: a PoseHlcmpConfig or an
    HlcmpForgettingConfig (subclasses of HlcmpConfig) would come back as an HlcmpConfig,
    their own fields dropped. A scenario with such a controller is written with every
    controller tagged with its own class; any other exactly as `yaml_dump_typed` writes
    it, so the tasks of a sweep or a library finished before stay finished.

    Parameters
    ----------
    scenario : Scenario
    controllers_in_order : bool
        Write the controllers in the scenario's order, which the runs, the tables and the
        figures follow (`yaml_dump_typed` sorts a mapping's keys): for a run's record of
        its scenario, which runs again to the same files. A sweep's and a library's tasks
        keep the sorted text their finished tasks were written with, and pick their
        controllers by label.

    Returns
    -------
    str
        A YAML document.
    """
    members = typing.get_args(ControllerConfig)
    lost = any(
        next(m for m in members if isinstance(config, m)) is not type(config)
        for config in scenario.controllers.values()
    )
    text = yaml_dump_typed(scenario, schema=_DUMP_SCHEMA if lost else Scenario)
    if not controllers_in_order:
        return text
    document = yaml.compose(text)
    order = {label: k for k, label in enumerate(scenario.controllers)}
    for key, value in document.value:
        if key.value == "controllers":
            value.value.sort(key=lambda pair: order[pair[0].value])
    return yaml.serialize(document, Dumper=yaml.SafeDumper)


def load_scenario_text(
    text: str,
    path: str | Path,
    overrides: Sequence[str | dict] = (),
    experiments: Mapping[str, ExperimentNeeds] | None = None,
) -> Scenario:
    """Load, override and validate a scenario given as YAML text (e.g. one that
    `dump_scenario` wrote, as a sweep ships it to its workers).

    Parameters
    ----------
    text : str
        The scenario's YAML document.
    path : str or Path
        The file the text stands for: messages name it, and a relative demonstration file
        is looked up in its folder (the file itself need not exist).
    overrides, experiments
        As for `load_scenario`.

    Returns
    -------
    Scenario
        The scenario, its demonstration file resolved to an absolute path.

    Raises
    ------
    InputError
        One line naming `path` and the line, or the override, and what is wrong.
    """
    return _load_text(text, Path(path), overrides, experiments)


@functools.lru_cache(maxsize=16)
def _typed_scenario(text: str) -> Scenario:
    """The Scenario a YAML document reads as, parsed once per text: PyYAML's pure-Python
    parser takes 9-15 ms for a bundled scenario, a copy of its result 0.2 ms, and sweeps,
    libraries and the checks load the same few files many times. Callers copy the result."""
    return yaml_load_typed(schema=Scenario, data=text)


def _has_content(text: str) -> bool:
    """Whether a YAML text holds more than blank lines, comments and document markers."""
    return any(
        line.strip() and not line.lstrip().startswith("#") and line.strip() not in ("---", "...")
        for line in text.splitlines()
    )


def _load_text(
    text: str,
    path: Path,
    overrides: Sequence[str | dict],
    experiments: Mapping[str, ExperimentNeeds] | None = None,
    variant: tuple[Path, str] | None = None,
    replay_problem: ReplayProblem | None = None,
) -> Scenario:
    """`load_scenario` after the files are read: parse, layer the variant, override,
    validate, resolve."""
    check_file_kind(path, text, "scenario")
    for file, content in [(path, text), *([variant] if variant else [])]:
        if not _has_content(content):
            raise InputError(f"{file}: holds no YAML (it is empty or only comments)")
        check_unique_keys(file, content)
        misshapen = misshapen_value(content, Scenario)
        if misshapen:
            line, key, problem = misshapen
            raise located(file, line, f"{_leaf(key)}: {problem}")
    try:
        scenario = copy.deepcopy(_typed_scenario(text))
    except Exception as error:  # yaml errors come as several exception types
        raise _yaml_error(path, text, error) from None
    if variant is not None:
        variant_path, variant_text = variant
        try:
            # yaml_load_typed reads into a copy of `defaults`
            scenario = yaml_load_typed(schema=Scenario, data=variant_text, defaults=scenario)
        except Exception as error:
            raise _yaml_error(variant_path, variant_text, error) from None
        # A variant sets values, so layering it again changes none; a run's own record
        # (DIR/scenario.yaml) already carries its name, which keeps its folder.
        suffix = f"_{variant_path.stem}"
        if not scenario.name.endswith(suffix):
            scenario.name += suffix
    base, parsed = scenario, [item for o in overrides for item in _parse_override(o)]
    for label, key, value in parsed:
        scenario = _overridden(scenario, label, key, value)
    notes = {o.typed: o.why for o in overrides if isinstance(o, TypedOverride) and o.why}
    source = _Source(path, text, [(label, key) for label, key, _ in parsed], variant, notes)
    found = _first_problem(scenario, path.parent, experiments, replay_problem)
    if found is not None:
        if not _task_given(source) and _of_the_world(found[0]):
            raise InputError(
                f"{path}: no task: a scenario says which world it is in `task` (!ArmTask for "
                "the arm, !SliderTask for the one-DOF slider); without it, it is the slider "
                f"world, where {_leaf(found[0])}: {found[1]}"
            )
        culprit = _culprit(base, parsed, found, source, path.parent, experiments, replay_problem)
        if culprit is not None:
            raise culprit
        source.fail(*found)
    if isinstance(scenario.reference, DemonstrationConfig):
        # Resolve the demonstration next to the scenario file, once, for every later user.
        scenario.reference.file = str(data_file(scenario.reference.file, path.parent).resolve())
    return scenario


def _task_given(source: _Source) -> bool:
    """Whether the scenario's file, its variant or an override gives `task` (else it is
    Scenario's default, the slider world's)."""
    texts = [source.text, *([source.variant[1]] if source.variant else [])]
    return any("task" in top_level_keys(text) for text in texts) or bool(
        source.overrides_of("task")
    )


def _of_the_world(dotted_key: str) -> bool:
    """Whether a problem at `dotted_key` may come of the world the task makes: the task's
    own fields, the kind of reference it follows, the experiment that needs a kind of task."""
    return dotted_key in ("experiment", "reference") or dotted_key.startswith("task.")


def check_scenario(scenario: Scenario, replay_problem: ReplayProblem | None = None) -> None:
    """The checks `load_scenario` makes, again, on a scenario changed in Python since it was
    loaded (a field set, a controller replaced): a value it would refuse is refused here
    too, before a diagram is built, rather than built into a run (a negative gain) or into
    a Drake assertion that ends the process (a vector of the wrong length).

    Parameters
    ----------
    scenario : Scenario
        As `load_scenario` returned it, maybe changed since (its demonstration's file
        resolved).
    replay_problem : callable(duration_s) -> str or None, optional
        As `load_scenario` takes it: for runs that follow another reference than the
        scenario's demonstration file.

    Raises
    ------
    InputError
        "scenario 'NAME': KEY: PROBLEM" for the first problem found.
    """
    found = _first_problem(scenario, Path.cwd(), None, replay_problem)
    if found is not None:
        key, problem = found
        raise InputError(f"scenario '{scenario.name}': {key}: {problem}")


def check_file_kind(path: Path, text: str, kind: str) -> None:
    """Refuse a YAML file of another kind than `kind` (a sweep given to `hlcmp run`, a
    scenario given to `hlcmp sweep`), told by the top-level keys only that kind has,
    before its keys are read as the wrong schema's.

    Parameters
    ----------
    path : Path
    text : str
        The file's text.
    kind : str
        A key of FILE_KINDS: what the command takes.

    Raises
    ------
    InputError
        "FILE: a sweep file (its keys labels, metrics), not a scenario file: give it to
        hlcmp sweep".
    """
    keys = top_level_keys(text)
    for other, (marks, command) in FILE_KINDS.items():
        found = sorted(keys & marks)
        if other != kind and found and not keys & FILE_KINDS[kind][0]:
            keys_named = f"key{'s' * (len(found) > 1)} {', '.join(found)}"
            raise InputError(
                f"{path}: a {other} file (its {keys_named}), not a {kind} file: "
                f"give it to {command}"
            )


def _overridden(scenario: Scenario, label: str, key: str, value: str) -> Scenario:
    """`scenario` with one override applied; InputError naming the override when it names
    no field, or its value has the wrong shape or does not load."""
    try:
        data = override_yaml(scenario, key, value)
    except KeyError as error:
        part, fields = error.args
        nearest = difflib.get_close_matches(part, fields, n=1)
        hint = f" (did you mean '{nearest[0]}'?)" if nearest else ""
        raise InputError(f"{_named(label)}: no field '{part}' in the scenario{hint}") from None
    except InputError as error:
        raise InputError(f"{_named(label)}: {error}") from None
    misshapen = misshapen_value(data, Scenario)
    if misshapen:
        raise InputError(f"{_named(label)}: {_leaf(misshapen[1])}: {misshapen[2]}")
    try:
        # yaml_load_typed reads into a copy of `defaults`: `scenario` stays as it was
        return yaml_load_typed(schema=Scenario, data=data, defaults=scenario)
    except Exception as error:
        message = " ".join(str(getattr(error, "problem", None) or error).split())
        raise InputError(f"{_named(label)}: {message}") from None


# Whether the files alone make a valid scenario, by their texts: a command with a bad
# override validates them again only for a file it has not seen (the tests break every
# field of a bundled scenario by one override each).
_VALID_FILES: dict[tuple, bool] = {}


def _files_valid(
    base: Scenario,
    source: _Source,
    folder: Path,
    experiments: Mapping[str, ExperimentNeeds] | None,
    replay_problem: ReplayProblem | None,
) -> bool:
    """Whether `base` (the scenario the files make, `source`'s texts) has no problem."""
    key = (
        str(source.path),
        source.text,
        source.variant and (str(source.variant[0]), source.variant[1]),
        tuple(experiments.items()) if experiments is not None else None,
        replay_problem,
    )
    if key not in _VALID_FILES:
        if len(_VALID_FILES) > 64:
            _VALID_FILES.clear()
        _VALID_FILES[key] = _first_problem(base, folder, experiments, replay_problem) is None
    return _VALID_FILES[key]


def _culprit(
    base: Scenario,
    parsed: list[tuple[str, str, str]],
    found: tuple[str, str],
    source: _Source,
    folder: Path,
    experiments: Mapping[str, ExperimentNeeds] | None,
    replay_problem: ReplayProblem | None,
) -> InputError | None:
    """The override that alone brings about the problem `found` (dotted key, problem) of
    the overridden scenario, where the files alone (`base`) are valid: one that sets the
    key, or one that makes a value of the files wrong (task=!SliderTask against the file's
    reference, named with the file's line). None where none does so alone (or there are
    no overrides): the problem is then named where `source` finds the key."""
    if not parsed or not _files_valid(base, source, folder, experiments, replay_problem):
        return None
    key, problem = found
    touching = {label for label, _ in source.overrides_of(key)}

    def blamed(label: str) -> InputError:
        where = "" if label in touching else f" (as {source.where(key)} sets it)"
        return source.blamed(label, f"{_leaf(key)}: {problem}{where}")

    if len(parsed) == 1:  # the overridden scenario is that override alone
        return blamed(parsed[0][0])
    # The overrides of the key itself first: mostly the culprit, found in one try.
    for label, override_key, value in sorted(parsed, key=lambda item: item[0] not in touching):
        try:
            alone = _overridden(base, label, override_key, value)
        except InputError:  # needs another override first (a field of a new controller)
            continue
        if _first_problem(alone, folder, experiments, replay_problem) == found:
            return blamed(label)
    return None


def scenario_error(path: Path, dotted_key: str, problem: str) -> InputError:
    """An InputError for a problem found after loading (by a world or an experiment).

    Parameters
    ----------
    path : Path
        The scenario file (an unreadable file gives a message without a line).
    dotted_key : str
        The dotted path of the field at fault, e.g. "controllers.hlcmp.q_k".
    problem : str
        What is wrong with it.

    Returns
    -------
    InputError
        Not raised: ``file:line: leaf: problem``, with the line where `path` sets
        `dotted_key` (omitted when it cannot be found) and the key's last part.
    """
    try:
        text = Path(path).read_text()
    except (OSError, UnicodeDecodeError):
        text = ""
    return _Source(Path(path), text, []).error(dotted_key, problem)
