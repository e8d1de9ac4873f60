"""Small functions that assemble a scenario's Drake diagram, one piece at a time.

    reference (DMP source / steps) --x_d, x_d', x_d'', s--> controller --f_c--> J^T map --> plant
    plant state --> TaskSpaceDynamics --x, x', M, C, G, J--> controller, J^T map

Every diagram is the plant + the world's extras + exactly one controller, so runs of
different controllers never share state. Loggers are Drake VectorLogSinks.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.parsing import ModelDirectives, Parser, ProcessModelDirectives
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant
from pydrake.solvers import Solve
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from hlcmp_drake.checks import check_demonstration_feasible
from hlcmp_drake.demos import read_demonstration
from hlcmp_drake.errors import InputError
from hlcmp_drake.dmp import Dmp, DmpSettings, basis_centers_and_widths
from hlcmp_drake.paths import register_package
from hlcmp_drake.scenario import (ArmTask, ConstantImpedanceConfig, DemonstrationConfig,
                                  HlcmpConfig, Scenario, SliderTask, StepReferenceConfig,
                                  VariableImpedanceConfig)
from hlcmp_drake.systems.baselines import ConstantImpedanceController, VariableImpedanceController
from hlcmp_drake.systems.arm import NullSpaceImpedance, ToolContactForce
from hlcmp_drake.systems.environment import UnilateralSpring
from hlcmp_drake.systems.hlcmp_controller import HlcmpController, HlcmpGains
from hlcmp_drake.systems.references import DmpSource, StepReference
from hlcmp_drake.systems.task_space import TaskForceToJointTorque, TaskSpaceDynamics


@dc.dataclass
class BuiltDiagram:
    """A finished diagram and the handles a run needs to read it back."""

    diagram: object
    plant: object
    controller: object
    loggers: dict  # log name -> VectorLogSink
    initial_positions: np.ndarray | None = None   # plant q at t = 0 (None: the model's default)
    monitor: object = None  # callable(root_context) -> problem text or None


def load_models(plant, scenario: Scenario):
    """The scenario's model directives into `plant`, which is then finalized."""
    parser = Parser(plant)
    register_package(parser.package_map())
    try:
        ProcessModelDirectives(ModelDirectives(directives=scenario.directives), plant, parser)
    except RuntimeError as error:
        first = next((line for line in str(error).splitlines() if line.strip()), "")
        hint = " (drake_models is downloaded on first use: is there internet?)" if "drake_models" in str(error) else ""
        raise InputError(f"{scenario.name}: the models could not be loaded{hint}: {first}") from None
    plant.Finalize()


def add_plant(builder, scenario: Scenario):
    """MultibodyPlant + SceneGraph from the scenario's plant config and model directives."""
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, builder)
    load_models(plant, scenario)
    return plant, scene_graph


def fit_demonstration(scenario: Scenario) -> Dmp:
    """Table I step II at start-up: the DMP of the scenario's demonstration file, after
    checking the arm can follow it (checks.check_demonstration_feasible)."""
    reference: DemonstrationConfig = scenario.reference
    t, positions, axes, lines = read_demonstration(reference.file, with_lines=True)
    if axes != ("x", "y", "z")[: len(axes)] or len(axes) != scenario.n_axes:
        raise InputError(f"{reference.file}: has columns {','.join(axes)}, the scenario "
                         f"'{scenario.name}' needs x,y,z")
    if isinstance(scenario.task, ArmTask):
        check_demonstration_feasible(scenario, t, positions, reference.file, lines)
    settings = DmpSettings(n_basis=scenario.basis.n_basis, alpha=reference.alpha,
                           alpha_s=scenario.basis.alpha_s, smoothing_s=reference.smoothing_s)
    return Dmp.fit(t, positions, axes, settings)


def add_reference(builder, scenario: Scenario, dmp: Dmp | None = None):
    """The desired-motion source: set-points, or the DMP (`dmp`) of a demonstration."""
    reference = scenario.reference
    if isinstance(reference, StepReferenceConfig):
        system = StepReference(reference.times_s, reference.positions_m, scenario.duration_s,
                               scenario.basis.alpha_s)
    else:
        system = DmpSource(dmp, tau=reference.duration_s or None)
    system.set_name("reference")
    return builder.AddSystem(system)


