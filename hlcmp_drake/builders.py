"""Small functions that assemble a scenario's Drake diagram, one piece at a time.

    reference (DMP source / steps) --x_d, x_d', x_d'', s--> controller --f_c--> J^T map --> plant
    plant state --> TaskSpaceDynamics --x, x', M, C, G, J--> controller, J^T map

Every diagram is the plant + the world's extras + exactly one controller, so runs of
different controllers never share state. Loggers are Drake VectorLogSinks.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.multibody.parsing import ModelDirectives, Parser, ProcessModelDirectives
from pydrake.multibody.plant import AddMultibodyPlant
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from hlcmp_drake.dmp import basis_centers_and_widths
from hlcmp_drake.paths import register_package
from hlcmp_drake.scenario import (ConstantImpedanceConfig, HlcmpConfig, Scenario, SliderTask,
                                  StepReferenceConfig, VariableImpedanceConfig)
from hlcmp_drake.systems.baselines import ConstantImpedanceController, VariableImpedanceController
from hlcmp_drake.systems.environment import UnilateralSpring
from hlcmp_drake.systems.hlcmp_controller import HlcmpController, HlcmpGains
from hlcmp_drake.systems.references import StepReference
from hlcmp_drake.systems.task_space import TaskForceToJointTorque, TaskSpaceDynamics


@dc.dataclass
class BuiltDiagram:
    """A finished diagram and the handles a run needs to read it back."""

    diagram: object
    plant: object
    controller: object
    loggers: dict  # log name -> VectorLogSink


def add_plant(builder, scenario: Scenario):
    """MultibodyPlant + SceneGraph from the scenario's plant config and model directives."""
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, builder)
    parser = Parser(plant)
    register_package(parser.package_map())
    ProcessModelDirectives(ModelDirectives(directives=scenario.directives), plant, parser)
    plant.Finalize()
    return plant, scene_graph


def add_reference(builder, scenario: Scenario):
    reference = scenario.reference
    if isinstance(reference, StepReferenceConfig):
        system = StepReference(reference.times_s, reference.positions_m, scenario.duration_s,
                               scenario.basis.alpha_s)
    else:  # pragma: no cover - the schema admits only the types above
        raise TypeError(f"unsupported reference {type(reference).__name__}")
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


def make_controller(name, config, scenario: Scenario, initial_position):
    """The controller system described by one entry of `scenario.controllers`."""
    m = scenario.n_axes
    if isinstance(config, HlcmpConfig):
        centers, widths = basis_centers_and_widths(scenario.basis.n_basis, scenario.basis.alpha_s)
        gains = HlcmpGains(np.asarray(config.q_k, float), np.asarray(config.q_d, float),
                           np.asarray(config.q_v, float), config.pi, np.asarray(config.gain_l, float))
        n = len(centers)
        theta0 = np.concatenate([np.full(m * n, config.theta_k0), np.full(m * n, config.theta_d0),
                                 np.full(m * n, config.theta_v0)])
        system = HlcmpController(centers, widths, gains, theta0)
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


def log(builder, loggers, name, port, period):
    logger = LogVectorOutput(port, builder, period)
    logger.set_name(f"log_{name.replace('/', '_')}")
    loggers[name] = logger


def build_slider_diagram(scenario: Scenario, controller_name: str) -> BuiltDiagram:
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
        controller_name, scenario.controllers[controller_name], scenario, initial_position))
    connect_controller(builder, controller, reference, task_space)
    if isinstance(controller, VariableImpedanceController):
        builder.Connect(spring.GetOutputPort("reaction_force"), controller.external_force)
    effort = [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
    torque_map = builder.AddSystem(TaskForceToJointTorque(scenario.n_axes, effort))
    torque_map.set_name("task_force_to_joint_torque")
    builder.Connect(controller.GetOutputPort("force"), torque_map.force)
    builder.Connect(task_space.GetOutputPort("jacobian"), torque_map.jacobian)
    builder.Connect(torque_map.get_output_port(), plant.get_actuation_input_port())
    loggers = {}
    period = scenario.log_period_s
    log(builder, loggers, "x", task_space.GetOutputPort("position"), period)
    log(builder, loggers, "xd", reference.GetOutputPort("desired_position"), period)
    log(builder, loggers, "f_ext", spring.GetOutputPort("reaction_force"), period)
    log(builder, loggers, "fc", controller.GetOutputPort("force"), period)
    log(builder, loggers, "plant_state", plant.get_state_output_port(), period)
    if isinstance(controller, HlcmpController):
        for name, port in [("Ks", "stiffness"), ("Kd", "damping"), ("v", "feedforward"),
                           ("eps", "sliding_error")]:
            log(builder, loggers, name, controller.GetOutputPort(port), period)
    diagram = builder.Build()
    diagram.set_name(f"{scenario.name}_{controller_name}")
    return BuiltDiagram(diagram, plant, controller, loggers)
