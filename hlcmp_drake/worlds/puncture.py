"""A foam that gives way, in any world that has the object and the tool: the HoleFriction
system wired to the plant, and the tear applied to SceneGraph when the system says so."""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.geometry import Box, CollisionFilterDeclaration, GeometrySet, SceneGraph
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.multibody.tree import Frame
from pydrake.systems.framework import Context, DiagramBuilder

from hlcmp_drake.config.scenario import PunctureConfig, Scenario
from hlcmp_drake.core.puncture import AT_THE_FACE_M, beside_by, depth_below, over_the_face
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.systems.puncture import HoleFriction
from hlcmp_drake.worlds.models import load_models, scoped_frame


@dc.dataclass
class Puncture:
    """A puncture model in a diagram: its system and what the simulation must do when the
    foam tears (`apply_tear`, called after every step, e.g. from the run's monitor)."""

    system: HoleFriction
    scene_graph: object
    tool_geometries: list
    object_geometries: list
    torn: bool = False

    def apply_tear(self, root_context: Context) -> None:
        """End the tool-object contact once the system's state says the foam has torn.

        Parameters
        ----------
        root_context : Context
            The diagram's root context (SceneGraph's context within it is changed).
        """
        if self.torn or not self.system.punctured(self.system.GetMyContextFromRoot(root_context)):
            return
        sg_context = self.scene_graph.GetMyMutableContextFromRoot(root_context)
        self.scene_graph.collision_filter_manager(sg_context).Apply(
            CollisionFilterDeclaration().ExcludeBetween(
                GeometrySet(self.tool_geometries), GeometrySet(self.object_geometries)
            )
        )
        self.torn = True


def add_puncture(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    config: PunctureConfig,
    tool_frame: Frame,
    tool_axis: list,
) -> Puncture:
    """Add the HoleFriction system for `config`, reading the plant's state and applying
    its force to the plant.

    Parameters
    ----------
    builder : DiagramBuilder
    plant : MultibodyPlant
        Finalized, discrete (the tear is checked every plant step).
    scene_graph : SceneGraph
        The plant's, where the tear's collision filter goes.
    config : PunctureConfig
        With a non-empty `object_frame`.
    tool_frame : Frame
        The tool point's frame (on the tool body).
    tool_axis : (3,) array
        The tool's axis in the world, pointing into the object.
    """
    top = _top_pose(plant, config)
    rotation = top.rotation().matrix()
    system = builder.AddSystem(
        HoleFriction(
            plant,
            tool_frame,
            tool_axis,
            top.translation(),
            rotation[:, 2],
            rotation,
            face_extent(plant, scene_graph, config),
            config.thickness_m,
            config.depth_m,
            config.hole_friction_N_per_m,
            config.sliding_speed_m_per_s,
            plant.time_step(),
        )
    )
    system.set_name("puncture")
    builder.Connect(plant.get_state_output_port(), system.plant_state)
    builder.Connect(
        system.GetOutputPort("spatial_forces"), plant.get_applied_spatial_force_input_port()
    )
    object_body = scoped_frame(plant, config.object_frame).body()
    return Puncture(
        system,
        scene_graph,
        plant.GetCollisionGeometriesForBody(tool_frame.body()),
        plant.GetCollisionGeometriesForBody(object_body),
    )


@dc.dataclass(frozen=True)
class ObjectFace:
    """The punctured object's top face in the world, as the foam's update reads it.

    Attributes
    ----------
    point : (3,) array
        The face frame's origin, on the face [m].
    rotation : (3, 3) array
        The face frame's orientation (its z the unit normal out of the object).
    extent : ((2,), (2,)) arrays or None
        Lower and upper x, y of the face in its frame [m] (`face_extent`); None: unbounded.
    """

    point: np.ndarray
    rotation: np.ndarray
    extent: tuple[np.ndarray, np.ndarray] | None

    @property
    def normal(self) -> np.ndarray:
        """The face's unit normal out of the object, world."""
        return self.rotation[:, 2]

    def depth_of(self, points: np.ndarray) -> float | np.ndarray:
        """How far `points` lie below the face [m] (`core.puncture.depth_below`).

        Parameters
        ----------
        points : (3,) or (T, 3) array
            World [m].
        """
        return depth_below(points, self.point, self.normal)

    def over(self, points: np.ndarray) -> bool | np.ndarray:
        """Whether `points` lie over (or under) the face (`core.puncture.over_the_face`;
        everywhere for an unbounded face).

        Parameters
        ----------
        points : (3,) or (T, 3) array
            World [m].
        """
        if self.extent is None:
            return True if np.ndim(points) == 1 else np.ones(len(points), dtype=bool)
        return over_the_face(points, self.point, self.rotation, *self.extent)

    def beside_by(self, points: np.ndarray) -> float | np.ndarray:
        """How far `points` lie beside the face [m], 0 over it (`core.puncture.beside_by`;
        0 everywhere for an unbounded face).

        Parameters
        ----------
        points : (3,) or (T, 3) array
            World [m].
        """
        if self.extent is None:
            return 0.0 if np.ndim(points) == 1 else np.zeros(len(points))
        return beside_by(points, self.point, self.rotation, *self.extent)


