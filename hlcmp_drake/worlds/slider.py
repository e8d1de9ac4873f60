"""The slider world (the paper's 1-DOF comparison, Fig. 13): one prismatic joint whose
body presses into an elastic object, a unilateral spring at the surface."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.scenario import Scenario, SliderTask
from hlcmp_drake.systems.environment import UnilateralSpring
from hlcmp_drake.systems.task_space import TaskSpaceDynamics
from hlcmp_drake.worlds.common import (
    BuiltDiagram,
    add_loggers,
    add_reference,
    add_safety_monitor,
    add_torque_map,
    modular_log_ports,
)
from hlcmp_drake.worlds.controllers import WorldPorts, add_controller
from hlcmp_drake.worlds.models import add_plant

if TYPE_CHECKING:
    from hlcmp_drake.core.dmp import Dmp


def prepare(scenario: Scenario, dmp: Dmp | None = None) -> None:
    """Nothing is shared between the slider's diagrams (no DMP, no start posture).

    Parameters
    ----------
    scenario : Scenario
        Unused (the same signature as the arm world's `prepare`).
    dmp : Dmp, optional
        Unused.

    Returns
    -------
    None
        The `setup` that `build` takes.
    """
    return None


def build(
    scenario: Scenario,
    controller_name: str,
    setup: None = None,
    *,
    theta0: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> BuiltDiagram:
    """The 1-DOF diagram: the slider plant, the unilateral spring, one controller.

    Parameters
    ----------
    scenario : Scenario
        With a SliderTask and a StepReferenceConfig.
    controller_name, theta0
        As for `hlcmp_drake.worlds.arm.build`.
    setup : None
        Unused (the arm's shared set-up has no slider counterpart).

    Returns
    -------
    BuiltDiagram
        The diagram, with the plant's default positions and the plant-state safety checks.
    """
    task: SliderTask = scenario.task
    builder = DiagramBuilder()
    plant, _ = add_plant(builder, scenario)
    frame = plant.GetBodyByName(task.body).body_frame()
    task_space = builder.AddSystem(TaskSpaceDynamics(plant, frame, axes=[task.axis]))
    task_space.set_name("task_space")
    builder.Connect(plant.get_state_output_port(), task_space.plant_state)
    spring = builder.AddSystem(
        UnilateralSpring(task.surface_position_m, task.environment_stiffness_N_per_m)
    )
    spring.set_name("environment")
    builder.Connect(plant.get_state_output_port(), spring.plant_state)
    builder.Connect(
        spring.GetOutputPort("generalized_force"), plant.get_applied_generalized_force_input_port()
    )
    reference = add_reference(builder, scenario)
    world = WorldPorts(
        reference, task_space, spring.GetOutputPort("reaction_force"), np.zeros(scenario.n_axes)
    )
    controller = add_controller(builder, scenario, controller_name, world, theta0)
    torque_map = add_torque_map(
        builder, scenario, plant=plant, controller=controller.system, task_space=task_space
    )
    add_safety_monitor(builder, scenario, plant)
    loggers = add_loggers(
        builder,
        scenario,
        modular_log_ports(
            plant=plant,
            task_space=task_space,
            reference=reference,
            controller=controller,
            force_port=world.contact_force,
            torque_map=torque_map,
        ),
    )
    diagram = builder.Build()
    diagram.set_name(f"{scenario.name}_{controller_name}")
    return BuiltDiagram(diagram, plant, controller, loggers)
