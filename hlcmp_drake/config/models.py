"""A scenario's models in a MultibodyPlant: the one way its model directives are parsed
(by the checks at load and by every world), and the scoped names of its models, frames
and bodies that scenario fields hold."""

from __future__ import annotations

import re
from stat import S_ISREG
from typing import TYPE_CHECKING, Sequence

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, GeometrySet
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import (
    GetScopedFrameByName,
    ModelDirectives,
    Parser,
    ProcessModelDirectives,
)
from pydrake.multibody.tree import (
    BodyIndex,
    FrameIndex,
    JacobianWrtVariable,
    ModelInstanceIndex,
)

from hlcmp_drake.io.paths import MODELS_DIR, PACKAGE_NAME, register_package

if TYPE_CHECKING:
    from pydrake.geometry import SceneGraph
    from pydrake.multibody.parsing import (
        AddCollisionFilterGroup,
        AddModel,
        AddWeld,
        ModelDirective,
    )
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import Frame, RigidBody


# The kinds of model directive (ModelDirective's fields: one is set in each).
DIRECTIVE_KINDS = (
    "add_model",
    "add_model_instance",
    "add_frame",
    "add_weld",
    "add_collision_filter_group",
    "add_directives",
)


def process_directives(
    plant: MultibodyPlant,
    directives: Sequence[ModelDirective],
    scene_graph: SceneGraph | None = None,
    by_drake: bool = False,
) -> None:
    """Add model directives to `plant` (not finalized), package://hlcmp_drake/... resolving
    to the bundled models.

    Directives that only add bundled SDF models, weld frames and filter collisions among
    their own groups (every bundled scenario's) are applied here, as Drake's
    ProcessModelDirectives applies them: each model parsed from its text
    (`bundled_model_text`) and each weld made (`weld_frames`) in the directives' order, the
    groups' collisions filtered last (`filter_collisions`). Any other list is Drake's
    whole. The plant is the same either way (tests/test_config_models.py compares every
    bundled world's model by model, geometry pair by geometry pair); the reason is time:
    Drake's SDF parser sets up its format description again for every file it opens, about
    40 ms a model here, and not for a model given as text (docs/performance.md, "Parsing
    the models").

    Parameters
    ----------
    plant : MultibodyPlant
        Not yet finalized; registered with a SceneGraph, the collision filter groups are
        checked and applied too (their members must exist).
    directives : sequence of ModelDirective
        A scenario's `directives`.
    scene_graph : SceneGraph, optional
        The plant's, where it has one: a plant with registered geometry but no scene graph
        given leaves directives with collision filter groups to Drake.
    by_drake : bool
        Every directive by ProcessModelDirectives (what Drake itself says of a directive
        it refuses).

    Raises
    ------
    RuntimeError
        Drake's, when a model cannot be loaded or a directive names what does not exist.
    """
    parser = Parser(plant)
    register_package(parser.package_map())
    texts = None if by_drake else bundled_model_texts(plant, directives)
    groups = [d.add_collision_filter_group for d in directives if d.add_collision_filter_group]
    # Without registered geometry Drake skips the groups; with it, they need the scene.
    filtered = bool(groups) and plant.geometry_source_is_registered()
    if texts is None or (filtered and scene_graph is None):
        ProcessModelDirectives(ModelDirectives(directives=list(directives)), plant, parser)
        return
    for directive, text in zip(directives, texts):
        if text is not None:
            parser.AddModelsFromString(text, "sdf")
        elif directive.add_weld is not None:
            weld_frames(plant, directive.add_weld)
    if filtered and scene_graph is not None:
        filter_collisions(plant, scene_graph, groups)


