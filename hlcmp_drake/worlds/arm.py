"""The arm world (the iiwa14 experiments): a torque-controlled arm whose task space is
the translation of a tool point, its start posture from inverse kinematics, the
orientation and posture held below the task, the wrist force sensor, and the safety
monitor."""

from __future__ import annotations

import dataclasses as dc
import functools
from typing import TYPE_CHECKING, Callable

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.scenario import ArmTask, Scenario
from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.core.orientation_dmp import OrientationDmp
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.systems.arm import BelowTaskImpedance, NullSpaceImpedance, ToolContactForce
from hlcmp_drake.systems.arm_tick import arm_control_tick
from hlcmp_drake.systems.control_loop import ControlTick
from hlcmp_drake.systems.monitor import saturation_check
from hlcmp_drake.systems.pose_control import PoseControlTick
from hlcmp_drake.systems.robot import (
    JointFriction,
    arm_bodies,
    sensed_force,
    set_model_off,
    velocity_estimate,
)
from hlcmp_drake.systems.task_space import TaskSpaceDynamics, TaskSpaceModel
from hlcmp_drake.worlds.arm_setup import ArmSetup
from hlcmp_drake.worlds.checks import check_demonstration_feasible
from hlcmp_drake.worlds.common import (
    BuiltDiagram,
    add_control_loop,
    add_loggers,
    add_reference,
    add_safety_monitor,
    add_torque_map,
    modular_log_ports,
    read_scenario_demonstration,
    read_scenario_orientations,
)
from hlcmp_drake.worlds.controllers import (
    WorldPorts,
    add_controller,
    controller_kind,
)
from hlcmp_drake.worlds.extras import ToolSensing, add_tool_sensing
from hlcmp_drake.worlds.models import add_plant, load_models, scoped_frame, solve_ik_for_tool
from hlcmp_drake.worlds.pose import LOGGED_REFERENCE, add_pose_reference, pose_tick
from hlcmp_drake.worlds.puncture import check_start_outside

if TYPE_CHECKING:
    from numpy.typing import ArrayLike
    from pydrake.multibody.tree import Frame
    from pydrake.systems.framework import OutputPort, System


