"""The pieces every world's diagram shares: the reference, the torque map, the loggers,
and the handles a run needs to read a built diagram back.

    reference (DMP source / steps) --x_d, x_d', x_d'', s--> controller --f_c--> J^T map --> plant
    plant state --> TaskSpaceDynamics --x, x', M, C, G, J--> controller, J^T map

Every diagram is the plant + the world's extras + exactly one controller, so runs of
different controllers never share state. Loggers are Drake VectorLogSinks.
"""

from __future__ import annotations

import dataclasses as dc
from typing import TYPE_CHECKING, Callable

import numpy as np
from pydrake.systems.primitives import LogVectorOutput

from hlcmp_drake.config.scenario import DemonstrationConfig, Scenario, StepReferenceConfig
from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.io.demos import read_demonstration
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.systems.references import DmpSource, StepReference
from hlcmp_drake.systems.task_space import TaskForceToJointTorque
from hlcmp_drake.worlds.controllers import AddedController

if TYPE_CHECKING:
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.systems.framework import DiagramBuilder, LeafSystem, OutputPort
    from pydrake.systems.primitives import VectorLogSink

    from hlcmp_drake.systems.task_space import TaskSpaceDynamics


@dc.dataclass
class BuiltDiagram:
    """A finished diagram and the handles a run needs to read it back.

    Attributes
    ----------
    diagram : Diagram
    plant : MultibodyPlant
    controller : AddedController
        The controller's system, its logs and (learning) its theta reader.
    loggers : dict of str to VectorLogSink
        One per series of the timeseries.npz contract.
    initial_positions : (nq,) array or None
        Plant positions at t = 0 (None: the model's default).
    monitor : callable(root_context) -> str or None, optional
        The world's safety checks: a problem's description, or None.
    """

    diagram: object
    plant: object
    controller: AddedController
    loggers: dict
    initial_positions: np.ndarray | None = None
    monitor: Callable | None = None


def read_scenario_demonstration(
        scenario: Scenario) -> tuple[np.ndarray, np.ndarray, tuple[str, ...], list[int]]:
    """Read the scenario's demonstration CSV, checked to have the axes the scenario controls.

    Parameters
    ----------
    scenario : Scenario
        With a DemonstrationConfig reference (its file resolved).

    Returns
    -------
    t : (T,) array
        Sample times [s].
    positions : (T, M) array
        Tool positions [m], world frame.
    axes : tuple of str
        The position columns, ("x", "y", "z").
    lines : list of int
        Each sample's line in the CSV file.

    Raises
    ------
    InputError
        When the file cannot be read, or its columns are not x,y,z for the scenario's M axes.
    """
    reference: DemonstrationConfig = scenario.reference
    t, positions, axes, lines = read_demonstration(reference.file, with_lines=True)
    if axes != ("x", "y", "z")[: len(axes)] or len(axes) != scenario.n_axes:
        raise InputError(f"{reference.file}: has columns {','.join(axes)}, the scenario "
                         f"'{scenario.name}' needs x,y,z")
    return t, positions, axes, lines


def add_reference(builder: DiagramBuilder, scenario: Scenario,
                  dmp: Dmp | None = None) -> StepReference | DmpSource:
    """Add the desired-motion source, named "reference", to `builder`.

    Set-points for a StepReferenceConfig; the DMP `dmp` for a DemonstrationConfig,
    replayed at the demonstration's tau or at reference.duration_s when that is > 0.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        Its reference; for set-points also duration_s [s] and dmp.alpha_s, over which
        their phase s runs.
    dmp : Dmp, optional
        Needed for a DemonstrationConfig reference; ignored for set-points.

    Returns
    -------
    StepReference or DmpSource
        The added system: x_d [m], x_d' [m/s], x_d'' [m/s^2] and the phase s.
    """
    reference = scenario.reference
    if isinstance(reference, StepReferenceConfig):
        system = StepReference(reference.times_s, reference.positions_m, scenario.duration_s,
                               scenario.dmp.alpha_s)
    else:
        system = DmpSource(dmp, tau=reference.duration_s or None)
    system.set_name("reference")
    return builder.AddSystem(system)


def add_torque_map(builder: DiagramBuilder, scenario: Scenario, plant: MultibodyPlant, controller: LeafSystem,
                   task_space: TaskSpaceDynamics,
                   extra_torque_port: OutputPort | None = None) -> TaskForceToJointTorque:
    """Add tau = J^T f_c (+ the torque below the task, when given) into the plant's actuation.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        Its number of task axes M.
    plant : MultibodyPlant
        Finalized; its actuators' effort limits [N m] bound tau.
    controller : LeafSystem
        The controller system; its "force" output is f_c, (M,) [N].
    task_space : TaskSpaceDynamics
        Its "jacobian" output is J.
    extra_torque_port : OutputPort, optional
        A joint torque (nv,) [N m] added to J^T f_c before saturation, e.g. the
        null-space impedance.

    Returns
    -------
    TaskForceToJointTorque
        The added system, connected to the plant's actuation input.
    """
    effort = [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
    torque_map = builder.AddSystem(TaskForceToJointTorque(scenario.n_axes, effort,
                                                          extra_torque=extra_torque_port is not None))
    torque_map.set_name("task_force_to_joint_torque")
    builder.Connect(controller.GetOutputPort("force"), torque_map.force)
    builder.Connect(task_space.GetOutputPort("jacobian"), torque_map.jacobian)
    if extra_torque_port is not None:
        builder.Connect(extra_torque_port, torque_map.extra)
    builder.Connect(torque_map.GetOutputPort("joint_torque"), plant.get_actuation_input_port())
    return torque_map


def add_loggers(builder: DiagramBuilder, scenario: Scenario, plant: MultibodyPlant,
                task_space: TaskSpaceDynamics, reference: StepReference | DmpSource,
                controller: AddedController, force_port: OutputPort,
                torque_map: TaskForceToJointTorque) -> dict[str, VectorLogSink]:
    """Add the loggers of the timeseries.npz contract's series and of the plant state.

    Drake VectorLogSinks at scenario.log_period_s, named "log_<series>": x, xd, f_ext, fc,
    plant_state (for the recording), saturated_joints, and the controller's own series.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        Its log_period_s [s].
    plant : MultibodyPlant
        Its state is logged.
    task_space : TaskSpaceDynamics
        Its "position" output is x, (M,) [m].
    reference : StepReference or DmpSource
        Its "desired_position" output is x_d, (M,) [m].
    controller : AddedController
        Its system's "force" output is f_c, (M,) [N]; its `logs` are logged too.
    force_port : OutputPort
        The measured environment force f_ext, (M,) [N].
    torque_map : TaskForceToJointTorque
        Its "saturated" output (the number of joints at their effort limit).

    Returns
    -------
    dict of str to VectorLogSink
        {series name: logger}.
    """
    ports = {
        "x": task_space.GetOutputPort("position"),
        "xd": reference.GetOutputPort("desired_position"),
        "f_ext": force_port,
        "fc": controller.system.GetOutputPort("force"),
        "plant_state": plant.get_state_output_port(),
        "saturated_joints": torque_map.GetOutputPort("saturated"),
        **controller.logs,
    }
    loggers = {}
    for name, port in ports.items():
        loggers[name] = LogVectorOutput(port, builder, scenario.log_period_s)
        loggers[name].set_name(f"log_{name}")
    return loggers