def weld_frames(plant: MultibodyPlant, weld: AddWeld) -> None:
    """The weld an add_weld directive makes: its parent and child frames by scoped name,
    X_PC's value or the identity (X_PC's base_frame unused, as by Drake).

    Parameters
    ----------
    plant : MultibodyPlant
        Not yet finalized, with both frames.
    weld : AddWeld
        The directive's weld.

    Raises
    ------
    RuntimeError
        Drake's, for a frame that is not there or a body already jointed.
    """
    X_PC = weld.X_PC.GetDeterministicValue() if weld.X_PC is not None else RigidTransform()
    plant.WeldFrames(
        GetScopedFrameByName(plant, weld.parent), GetScopedFrameByName(plant, weld.child), X_PC
    )


def filter_collisions(
    plant: MultibodyPlant, scene_graph: SceneGraph, groups: Sequence[AddCollisionFilterGroup]
) -> None:
    """The collisions add_collision_filter_group directives filter: each group the body
    frames of its members ("model::body"), no collision within a group that ignores
    itself, nor between a group and another it ignores.

    Parameters
    ----------
    plant : MultibodyPlant
        Not yet finalized, with every member's body and its geometry registered.
    scene_graph : SceneGraph
        The plant's.
    groups : sequence of AddCollisionFilterGroup
        Uniquely named, without namespace or member groups; each ignored group among them.

    Raises
    ------
    RuntimeError
        Drake's, for a member that is not a body of the plant.
    """
    frames = {
        group.name: GeometrySet(
            [
                plant.GetBodyFrameIdOrThrow(scoped_body(plant, name).index())
                for name in group.members
            ]
        )
        for group in groups
    }
    manager = scene_graph.collision_filter_manager()
    for group in groups:
        for other in group.ignored_collision_filter_groups:
            declaration = CollisionFilterDeclaration()
            if other == group.name:
                declaration.ExcludeWithin(frames[other])
            else:
                declaration.ExcludeBetween(frames[group.name], frames[other])
            manager.Apply(declaration)


def scoped_body(plant: MultibodyPlant, scoped_name: str) -> RigidBody:
    """The body named 'model::body' of `plant`.

    Parameters
    ----------
    plant : MultibodyPlant
    scoped_name : str
        E.g. "foam_plank::plank".

    Returns
    -------
    RigidBody

    Raises
    ------
    RuntimeError
        Drake's, when there is no such model or body.
    """
    model, _, name = scoped_name.rpartition("::")
    return plant.GetBodyByName(name, plant.GetModelInstanceByName(model))


_BUNDLED = f"package://{PACKAGE_NAME}/models/"
_PLAIN_NAME = re.compile(r"[A-Za-z0-9_]+")
_SCOPED_BODY = re.compile(r"[A-Za-z0-9_]+::[A-Za-z0-9_]+")
_MODEL_NAME = re.compile(r'(<model\s+name=")[^"]*(")')
_RELATIVE_URI = re.compile(r"<uri>(?![a-z]+://)([^<]+)</uri>")


def bundled_model_texts(
    plant: MultibodyPlant, directives: Sequence[ModelDirective]
) -> list[str | None] | None:
    """For directives that only add bundled SDF models, weld frames and filter collisions
    among their own groups: each model's text (`bundled_model_text`), None for the others.

    Parameters
    ----------
    plant : MultibodyPlant
        The plant they go into.
    directives : sequence of ModelDirective

    Returns
    -------
    list of (str or None), or None
        None when any directive is of another kind, adds another model, or names a model
        twice or one already in the plant; or when a collision filter group's name is not
        plain (letters, digits, underscores) or is given twice, when it has no members or
        one not named "model::body" (plain names), a namespace or member groups, or when
        it ignores a group that these directives do not make: what Drake checks of a
        group's names, it checks itself.
    """
    groups = [d.add_collision_filter_group for d in directives if d.add_collision_filter_group]
    group_names = {group.name for group in groups}
    if len(group_names) < len(groups) or any(
        not _PLAIN_NAME.fullmatch(group.name)
        or not group.members
        or not all(_SCOPED_BODY.fullmatch(member) for member in group.members)
        or group.model_namespace is not None
        or group.member_groups
        or not set(group.ignored_collision_filter_groups) <= group_names
        for group in groups
    ):
        return None
    names = set()
    texts: list[str | None] = []
    for directive in directives:
        kinds = [kind for kind in DIRECTIVE_KINDS if getattr(directive, kind) is not None]
        add = directive.add_model
        if kinds == ["add_model"] and add is not None:
            name = add.name
            text = bundled_model_text(add)
            if text is None or name in names or plant.HasModelInstanceNamed(name):
                return None
            names.add(name)
            texts.append(text)
        elif kinds in (["add_weld"], ["add_collision_filter_group"]):
            texts.append(None)
        else:
            return None
    return texts


