"""A scenario's world as a skill records it, so that a replay can tell whether it runs the
skill where the skill was learned.

The world is what the skill's profiles were learned against: the models and where they
stand (the model directives, each model file by its content rather than by its path) and
the task (the tool, the axes, how the arm holds the tool, the object's puncture, the
safety limits; for a slider its body, axis and the object's stiffness and surface). Not
part of it: the controllers and their learning rates, the durations, the DMP settings,
the demonstration (the skill brings its own DMP), the plant's and the simulator's
numerical settings (time step, contact approximation, integrator), logging, recording,
the probe and the iiwa driver's channels -- a replay may change any of these and still
run in the skill's world.

The digest is the SHA-256 of a canonical JSON text of {kind, directives, task}: the
directives as Drake's YAML writes them (empty values left out, so a field Drake adds with
an empty default changes nothing), each `add_model` file replaced by the SHA-256 of its
bytes when it is a file of ours or a plain path (other packages' URLs stay as they are:
reading them could mean a download; the meshes a model file includes are not followed),
and the task's fields that differ from its class's defaults (so a field added to the task
later, at its default, changes nothing).
"""

from __future__ import annotations

import dataclasses as dc
import hashlib
import json
from pathlib import Path
from typing import Any, Sequence

import yaml
from pydrake.common.yaml import yaml_dump_typed
from pydrake.multibody.parsing import ModelDirectives

from hlcmp_drake.config.scenario import DemonstrationConfig, Scenario
from hlcmp_drake.io.paths import MODELS_DIR, PACKAGE_NAME
from hlcmp_drake.io.skill import SkillWorld


def world_of_scenario(scenario: Scenario, overrides: Sequence[str] = ()) -> SkillWorld:
    """The world of `scenario` as a skill records it: its name, its kind and its digest,
    and the overrides among `overrides` that change what the digest covers.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario (after its overrides).
    overrides : sequence of str
        The ``key=value`` overrides it was loaded with, if they are to be recorded.

    Returns
    -------
    SkillWorld
        scenario.name, the task's class name ("ArmTask", "SliderTask"), the SHA-256 of
        `world_definition(scenario)`, and the overrides of the task and the directives.
    """
    text = json.dumps(world_definition(scenario), sort_keys=True, separators=(",", ":"))
    digest = hashlib.sha256(text.encode()).hexdigest()
    defining = tuple(
        o
        for o in overrides
        if isinstance(o, str) and o.split("=", 1)[0].strip().split(".")[0] in WORLD_SECTIONS
    )
    return SkillWorld(scenario.name, type(scenario.task).__name__, digest, defining)


# The scenario's top-level fields `world_definition` reads: an override of anything else
# leaves the world as it is.
WORLD_SECTIONS = ("directives", "task")


def inputs_digest(scenario: Scenario) -> str:
    """The SHA-256 of the files a run of `scenario` reads besides its own text: its world
    (`world_definition`: each model file by its content) and its demonstration's bytes.
    A sweep compares it to tell a finished task from one whose files changed since.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario (its demonstration's file resolved).

    Returns
    -------
    str
        64 hex digits.
    """
    reference = scenario.reference
    demonstration = None
    if isinstance(reference, DemonstrationConfig) and Path(reference.file).is_file():
        demonstration = hashlib.sha256(Path(reference.file).read_bytes()).hexdigest()
    inputs = {"world": world_definition(scenario), "demonstration": demonstration}
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def world_definition(scenario: Scenario) -> dict:
    """What defines the scenario's world, as plain data (the digest's input).

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.

    Returns
    -------
    dict
        "kind": the task's class name; "directives": the model directives as plain data,
        each model file as {"sha256": ...} of its content where it can be read here;
        "task": the task's fields that differ from its class's defaults.
    """
    text = yaml_dump_typed(ModelDirectives(directives=scenario.directives))
    dumped = yaml.load(text, Loader=_TaggedLoader)
    directives = [_without_empty(d) for d in dumped.get("directives") or []]
    for directive in directives:
        model = directive.get("add_model")
        if model is not None and "file" in model:
            model["file"] = _model_content(model["file"])
    return {
        "kind": type(scenario.task).__name__,
        "directives": directives,
        "task": _non_default_fields(scenario.task),
    }


class _TaggedLoader(yaml.SafeLoader):
    """Safe YAML, reading a tagged node (a rotation's !Rpy, !AngleAxis) as {"!Tag": value}."""


def _tagged(loader, suffix, node):
    if isinstance(node, yaml.MappingNode):
        value: Any = loader.construct_mapping(node, deep=True)
    elif isinstance(node, yaml.SequenceNode):
        value = loader.construct_sequence(node, deep=True)
    else:
        value = loader.construct_scalar(node)
    return {f"!{suffix}": value}


_TaggedLoader.add_multi_constructor("!", _tagged)


def _without_empty(value: Any) -> Any:
    """`value` with every empty dict, list and None left out, recursively."""
    if isinstance(value, dict):
        kept = {k: _without_empty(v) for k, v in value.items()}
        return {k: v for k, v in kept.items() if v not in ({}, [], None)}
    if isinstance(value, list):
        return [_without_empty(v) for v in value]
    return value


def _model_content(file: str) -> Any:
    """A model file by the SHA-256 of its bytes, or its URL when it cannot be read here."""
    ours = f"package://{PACKAGE_NAME}/models/"
    if file.startswith(ours):
        path: Path | None = MODELS_DIR / file[len(ours) :]
    elif file.startswith("package://"):
        path = None  # another package (e.g. drake_models): resolving it may download it
    else:
        path = Path(file.removeprefix("file://"))
    if path is None or not path.is_file():
        return file
    return {"sha256": hashlib.sha256(path.read_bytes()).hexdigest()}


def _non_default_fields(config: Any) -> dict:
    """A config dataclass's fields that differ from its class's defaults, nested configs
    as dicts of theirs (left out when they are at their defaults)."""
    default = type(config)()
    fields = {}
    for field in dc.fields(config):
        value = getattr(config, field.name)
        if dc.is_dataclass(value):
            nested = _non_default_fields(value)
            if nested:
                fields[field.name] = nested
        elif value != getattr(default, field.name):
            fields[field.name] = value
    return fields