def object_face(scenario: Scenario) -> ObjectFace | None:
    """Where the punctured object's top face is and how far it reaches: what `add_puncture`
    reads, from the scenario's models alone.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask.

    Returns
    -------
    ObjectFace or None
        None when the task has no puncture.
    """
    config = scenario.task.puncture
    if not config.object_frame:
        return None
    plant, scene_graph = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.0)
    load_models(plant, scenario, scene_graph=scene_graph)
    top = _top_pose(plant, config)
    return ObjectFace(
        top.translation(), top.rotation().matrix(), face_extent(plant, scene_graph, config)
    )


def check_start_outside(
    scenario: Scenario,
    start: np.ndarray,
    starts: str = "the reference starts",
    advice: str = "is the demonstration in the scenario's world frame?",
) -> None:
    """Refuse a reference whose start puts the tool point below the punctured object's top
    face and over it: the tool would start inside the object or under it, where it could
    never come in through the face -- a reference in another frame than the world's, or
    shifted. (Below the face's plane beside the object is a place the tool can be: such a
    run goes ahead and does not tear the object. A start at the face, less than
    `core.puncture.AT_THE_FACE_M` below it, is the tool resting on it: it comes in.)

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask; nothing is checked without a puncture.
    start : (3,) array
        The tool point's start, world [m] (the reference's first point).
    starts : str, optional
        What starts the tool point there, for the message (e.g. "probe.start_m puts").
    advice : str, optional
        What to look at, ending the message.

    Raises
    ------
    InputError
        When the start is below the face (AT_THE_FACE_M or more) and over it.
    """
    face = object_face(scenario)
    if face is None:
        return
    start = np.asarray(start, dtype=float)
    depth = float(face.depth_of(start))
    if depth < AT_THE_FACE_M or not face.over(start):
        return
    raise InputError(
        f"{starts} the tool point at {_point(start)} m, {1000 * depth:.1f} mm "
        f"below the top face of '{scenario.task.puncture.object_frame}' (its centre at "
        f"{_point(face.point)} m) and over it: the tool would start inside or under the "
        f"object and could never come in through its face to tear it; {advice}"
    )


def _point(xyz) -> str:
    return "(" + ", ".join(f"{value:.3f}" for value in xyz) + ")"


def face_extent(
    plant: MultibodyPlant, scene_graph: SceneGraph, config: PunctureConfig
) -> tuple[np.ndarray, np.ndarray] | None:
    """The object's extent along its top face frame's x and y: the bounds of its collision
    boxes' corners in that frame (the model's own sizes, e.g. the foam plank's 0.30 x 0.20
    m), so a tool point beside the object tears and rubs nothing.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized, its geometry registered with `scene_graph`.
    scene_graph : SceneGraph
    config : PunctureConfig
        With a non-empty `object_frame`.

    Returns
    -------
    ((2,), (2,)) arrays or None
        Lower and upper x, y [m]; None when the object has a collision shape other than a
        box (its extent is then not read: unbounded, as before).
    """
    frame = scoped_frame(plant, config.object_frame)
    inspector = scene_graph.model_inspector()
    X_FB = frame.GetFixedPoseInBodyFrame().inverse()
    corners = []
    for geometry in plant.GetCollisionGeometriesForBody(frame.body()):
        shape = inspector.GetShape(geometry)
        if not isinstance(shape, Box):
            return None
        half = np.array([shape.width(), shape.depth(), shape.height()]) / 2
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        X_FG = X_FB @ inspector.GetPoseInFrame(geometry)
        corners += [X_FG @ (sign * half) for sign in signs]
    if not corners:
        return None
    xy = np.array(corners)[:, :2]
    return xy.min(axis=0), xy.max(axis=0)


def _top_pose(plant: MultibodyPlant, config: PunctureConfig):
    """The object's top-face frame in the world (origin on the face, +z out of the object),
    at the plant's default pose."""
    return scoped_frame(plant, config.object_frame).CalcPoseInWorld(plant.CreateDefaultContext())