def bundled_models_version(directives: Sequence[ModelDirective]) -> tuple | None:
    """What the models of `directives` are read from, as a value that changes when any of
    it does: the name, size and modification time of every bundled model file (meshes
    included), when the directives read no other file; else None.

    Parameters
    ----------
    directives : sequence of ModelDirective

    Returns
    -------
    tuple or None
        None for an add_directives, or an add_model of a file that is not a bundled model
        (package://hlcmp_drake/models/..., inside that folder): files whose changes this
        does not follow.
    """
    root = MODELS_DIR.resolve()
    for d in directives:
        if d.add_directives is not None:
            return None
        if (
            d.add_model is not None
            and not (
                d.add_model.file.startswith(_BUNDLED)  # and not out of it: models/../elsewhere
                and (MODELS_DIR / d.add_model.file[len(_BUNDLED) :]).resolve().is_relative_to(root)
            )
        ):
            return None
    files = []
    for path in sorted(MODELS_DIR.rglob("*")):
        stat = path.stat()
        if S_ISREG(stat.st_mode):
            files.append((str(path), stat.st_size, stat.st_mtime_ns))
    return tuple(files)


def bundled_model_text(add: AddModel) -> str | None:
    """The SDF text that loads as an add_model directive loads its bundled model: its one
    model renamed to the directive's name, the files it names beside it given as
    package://hlcmp_drake/models/....

    Parameters
    ----------
    add : AddModel
        An add_model directive.

    Returns
    -------
    str or None
        None unless it adds a bundled SDF file of one model under a plain name (letters,
        digits, underscores) and sets nothing else (default joint positions or body
        poses).
    """
    if (
        not add.file.startswith(_BUNDLED)
        or not add.file.endswith(".sdf")
        or not _PLAIN_NAME.fullmatch(add.name)
        or add.default_joint_positions
        or add.default_free_body_pose
    ):
        return None
    path = MODELS_DIR / add.file[len(_BUNDLED) :]
    if not path.is_file():
        return None
    text = path.read_text(encoding="utf-8")
    if len(re.findall(r"<model\b", text)) != 1:
        return None
    text = _MODEL_NAME.sub(lambda m: m[1] + add.name + m[2], text, count=1)
    return _RELATIVE_URI.sub(lambda m: f"<uri>{_BUNDLED}{m[1]}</uri>", text)


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


def translation_axes(plant: MultibodyPlant, name: str) -> list[int]:
    """The world axes (0 x, 1 y, 2 z) along which the plant's joints can move the origin of
    the body `name`: the nonzero rows of its translational Jacobian at the default state.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized.
    name : str
        A body's unique name (`body_problem` says None).

    Returns
    -------
    list of int
    """
    context = plant.CreateDefaultContext()
    frame, world = plant.GetBodyByName(name).body_frame(), plant.world_frame()
    origin = np.zeros(3)
    jacobian = plant.CalcJacobianTranslationalVelocity(
        context,
        JacobianWrtVariable.kV,
        frame,
        origin,  # type: ignore[arg-type]  # pydrake's stub wants a 2-D array type
        world,
        world,
    )
    return [axis for axis in range(3) if np.any(np.abs(jacobian[axis]) > 1e-12)]


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