def solve_start_posture(
    scenario: Scenario, tip_position: ArrayLike, orientation: RotationMatrix | None = None
) -> tuple[np.ndarray, RotationMatrix]:
    """The start posture for the tool point at `tip_position`, and the tool's orientation there.

    Inverse kinematics on a plant of the scenario's models, seeded with task.ik_seed_rad
    (elbow up), with the tool pointing as the task asks (or as `orientation`).

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask.
    tip_position : (3,) array
        World position of the tool point [m], e.g. the DMP's start.
    orientation : RotationMatrix, optional
        The tool's whole orientation there (a pose demonstration's first).

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
    q0 = solve_ik_for_tool(plant, task, tip_position, task.ik_seed_rad, orientation)
    if q0 is None:
        if orientation is not None:
            turned = (np.round(RollPitchYaw(orientation).vector(), 3) + 0.0).tolist()  # no -0.0
            pointing = f"turned as the demonstration's first orientation (rpy {turned} rad)"
        else:
            pointing = (
                f"pointing along {task.tool_direction} "
                f"(orientation {task.tool_rpy_rad or 'free about it'})"
            )
        raise InputError(
            f"inverse kinematics found no posture with the tool at {np.round(tip_position, 3)} "
            f"(the demonstration's start) {pointing}: is it within the arm's reach, and can "
            "the tool turn so there? The solver starts from task.ik_seed_rad, and a seed "
            "nearer such a posture may find one"
        )
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


def fit_orientation_demonstration(scenario: Scenario) -> OrientationDmp | None:
    """Fit the orientation DMP to the scenario's demonstration, when it is a pose.

    Parameters
    ----------
    scenario : Scenario
        With a DemonstrationConfig; the DMP's settings are scenario.dmp.

    Returns
    -------
    OrientationDmp or None
        None for a position-only demonstration.
    """
    demonstrated = read_scenario_orientations(scenario)
    return None if demonstrated is None else OrientationDmp.fit(*demonstrated, scenario.dmp)


def prepare(
    scenario: Scenario, dmp: Dmp | None = None, orientation_dmp: OrientationDmp | None = None
) -> ArmSetup:
    """What every controller's diagram shares: the DMPs, the start posture and the tool
    orientation there.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask and a DemonstrationConfig.
    dmp : Dmp, optional
        E.g. a saved skill's; None: fitted to the scenario's demonstration.
    orientation_dmp : OrientationDmp, optional
        A pose skill's; None: fitted to the demonstration when it is a pose.

    Returns
    -------
    ArmSetup
        The DMPs, q0 [rad] with the tool at the DMP's start (and, for a pose, in its
        start orientation), and the tool orientation there.

    Raises
    ------
    InputError
        From fitting the demonstration, for a start inside or under the punctured object
        (`check_start_outside`), or from the inverse kinematics.
    """
    dmp = dmp or fit_demonstration(scenario)
    orientation_dmp = orientation_dmp or fit_orientation_demonstration(scenario)
    start = (
        None
        if orientation_dmp is None
        else RotationMatrix(Quaternion(np.asarray(orientation_dmp.start, float)))
    )
    check_start_outside(scenario, dmp.start)
    q0, orientation = solve_start_posture(scenario, dmp.start, start)
    return ArmSetup(dmp, q0, orientation, orientation_dmp)


@dc.dataclass
class ArmWorld:
    """The arm's world in a diagram being built, before any controller.

    Attributes
    ----------
    plant : MultibodyPlant
        Finalized, with the scenario's models.
    tool_frame : Frame
        The tool point's frame (task.tool_frame).
    sensing : ToolSensing
        The wrist force sensor and the task's physics extras (e.g. the foam's give-way).
    """

    plant: MultibodyPlant
    tool_frame: Frame
    sensing: ToolSensing

    @property
    def sensor(self) -> ToolContactForce:
        """The wrist force sensor."""
        return self.sensing.sensor


def add_world(builder: DiagramBuilder, scenario: Scenario) -> ArmWorld:
    """Add the plant and its models, the task's physics extras (the foam's give-way, when
    the task has one) and the wrist force sensor.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        With an ArmTask.

    Returns
    -------
    ArmWorld
        What a controller and the harness connect to.
    """
    task: ArmTask = scenario.task
    plant, scene_graph = add_plant(builder, scenario)
    tool_frame = scoped_frame(plant, task.tool_frame)
    sensing = add_tool_sensing(builder, plant, scene_graph, task, tool_frame, axes=tuple(task.axes))
    return ArmWorld(plant, tool_frame, sensing)


def add_harness(
    builder: DiagramBuilder,
    scenario: Scenario,
    world: ArmWorld,
    *,
    log_ports: dict,
    saturated: OutputPort,
    force: OutputPort | None = None,
) -> dict:
    """Add what a run carries besides its world and controller: the SafetyMonitor (with
    the arm's checks on the wrist force, the joint limits and `saturated`) and the loggers.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        With an ArmTask.
    world : ArmWorld
        From `add_world`.
    log_ports : dict
        The series to log (see `add_loggers`).
    saturated : OutputPort
        The number of joints at their effort limit (1).
    force : OutputPort, optional
        The wrist force the monitor checks (3, world) [N]; default the sensor's.

    Returns
    -------
    dict of str to (VectorLogSink, slice)
        The loggers, as `add_loggers` returns them.
    """
    if force is None:
        force = world.sensor.GetOutputPort("force")
    add_safety_monitor(
        builder,
        scenario,
        world.plant,
        extra_inputs={"contact_force": force, "saturated": saturated},
        extra_check=arm_check(world.plant, scenario.task),
    )
    return add_loggers(builder, scenario, log_ports)


def build(
    scenario: Scenario,
    controller_name: str,
    setup: ArmSetup,
    *,
    theta0: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    harness: bool = True,
) -> BuiltDiagram:
    """The iiwa diagram: the world, one controller and the harness (safety monitor, loggers).

    The controller goes in as task.control_path says: "fast" (`_add_fast_controller`) or
    "modular" (`_add_modular_controller`). A robot that is not its model
    (scenario.robot_imperfection, fast path only: checked at load) adds `add_real_arm`'s
    systems and sets the controller's model off the arm.

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
    harness : bool
        False: no safety monitor and no loggers (the benchmark's bare runs).

    Returns
    -------
    BuiltDiagram
        The diagram, with initial_positions = setup.q0 and, with a foam that gives way,
        its tear as `after_step`.
    """
    builder = DiagramBuilder()
    world = add_world(builder, scenario)
    real = (
        None
        if scenario.robot_imperfection.perfect
        else add_real_arm(builder, scenario, world, setup)
    )
    fast = (
        scenario.task.control_path == "fast"
        and controller_kind(scenario, controller_name).law is not None
    )
    add = (
        functools.partial(_add_fast_controller, real_arm=real) if fast else _add_modular_controller
    )
    controller, log_ports, saturated = add(
        builder,
        scenario,
        controller_name,
        plant=world.plant,
        tool_frame=world.tool_frame,
        setup=setup,
        contact_force=world.sensor.GetOutputPort("task_force"),
        theta0=theta0,
    )
    log_ports = {**log_ports, "tau_ext": world.sensor.GetOutputPort("torque")}
    loggers = (
        add_harness(
            builder,
            scenario,
            world,
            log_ports=log_ports,
            saturated=saturated,
            force=real.force if real else None,
        )
        if harness
        else {}
    )
    diagram = builder.Build()
    diagram.set_name(f"{scenario.name}_{controller_name}")
    return BuiltDiagram(
        diagram,
        world.plant,
        controller,
        loggers,
        setup.q0,
        world.sensing.after_step(),
    )


def build_driven(
    scenario: Scenario,
    setup: ArmSetup,
    *,
    add_driver: Callable[[DiagramBuilder, MultibodyPlant], None] | None = None,
) -> BuiltDiagram:
    """The arm's world with no controller: the plant's actuation input is left open for
    whoever drives the joints (`hlcmp sim-driver`, which fixes it to a driver's command
    plus gravity compensation every period), or taken by a driver's systems.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask.
    setup : ArmSetup
        Its q0 is the start posture.
    add_driver : callable(builder, plant), optional
        Adds a driver's systems to the world's builder and connects them to the plant
        (Drake's own simulated iiwa driver: `run.drake_driver`).

    Returns
    -------
    BuiltDiagram
        With no controller and no loggers; the wrist force sensor is the diagram's system
        "wrist_force_sensor"; with a foam that gives way, its tear as `after_step`.
    """
    builder = DiagramBuilder()
    world = add_world(builder, scenario)
    if add_driver is not None:
        add_driver(builder, world.plant)
    diagram = builder.Build()
    diagram.set_name(f"{scenario.name}_driven")
    return BuiltDiagram(
        diagram,
        world.plant,
        None,
        {},
        setup.q0,
        world.sensing.after_step(),
    )


def _add_modular_controller(
    builder, scenario, name, *, plant, tool_frame, setup, contact_force, theta0
):
    """DmpSource -> controller -> J^T f_c + NullSpaceImpedance -> plant, one system per role."""
    task: ArmTask = scenario.task
    task_space = builder.AddSystem(TaskSpaceDynamics(plant, tool_frame, axes=task.axes))
    task_space.set_name("task_space")
    builder.Connect(plant.get_state_output_port(), task_space.plant_state)
    reference = add_reference(builder, scenario, dmp=setup.dmp)
    world = WorldPorts(reference, task_space, contact_force, setup.dmp.start)
    controller = add_controller(builder, scenario, name, world, theta0)
    below_task = builder.AddSystem(
        NullSpaceImpedance(
            plant, tool_frame, setup.tool_orientation, setup.q0, *_below_task_gains(task)
        )
    )
    below_task.set_name("null_space_impedance")
    builder.Connect(plant.get_state_output_port(), below_task.plant_state)
    builder.Connect(task_space.GetOutputPort("null_space_projector"), below_task.projector)
    builder.Connect(task_space.GetOutputPort("joint_gravity"), below_task.gravity)
    torque_map = add_torque_map(
        builder,
        scenario,
        plant=plant,
        controller=controller.system,
        task_space=task_space,
        extra_torque_port=below_task.get_output_port(),
    )
    ports = modular_log_ports(
        plant=plant,
        task_space=task_space,
        reference=reference,
        controller=controller,
        force_port=contact_force,
        torque_map=torque_map,
    )
    return controller, ports, torque_map.GetOutputPort("saturated")


@dc.dataclass
class RealArm:
    """What a robot that is not its model adds to an arm's diagram (`add_real_arm`).

    Attributes
    ----------
    force : OutputPort
        The wrist force as the controller and the safety monitor read it (3, world) [N]:
        the sensor's reading, with its noise and bias when the scenario sets them. The
        logged force (and so the metrics) stays the true one: what the world did.
    measured_state : OutputPort or None
        The plant state as the controller reads it (the velocity estimate), or None for
        the plant's own.
    period : float
        The controller's tick [s].
    """

    force: OutputPort
    measured_state: OutputPort | None
    period: float


def add_real_arm(
    builder: DiagramBuilder, scenario: Scenario, world: ArmWorld, setup: ArmSetup
) -> RealArm:
    """Add what scenario.robot_imperfection sets to an arm's world: the joints' friction
    on the plant, the wrist force sensor's noise and bias, the velocity estimate the
    controller reads. (The controller's own model is set off in `_add_fast_controller`.)

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        With an ArmTask and an imperfect robot.
    world : ArmWorld
        From `add_world`.
    setup : ArmSetup
        Its q0 starts the velocity estimate.

    Returns
    -------
    RealArm
    """
    real, plant = scenario.robot_imperfection, world.plant
    period = real.control_period_s or plant.time_step()
    if real.has_friction:
        friction = builder.AddSystem(
            JointFriction(
                plant.num_positions(),
                real.viscous_friction_Nms_per_rad,
                real.coulomb_friction_Nm,
                real.friction_speed_rad_per_s,
            )
        )
        friction.set_name("joint_friction")
        builder.Connect(plant.get_state_output_port(), friction.plant_state)
        builder.Connect(
            friction.GetOutputPort("generalized_force"),
            plant.get_applied_generalized_force_input_port(),
        )
    force = world.sensor.GetOutputPort("force")
    if real.senses_force:
        force = sensed_force(
            builder,
            force,
            sigma=np.asarray(real.force_noise_N),
            bias=np.asarray(real.force_bias_N),
            seed=real.noise_seed,
            period=period,
            duration=scenario.duration_s,
        )
    measured = None
    if real.velocity_filter_hz:
        estimate = builder.AddSystem(
            velocity_estimate(plant.num_positions(), period, real.velocity_filter_hz, setup.q0)
        )
        builder.Connect(plant.get_state_output_port(), estimate.get_input_port())
        measured = estimate.get_output_port()
    return RealArm(force, measured, period)


def _add_fast_controller(
    builder, scenario, name, *, plant, tool_frame, setup, contact_force, theta0, real_arm=None
):
    """The C++ DMP source -> ControlLoop (one Python call per plant step) -> plant, θ in
    a C++ Integrator fed the loop's held rate (`add_control_loop`); on a `RealArm`, at its
    period, reading its state estimate, with the controller's model set off the arm. A
    6-D controller reads the pose reference and runs the 6-D tick (`worlds.pose`), and
    its desired orientation is logged as "q_tool_d" (`worlds.pose.LOGGED_REFERENCE`)."""
    reference = add_fast_reference(builder, scenario, name, setup)
    tick = fast_tick(scenario, name, plant=plant, setup=setup)
    imperfection = scenario.robot_imperfection
    if imperfection.model_differs:
        set_model_off(
            plant,
            tick.model.context,
            arm_bodies=arm_bodies(plant),
            tool_body=tool_frame.body(),
            link_mass_error=imperfection.link_mass_error,
            tool_mass_error=imperfection.tool_mass_error,
            tool_com_error=np.asarray(imperfection.tool_com_error_m),
        )
    controller, ports, saturated = add_control_loop(
        builder,
        scenario,
        name,
        tick=tick,
        plant=plant,
        reference=reference,
        contact_force=contact_force,
        theta0=theta0,
        initial_position=setup.dmp.start,
        measured_state=real_arm.measured_state if real_arm else None,
        period=real_arm.period if real_arm else None,
        sensed_force=real_arm.force if real_arm else None,
    )
    for port, series in LOGGED_REFERENCE.items():
        if port in dict(tick.reference_ports):
            ports[series] = reference.GetOutputPort(port)
    return controller, ports, saturated


def add_fast_reference(
    builder: DiagramBuilder, scenario: Scenario, controller_name: str, setup: ArmSetup
) -> System:
    """Add the reference the fast path's controller reads: the pose reference for a 6-D
    controller (`worlds.pose.add_pose_reference`), else the compiled DMP source.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        With an ArmTask and a DemonstrationConfig.
    controller_name : str
        A controller with a one-tick law.
    setup : ArmSetup
        The DMPs (and the start orientation a 6-D controller holds without an orientation
        DMP).

    Returns
    -------
    System
        With the output ports of `fast_tick`'s `reference_ports`.
    """
    if controller_kind(scenario, controller_name).pose:
        return add_pose_reference(builder, scenario, setup)
    return add_reference(builder, scenario, dmp=setup.dmp, compiled=True)


def fast_tick(
    scenario: Scenario, controller_name: str, *, plant: MultibodyPlant, setup: ArmSetup
) -> ControlTick | PoseControlTick:
    """The fast path's controller at one instant: `worlds.pose.pose_tick` for a 6-D
    controller, else `arm_tick`.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask.
    controller_name : str
        A controller with a one-tick law.
    plant : MultibodyPlant
        Finalized, with the scenario's models (a world's plant, or a control-side copy).
    setup : ArmSetup
        The start posture and the orientation held below (or by) the task.

    Returns
    -------
    ControlTick or PoseControlTick
    """
    if controller_kind(scenario, controller_name).pose:
        return pose_tick(scenario, controller_name, plant=plant, setup=setup)
    return arm_tick(scenario, controller_name, plant=plant, setup=setup)


def arm_tick(
    scenario: Scenario, controller_name: str, *, plant: MultibodyPlant, setup: ArmSetup
) -> ControlTick:
    """The arm's whole controller at one instant (`systems.arm_tick.arm_control_tick`: the
    compiled two-call tick for the laws it fuses, else `ControlTick`): the controller's law,
    the tool point's task-space terms, the orientation and posture held below the task, and
    the actuators' effort limits.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask; its controller `controller_name` must have a `core.laws` law
        (an Hl-CMP or a constant impedance).
    controller_name : str
        The controller's label.
    plant : MultibodyPlant
        Finalized, with the scenario's models (a world's plant, or a control-side copy).
    setup : ArmSetup
        The start posture and the tool orientation held below the task.

    Returns
    -------
    ControlTick
    """
    task: ArmTask = scenario.task
    tool_frame = scoped_frame(plant, task.tool_frame)
    law = controller_kind(scenario, controller_name).law(
        scenario.controllers[controller_name], scenario
    )
    effort = [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
    return arm_control_tick(
        TaskSpaceModel(plant, tool_frame, axes=task.axes),
        BelowTaskImpedance(
            plant, tool_frame, setup.tool_orientation, setup.q0, *_below_task_gains(task)
        ),
        law,
        effort,
    )


def _below_task_gains(task: ArmTask) -> tuple[float, float, float, float]:
    return (
        task.orientation_stiffness_Nm_per_rad,
        task.orientation_damping_Nms_per_rad,
        task.posture_stiffness_Nm_per_rad,
        task.posture_damping_Nms_per_rad,
    )


def arm_check(plant: MultibodyPlant, task: ArmTask) -> Callable[[float, dict], str | None]:
    """The arm's safety check for the run's SafetyMonitor.

    A problem is a contact force above task.max_contact_force_N, a joint beyond its
    position limit (by more than 1e-3 rad), or some joint torque at its effort limit at
    every check for longer than task.max_saturation_s.

    Parameters
    ----------
    plant : MultibodyPlant
        The diagram's finalized plant: its joint limits and names.
    task : ArmTask
        The safety limits.

    Returns
    -------
    callable(t, values) -> str or None
        Reads values "plant_state", "contact_force" (3, [N]) and "saturated" (the number of
        joints at their effort limit). It keeps the time saturation began, so use one per
        simulation, called in time order.
    """
    lower, upper = plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()
    nq = plant.num_positions()
    names = [
        plant.get_joint(plant.get_joint_actuator(i).joint().index()).name()
        for i in plant.GetJointActuatorIndices()
    ]
    saturation = saturation_check(task.max_saturation_s)

    def check(t, values):
        force = np.linalg.norm(values["contact_force"])
        if force > task.max_contact_force_N:
            return (
                f"contact force {force:.1f} N above max_contact_force_N = "
                f"{task.max_contact_force_N} N"
            )
        q = values["plant_state"][:nq]
        beyond = np.flatnonzero((q < lower - 1e-3) | (q > upper + 1e-3))
        if beyond.size:
            k = beyond[0]
            return f"joint {names[k]} at {q[k]:.3f} rad, beyond its limit ±{upper[k]:.3f} rad"
        return saturation(t, values["saturated"][0])

    return check
