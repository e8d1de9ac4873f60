"""The arm world (the iiwa14 experiments): a torque-controlled arm whose task space is
the translation of a tool point, its start posture from inverse kinematics, the
orientation and posture held below the task, the wrist force sensor, and the safety
monitor."""

from __future__ import annotations

import dataclasses as dc
from typing import TYPE_CHECKING, Callable

import numpy as np
from pydrake.math import RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.scenario import ArmTask, Scenario
from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.systems.arm import NullSpaceImpedance, ToolContactForce
from hlcmp_drake.systems.task_space import TaskSpaceDynamics
from hlcmp_drake.worlds.checks import check_demonstration_feasible
from hlcmp_drake.worlds.common import (BuiltDiagram, add_loggers, add_reference, add_torque_map,
                                       read_scenario_demonstration)
from hlcmp_drake.worlds.controllers import WorldPorts, add_controller
from hlcmp_drake.worlds.puncture import Puncture, add_puncture
from hlcmp_drake.worlds.models import add_plant, load_models, scoped_frame, solve_ik_for_tool

if TYPE_CHECKING:
    from numpy.typing import ArrayLike
    from pydrake.systems.framework import Context

    from hlcmp_drake.systems.task_space import TaskForceToJointTorque


@dc.dataclass
class ArmSetup:
    """What every controller's diagram of an arm scenario shares: the fitted DMP, the
    start posture q0 [rad] (inverse kinematics) and the tool orientation to hold."""

    dmp: Dmp
    q0: np.ndarray
    tool_orientation: RotationMatrix


def solve_start_posture(scenario: Scenario, tip_position: ArrayLike) -> tuple[np.ndarray, RotationMatrix]:
    """The start posture for the tool point at `tip_position`, and the tool's orientation there.

    Inverse kinematics on a plant of the scenario's models, seeded with task.ik_seed_rad
    (elbow up), with the tool pointing as the task asks.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask.
    tip_position : (3,) array
        World position of the tool point [m], e.g. the DMP's start.

    Returns
    -------
    q0 : (nq,) array
        The plant's joint positions [rad].
    tool_orientation : RotationMatrix
        The tool frame's orientation in the world at q0.

    Raises
    ------
    InputError
        When the models cannot be loaded, or no posture puts the tool there.
    """
    task: ArmTask = scenario.task
    plant = MultibodyPlant(0.0)
    load_models(plant, scenario)
    q0 = solve_ik_for_tool(plant, task, tip_position, task.ik_seed_rad)
    if q0 is None:
        raise InputError(f"inverse kinematics found no posture with the tool at {np.round(tip_position, 3)} "
                         f"(the demonstration's start) pointing along {task.tool_direction} "
                         f"(orientation {task.tool_rpy_rad or 'free about it'}): "
                         "is it within the arm's reach?")
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q0)
    return q0, scoped_frame(plant, task.tool_frame).CalcRotationMatrixInWorld(context)


def fit_demonstration(scenario: Scenario) -> Dmp:
    """Table I step II at start-up: fit the DMP to the scenario's demonstration file.

    The demonstration is first checked to have the x, y, z columns the scenario controls
    and to be reachable by the arm within its joint speed limits.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask and a DemonstrationConfig (its file already resolved); the DMP's
        settings are scenario.dmp.

    Returns
    -------
    Dmp
        The fitted DMP, tau the demonstration's duration [s].

    Raises
    ------
    InputError
        When the demonstration cannot be read, has the wrong axes, or the arm cannot follow it.
    """
    t, positions, axes, lines = read_scenario_demonstration(scenario)
    check_demonstration_feasible(scenario, t, positions, scenario.reference.file, lines)
    return Dmp.fit(t, positions, axes, scenario.dmp)


def prepare(scenario: Scenario, dmp: Dmp | None = None) -> ArmSetup:
    """What every controller's diagram shares: the DMP, its start posture and the tool orientation.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask and a DemonstrationConfig.
    dmp : Dmp, optional
        E.g. a saved skill's; None: fitted to the scenario's demonstration.

    Returns
    -------
    ArmSetup
        The DMP, q0 [rad] with the tool at the DMP's start, and the tool orientation there.

    Raises
    ------
    InputError
        From fitting the demonstration or from the inverse kinematics.
    """
    dmp = dmp or fit_demonstration(scenario)
    q0, orientation = solve_start_posture(scenario, dmp.start)
    return ArmSetup(dmp, q0, orientation)