def desired_force_schedule(config: VariableImpedanceConfig, reference: StepReferenceConfig, duration):
    """f_d(t): the configured force during the listed reference segments, 0 elsewhere."""
    edges = list(reference.times_s) + [float("inf")]
    windows = [(edges[k], edges[k + 1]) for k in config.force_segments]
    force, zero = np.asarray(config.desired_force_N, dtype=float), np.zeros(len(config.desired_force_N))

    def schedule(t):
        return force if any(start <= t < end for start, end in windows) else zero

    return schedule


def make_controller(name, config, scenario: Scenario, initial_position, theta0=None):
    """The controller system described by one entry of `scenario.controllers`. For an
    Hl-CMP, `theta0` ((theta_k, theta_d, theta_v), each M x N) replaces the configured
    uniform initial weights: a learned skill, or the previous trial's result."""
    m = scenario.n_axes
    if isinstance(config, HlcmpConfig):
        centers, widths = basis_centers_and_widths(scenario.basis.n_basis, scenario.basis.alpha_s)
        gains = HlcmpGains(np.asarray(config.q_k, float), np.asarray(config.q_d, float),
                           np.asarray(config.q_v, float), config.pi, np.asarray(config.gain_l, float))
        n = len(centers)
        if theta0 is None:
            theta0 = np.concatenate([np.full(m * n, config.theta_k0), np.full(m * n, config.theta_d0),
                                     np.full(m * n, config.theta_v0)])
        system = HlcmpController(centers, widths, gains, np.concatenate([np.ravel(t) for t in theta0]))
    elif isinstance(config, ConstantImpedanceConfig):
        system = ConstantImpedanceController(config.stiffness_N_per_m, config.damping_Ns_per_m,
                                             config.pi, config.gain_l)
    elif isinstance(config, VariableImpedanceConfig):
        system = VariableImpedanceController(
            config.mass_kg, config.damping_Ns_per_m, config.free_stiffness_N_per_m, config.sigma,
            config.sample_period_s, config.kp, config.kv,
            desired_force_schedule(config, scenario.reference, scenario.duration_s),
            initial_position)
    else:  # pragma: no cover
        raise TypeError(f"unsupported controller {type(config).__name__}")
    system.set_name(name)
    return system


def connect_controller(builder, controller, reference, task_space):
    """Wire the standard task-space controller inputs."""
    for port in ("desired_position", "desired_velocity", "desired_acceleration", "phase"):
        builder.Connect(reference.GetOutputPort(port), controller.GetInputPort(port))
    for port in ("position", "velocity", "task_inertia", "task_coriolis", "task_gravity"):
        builder.Connect(task_space.GetOutputPort(port), controller.GetInputPort(port))


HLCMP_LOGS = [("Ks", "stiffness"), ("Kd", "damping"), ("v", "feedforward"), ("u", "impedance_force"),
              ("eps", "sliding_error")]


def add_torque_map(builder, scenario, plant, controller, task_space, extra_torque_port=None):
    """tau = J^T f_c (+ the torque below the task, when given) into the plant's actuation."""
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


def add_loggers(builder, scenario, plant, task_space, reference, controller, force_port, torque_map):
    """The timeseries.npz contract's series (and the plant state for the recording), as
    Drake VectorLogSinks at scenario.log_period_s. Returns {series name: logger}."""
    ports = {
        "x": task_space.GetOutputPort("position"),
        "xd": reference.GetOutputPort("desired_position"),
        "f_ext": force_port,
        "fc": controller.GetOutputPort("force"),
        "plant_state": plant.get_state_output_port(),
        "saturated_joints": torque_map.GetOutputPort("saturated"),
    }
    if isinstance(controller, HlcmpController):
        ports.update({name: controller.GetOutputPort(port) for name, port in HLCMP_LOGS})
    loggers = {}
    for name, port in ports.items():
        loggers[name] = LogVectorOutput(port, builder, scenario.log_period_s)
        loggers[name].set_name(f"log_{name}")
    return loggers


