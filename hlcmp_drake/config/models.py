"""A scenario's models in a MultibodyPlant: the one way its model directives are parsed
(by the checks at load and by every world), and the scoped names of its models, frames
and bodies that scenario fields hold."""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Sequence

from pydrake.multibody.parsing import ModelDirectives, Parser, ProcessModelDirectives
from pydrake.multibody.tree import BodyIndex, FrameIndex, ModelInstanceIndex

from hlcmp_drake.io.paths import register_package

if TYPE_CHECKING:
    from pydrake.multibody.parsing import ModelDirective
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import Frame


def process_directives(plant: MultibodyPlant, directives: Sequence[ModelDirective]) -> None:
    """Add model directives to `plant` (not finalized), package://hlcmp_drake/... resolving
    to the bundled models.

    Parameters
    ----------
    plant : MultibodyPlant
        Not yet finalized; with a SceneGraph, the collision filter groups are checked and
        applied too (their members must exist).
    directives : sequence of ModelDirective
        A scenario's `directives`.

    Raises
    ------
    RuntimeError
        Drake's, when a model cannot be loaded or a directive names what does not exist.
    """
    parser = Parser(plant)
    register_package(parser.package_map())
    ProcessModelDirectives(ModelDirectives(directives=list(directives)), plant, parser)


def drake_error_line(error: Exception) -> str:
    """Drake's error message in one line: its first line, followed by the line after it
    when it ends in a colon; a failed download as its first candidate's reason, e.g.
    "All downloads failed: 3 candidates, the first (https://...) with <urlopen error ...>".

    Parameters
    ----------
    error : Exception
        What Drake raised.

    Returns
    -------
    str
    """
    text = str(error)
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    if not lines:
        return type(error).__name__
    candidates = re.findall(r"Candidate (\S+) failed:\s*\n\s*(.+)", text)
    if candidates:
        url, reason = candidates[0]
        count = len(candidates)
        where = f"{count} candidates, the first ({url})" if count > 1 else f"from {url}"
        return f"{lines[0]} {where} with {reason.strip()}"
    if lines[0].endswith(":") and len(lines) > 1:
        return f"{lines[0]} {lines[1]}"
    return lines[0]


def loading_problem(error: RuntimeError) -> str:
    """What Drake's error while loading models says, in one line.

    Parameters
    ----------
    error : RuntimeError
        As `process_directives` raised it.

    Returns
    -------
    str
        `drake_error_line(error)`, after a hint when a drake_models file could not be had
        (Drake downloads that package on first use).
    """
    hint = "(drake_models is downloaded on first use: is there internet?) "
    return (hint if "drake_models" in str(error) else "") + drake_error_line(error)


def scoped_frame(plant: MultibodyPlant, scoped_name: str) -> Frame:
    """The frame named 'model::frame' (or a unique 'frame') of `plant`.

    Parameters
    ----------
    plant : MultibodyPlant
        With the scenario's models.
    scoped_name : str
        E.g. "insertion_tool::tip"; the part after the last "::" is the frame.

    Returns
    -------
    Frame
        The frame (Drake raises RuntimeError when there is no such model or frame;
        `frame_problem` says so beforehand).
    """
    model, _, name = scoped_name.rpartition("::")
    return (
        plant.GetFrameByName(name, plant.GetModelInstanceByName(model))
        if model
        else plant.GetFrameByName(name)
    )


def model_names(plant: MultibodyPlant) -> list[str]:
    """The names of the plant's model instances that models were loaded into.

    Parameters
    ----------
    plant : MultibodyPlant

    Returns
    -------
    list of str
        In the order they were added; Drake's "WorldModelInstance" and
        "DefaultModelInstance" left out.
    """
    names = [
        plant.GetModelInstanceName(ModelInstanceIndex(k))
        for k in range(plant.num_model_instances())
    ]
    return [n for n in names if n not in ("WorldModelInstance", "DefaultModelInstance")]


def _frames_of(plant: MultibodyPlant, model: str | None) -> list[str]:
    """The names of the frames of `model` (every model: None), Drake's "__model__" left out."""
    frames = [plant.get_frame(FrameIndex(k)) for k in range(plant.num_frames())]
    return sorted(
        {
            f.name()
            for f in frames
            if not f.name().startswith("__")
            and (model is None or plant.GetModelInstanceName(f.model_instance()) == model)
        }
    )


def missing_model(plant: MultibodyPlant, model: str) -> str | None:
    """What is wrong with the model instance name `model`, or None if `plant` has it.

    Parameters
    ----------
    plant : MultibodyPlant
    model : str
        A model instance's name, e.g. "iiwa".

    Returns
    -------
    str or None
        E.g. "no model 'iiwaa' (the scenario's models: iiwa, insertion_tool, foam_plank)".
    """
    if plant.HasModelInstanceNamed(model):
        return None
    return f"no model '{model}' (the scenario's models: {', '.join(model_names(plant))})"


def frame_problem(plant: MultibodyPlant, scoped_name: str) -> str | None:
    """What is wrong with a scoped frame name, or None if `scoped_frame` finds the frame.

    Parameters
    ----------
    plant : MultibodyPlant
        With the scenario's models.
    scoped_name : str
        "model::frame", or a frame name that only one model has.

    Returns
    -------
    str or None
        The problem and what there is instead, e.g. "no frame 'tipp' in model
        'insertion_tool' (its frames: mount, tip, tool)".
    """
    model, _, name = scoped_name.rpartition("::")
    if model:
        missing = missing_model(plant, model)
        if missing:
            return missing
        if plant.HasFrameNamed(name, plant.GetModelInstanceByName(model)):
            return None
        return (
            f"no frame '{name}' in model '{model}' (its frames: "
            f"{', '.join(_frames_of(plant, model))})"
        )
    owners = [
        m for m in ["WorldModelInstance", *model_names(plant)] if name in _frames_of(plant, m)
    ]
    if len(owners) == 1:
        return None
    if owners:
        return f"frame '{name}' is in models {', '.join(owners)}: expected 'model::{name}'"
    return (
        f"no frame '{name}' in any model: expected 'model::frame' "
        f"(the scenario's models: {', '.join(model_names(plant))})"
    )


def body_problem(plant: MultibodyPlant, name: str) -> str | None:
    """What is wrong with a body name that `MultibodyPlant.GetBodyByName(name)` is given,
    or None if the plant has exactly one body of that name.

    Parameters
    ----------
    plant : MultibodyPlant
    name : str
        A body's name, unscoped (e.g. "body").

    Returns
    -------
    str or None
        The problem and the bodies there are.
    """
    bodies = [plant.get_body(BodyIndex(k)) for k in range(plant.num_bodies())]
    count = sum(b.name() == name for b in bodies)
    if count == 1:
        return None
    if count:
        return f"{count} bodies are named '{name}': GetBodyByName needs a unique name"
    names = sorted({b.name() for b in bodies if b.name() != "world"})
    return f"no body '{name}' (the scenario's bodies: {', '.join(names)})"


def tool_mount(directives: Sequence[ModelDirective], arm: str) -> str | None:
    """The frame of the tool that the directives weld to the model `arm`.

    Parameters
    ----------
    directives : sequence of ModelDirective
    arm : str
        The arm's model instance name, e.g. "iiwa".

    Returns
    -------
    str or None
        The child of the last add_weld whose parent is one of `arm`'s frames ("arm::..."),
        e.g. "insertion_tool::mount"; None when nothing is welded to the arm.
    """
    mount = None
    for directive in directives:
        weld = directive.add_weld
        if weld is not None and weld.parent.startswith(f"{arm}::"):
            mount = weld.child
    return mount