def build(scenario: Scenario, controller_name: str, setup: ArmSetup,
          theta0: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> BuiltDiagram:
    """The iiwa diagram: DMP source -> controller -> J^T f_c + null-space terms -> plant.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask and a DemonstrationConfig.
    controller_name : str
        The label of the controller to build.
    setup : ArmSetup
        From `prepare`, shared by every controller of the scenario.
    theta0 : tuple of three (M, N) arrays, optional
        A learning controller's initial weights (theta_k, theta_d, theta_v).

    Returns
    -------
    BuiltDiagram
        The diagram, with initial_positions = setup.q0 and the arm's safety `monitor`.
    """
    task: ArmTask = scenario.task
    builder = DiagramBuilder()
    plant, scene_graph = add_plant(builder, scenario)
    tool_frame = scoped_frame(plant, task.tool_frame)
    task_space = builder.AddSystem(TaskSpaceDynamics(plant, tool_frame, axes=task.axes))
    task_space.set_name("task_space")
    builder.Connect(plant.get_state_output_port(), task_space.plant_state)
    reference = add_reference(builder, scenario, setup.dmp)
    puncture = None
    if task.puncture.object_frame:   # a foam that gives way; the tool point's x, x' are all three axes
        puncture = add_puncture(builder, plant, scene_graph, task.puncture, tool_frame, task.tool_direction,
                                task_space.GetOutputPort("position"), task_space.GetOutputPort("velocity"))
    sensor = builder.AddSystem(ToolContactForce(plant, tool_frame.body(), task.axes,
                                                applied_force=puncture is not None))
    sensor.set_name("wrist_force_sensor")
    builder.Connect(plant.get_contact_results_output_port(), sensor.contact_results)
    if puncture is not None:
        builder.Connect(puncture.system.GetOutputPort("force"), sensor.applied_force)
    world = WorldPorts(reference, task_space, sensor.GetOutputPort("task_force"), setup.dmp.start)
    controller = add_controller(builder, scenario, controller_name, world, theta0)
    below_task = builder.AddSystem(NullSpaceImpedance(
        plant, tool_frame, setup.tool_orientation, setup.q0,
        task.orientation_stiffness_Nm_per_rad, task.orientation_damping_Nms_per_rad,
        task.posture_stiffness_Nm_per_rad, task.posture_damping_Nms_per_rad))
    below_task.set_name("null_space_impedance")
    builder.Connect(plant.get_state_output_port(), below_task.plant_state)
    builder.Connect(task_space.GetOutputPort("null_space_projector"), below_task.projector)
    builder.Connect(task_space.GetOutputPort("joint_gravity"), below_task.gravity)
    torque_map = add_torque_map(builder, scenario, plant, controller.system, task_space,
                                below_task.get_output_port())
    loggers = add_loggers(builder, scenario, plant, task_space, reference, controller,
                          world.contact_force, torque_map)
    diagram = builder.Build()
    diagram.set_name(f"{scenario.name}_{controller_name}")
    return BuiltDiagram(diagram, plant, controller, loggers, setup.q0,
                        monitor(plant, sensor, torque_map, task, puncture))


def monitor(plant: MultibodyPlant, sensor: ToolContactForce, torque_map: TaskForceToJointTorque,
            task: ArmTask, puncture: Puncture | None = None) -> Callable[[Context], str | None]:
    """The arm's safety checks, to run after every step; first, the foam's tear, if any.

    A problem is a contact force above task.max_contact_force_N, a joint beyond its
    position limit (by more than 1e-3 rad), or some joint torque at its effort limit
    without a break for longer than task.max_saturation_s.

    Parameters
    ----------
    plant : MultibodyPlant
        The diagram's finalized plant.
    sensor : ToolContactForce
        The wrist force sensor; its "force" output [N] is checked.
    torque_map : TaskForceToJointTorque
        Its "saturated" output counts the joints at their effort limit.
    task : ArmTask
        The safety limits.
    puncture : Puncture, optional
        Its tear is applied as soon as its system says the foam has torn.

    Returns
    -------
    callable(root_context) -> str or None
        The first problem's description, or None. It keeps the time saturation began, so
        use one per simulation, called in time order.
    """
    lower, upper = plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()
    names = [plant.get_joint(plant.get_joint_actuator(i).joint().index()).name()
             for i in plant.GetJointActuatorIndices()]
    saturated_since = [None]

    def check(root_context):
        if puncture is not None:
            puncture.apply_tear(root_context)
        force = sensor.GetOutputPort("force").Eval(sensor.GetMyContextFromRoot(root_context))
        if np.linalg.norm(force) > task.max_contact_force_N:
            return (f"contact force {np.linalg.norm(force):.0f} N above max_contact_force_N = "
                    f"{task.max_contact_force_N} N")
        q = plant.GetPositions(plant.GetMyContextFromRoot(root_context))
        beyond = np.flatnonzero((q < lower - 1e-3) | (q > upper + 1e-3))
        if beyond.size:
            k = beyond[0]
            return f"joint {names[k]} at {q[k]:.3f} rad, beyond its limit ±{upper[k]:.3f} rad"
        t = root_context.get_time()
        if torque_map.GetOutputPort("saturated").Eval(torque_map.GetMyContextFromRoot(root_context))[0] > 0:
            saturated_since[0] = t if saturated_since[0] is None else saturated_since[0]
            if t - saturated_since[0] > task.max_saturation_s:
                return f"joint torques saturated for more than max_saturation_s = {task.max_saturation_s} s"
        else:
            saturated_since[0] = None
        return None

    return check