def build_slider_diagram(scenario: Scenario, controller_name: str, theta0=None) -> BuiltDiagram:
    """The 1-DOF experiment: one prismatic joint, the unilateral spring, one controller."""
    task: SliderTask = scenario.task
    builder = DiagramBuilder()
    plant, _ = add_plant(builder, scenario)
    frame = plant.GetBodyByName(task.body).body_frame()
    task_space = builder.AddSystem(TaskSpaceDynamics(plant, frame, axes=[task.axis]))
    task_space.set_name("task_space")
    builder.Connect(plant.get_state_output_port(), task_space.plant_state)
    spring = builder.AddSystem(UnilateralSpring(task.surface_position_m,
                                                task.environment_stiffness_N_per_m))
    spring.set_name("environment")
    builder.Connect(plant.get_state_output_port(), spring.plant_state)
    builder.Connect(spring.GetOutputPort("generalized_force"),
                    plant.get_applied_generalized_force_input_port())
    reference = add_reference(builder, scenario)
    initial_position = np.zeros(scenario.n_axes)
    controller = builder.AddSystem(make_controller(
        controller_name, scenario.controllers[controller_name], scenario, initial_position, theta0))
    connect_controller(builder, controller, reference, task_space)
    if isinstance(controller, VariableImpedanceController):
        builder.Connect(spring.GetOutputPort("reaction_force"), controller.external_force)
    torque_map = add_torque_map(builder, scenario, plant, controller, task_space)
    loggers = add_loggers(builder, scenario, plant, task_space, reference, controller,
                          spring.GetOutputPort("reaction_force"), torque_map)
    diagram = builder.Build()
    diagram.set_name(f"{scenario.name}_{controller_name}")
    return BuiltDiagram(diagram, plant, controller, loggers)


@dc.dataclass
class ArmSetup:
    """What every controller's diagram of an arm scenario shares: the fitted DMP, the
    start posture q0 (inverse kinematics) and the tool orientation to hold."""

    dmp: Dmp
    q0: np.ndarray
    tool_orientation: RotationMatrix


def solve_ik_for_tool(plant, task: ArmTask, tip_position, seed):
    """Inverse kinematics on a finalized `plant`: the tool point at `tip_position`, the
    tool's +z along task.tool_direction (or the tool at task.tool_rpy_rad), as close as
    possible to `seed`. Returns q, or None if there is no such posture."""
    frame = plant.GetFrameByName(*_scoped(plant, task.tool_frame))
    ik = InverseKinematics(plant)
    ik.AddPositionConstraint(frame, np.zeros(3), plant.world_frame(),
                             np.asarray(tip_position) - 1e-4, np.asarray(tip_position) + 1e-4)
    if task.tool_rpy_rad:
        ik.AddOrientationConstraint(plant.world_frame(), RotationMatrix(RollPitchYaw(task.tool_rpy_rad)),
                                    frame, RotationMatrix(), 1e-3)
    else:
        ik.AddAngleBetweenVectorsConstraint(plant.world_frame(), np.asarray(task.tool_direction, float),
                                            frame, np.array([0.0, 0.0, 1.0]), 0.0, 1e-3)
    seed = np.asarray(seed, dtype=float)
    ik.get_mutable_prog().AddQuadraticErrorCost(np.eye(len(seed)), seed, ik.q())
    result = Solve(ik.prog(), seed)
    return result.GetSolution(ik.q()) if result.is_success() else None


def solve_start_posture(scenario: Scenario, tip_position):
    """The start posture q0 for the DMP's start (elbow-up seed task.ik_seed_rad), and the
    tool's orientation in the world there."""
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
    return q0, plant.GetFrameByName(*_scoped(plant, task.tool_frame)).CalcRotationMatrixInWorld(context)


def _scoped(plant, scoped_name):
    """('frame', model instance) for 'model::frame'."""
    model, _, name = scoped_name.rpartition("::")
    return (name, plant.GetModelInstanceByName(model)) if model else (name,)


