"""Loading a scenario's models into a MultibodyPlant, and inverse kinematics for a tool."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.plant import AddMultibodyPlant
from pydrake.solvers import Solve

from hlcmp_drake.config.models import (
    drake_error_line,
    loading_problem,
    process_directives,
    scoped_frame,
)
from hlcmp_drake.config.scenario import ArmTask, Scenario
from hlcmp_drake.io.errors import InputError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike
    from pydrake.geometry import SceneGraph
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.systems.framework import DiagramBuilder

__all__ = ["add_plant", "drake_error_line", "load_models", "scoped_frame", "solve_ik_for_tool"]


def load_models(
    plant: MultibodyPlant,
    scenario: Scenario,
    finalize: bool = True,
    scene_graph: SceneGraph | None = None,
) -> None:
    """Add the scenario's model directives to `plant`, then finalize it.

    Parameters
    ----------
    plant : MultibodyPlant
        Not yet finalized.
    scenario : Scenario
        Its `directives` (package://hlcmp_drake/... resolves to the bundled models).
    finalize : bool
        Finalize the plant (False: the caller adds more first).
    scene_graph : SceneGraph, optional
        The plant's, when it has one (`process_directives`).

    Raises
    ------
    InputError
        When Drake cannot load a model (the first line of Drake's message).
    """
    try:
        process_directives(plant, scenario.directives, scene_graph)
    except RuntimeError as error:
        raise InputError(
            f"{scenario.name}: the models could not be loaded: {loading_problem(error)}"
        ) from None
    if finalize:
        plant.Finalize()


def add_plant(
    builder: DiagramBuilder, scenario: Scenario, finalize: bool = True
) -> tuple[MultibodyPlant, SceneGraph]:
    """MultibodyPlant + SceneGraph from the scenario's plant config and model directives.

    Parameters
    ----------
    builder : DiagramBuilder
        Receives the plant and the scene graph.
    scenario : Scenario
        Its `plant_config` and `directives`.
    finalize : bool
        Finalize the plant (False: the caller adds bodies or joints first).

    Returns
    -------
    (MultibodyPlant, SceneGraph)
        Both added to `builder`; the plant finalized unless asked not to.

    Raises
    ------
    InputError
        When Drake cannot load a model.
    """
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, builder)
    load_models(plant, scenario, finalize, scene_graph)
    return plant, scene_graph


def solve_ik_for_tool(
    plant: MultibodyPlant,
    task: ArmTask,
    tip_position: ArrayLike,
    seed: ArrayLike,
    orientation: RotationMatrix | None = None,
) -> np.ndarray | None:
    """Inverse kinematics: the tool point at `tip_position`, pointing as the task asks
    (or with the whole `orientation`, a pose demonstration's first).

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized, with the arm and the tool.
    task : ArmTask
        The tool frame, and its +z along `tool_direction` (or the whole orientation
        `tool_rpy_rad` when given).
    tip_position : (3,) array
        World position of the tool point [m] (held within 0.1 mm).
    seed : (nq,) array
        Joint positions [rad] to start from and stay close to.
    orientation : RotationMatrix, optional
        The tool frame's whole orientation in the world, in place of the task's.

    Returns
    -------
    (nq,) array or None
        The joint positions, or None if there is no such posture.
    """
    frame = scoped_frame(plant, task.tool_frame)
    ik = InverseKinematics(plant)
    ik.AddPositionConstraint(
        frame,
        np.zeros(3),
        plant.world_frame(),
        np.asarray(tip_position) - 1e-4,
        np.asarray(tip_position) + 1e-4,
    )
    if orientation is None and task.tool_rpy_rad:
        orientation = RotationMatrix(RollPitchYaw(task.tool_rpy_rad))
    if orientation is not None:
        ik.AddOrientationConstraint(
            plant.world_frame(),
            orientation,
            frame,
            RotationMatrix(),
            1e-3,
        )
    else:
        ik.AddAngleBetweenVectorsConstraint(
            plant.world_frame(),
            np.asarray(task.tool_direction, float),
            frame,
            np.array([0.0, 0.0, 1.0]),
            0.0,
            1e-3,
        )
    seed = np.asarray(seed, dtype=float)
    ik.get_mutable_prog().AddQuadraticErrorCost(np.eye(len(seed)), seed, ik.q())
    result = Solve(ik.prog(), seed)
    return result.GetSolution(ik.q()) if result.is_success() else None