def prepare_arm(scenario: Scenario, dmp: Dmp | None = None) -> ArmSetup:
    """The DMP (`dmp`, e.g. a saved skill's, or fitted to the scenario's demonstration),
    the start posture for it, and the tool orientation to hold."""
    dmp = dmp or fit_demonstration(scenario)
    q0, orientation = solve_start_posture(scenario, dmp.start)
    return ArmSetup(dmp, q0, orientation)


def build_arm_diagram(scenario: Scenario, controller_name: str, setup: ArmSetup,
                      theta0=None) -> BuiltDiagram:
    """The iiwa tasks: DMP source -> controller -> J^T f_c + null-space terms -> plant."""
    task: ArmTask = scenario.task
    builder = DiagramBuilder()
    plant, _ = add_plant(builder, scenario)
    tool_frame = plant.GetFrameByName(*_scoped(plant, task.tool_frame))
    task_space = builder.AddSystem(TaskSpaceDynamics(plant, tool_frame, axes=task.axes))
    task_space.set_name("task_space")
    builder.Connect(plant.get_state_output_port(), task_space.plant_state)
    reference = add_reference(builder, scenario, setup.dmp)
    controller = builder.AddSystem(make_controller(
        controller_name, scenario.controllers[controller_name], scenario, setup.dmp.start, theta0))
    connect_controller(builder, controller, reference, task_space)
    sensor = builder.AddSystem(ToolContactForce(plant, tool_frame.body(), task.axes))
    sensor.set_name("wrist_force_sensor")
    builder.Connect(plant.get_contact_results_output_port(), sensor.contact_results)
    if isinstance(controller, VariableImpedanceController):
        builder.Connect(sensor.GetOutputPort("task_force"), controller.external_force)
    below_task = builder.AddSystem(NullSpaceImpedance(
        plant, tool_frame, setup.tool_orientation, setup.q0,
        task.orientation_stiffness_Nm_per_rad, task.orientation_damping_Nms_per_rad,
        task.posture_stiffness_Nm_per_rad, task.posture_damping_Nms_per_rad))
    below_task.set_name("null_space_impedance")
    builder.Connect(plant.get_state_output_port(), below_task.plant_state)
    builder.Connect(task_space.GetOutputPort("null_space_projector"), below_task.projector)
    builder.Connect(task_space.GetOutputPort("joint_gravity"), below_task.gravity)
    torque_map = add_torque_map(builder, scenario, plant, controller, task_space,
                                below_task.get_output_port())
    loggers = add_loggers(builder, scenario, plant, task_space, reference, controller,
                          sensor.GetOutputPort("task_force"), torque_map)
    diagram = builder.Build()
    diagram.set_name(f"{scenario.name}_{controller_name}")

    return BuiltDiagram(diagram, plant, controller, loggers, setup.q0,
                        arm_monitor(plant, sensor, torque_map, task))


def arm_monitor(plant, sensor, torque_map, task: ArmTask):
    """The arm's safety checks, run after every step: contact force above
    task.max_contact_force_N, a joint beyond its position limit, or any joint held at its
    effort limit for longer than task.max_saturation_s. Returns the problem or None."""
    lower, upper = plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()
    names = [plant.get_joint(plant.get_joint_actuator(i).joint().index()).name()
             for i in plant.GetJointActuatorIndices()]
    saturated_since = [None]

    def monitor(root_context):
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

    return monitor


def diagram_factory(scenario: Scenario, dmp: Dmp | None = None):
    """callable(controller name, theta0=None) -> BuiltDiagram for the scenario's kind of
    world; the work all controllers share (fitting the DMP unless `dmp` is given, inverse
    kinematics) is done once here."""
    if isinstance(scenario.task, ArmTask):
        setup = prepare_arm(scenario, dmp)
        return lambda name, theta0=None: build_arm_diagram(scenario, name, setup, theta0)
    return lambda name, theta0=None: build_slider_diagram(scenario, name, theta0)
