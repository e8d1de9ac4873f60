"""The slider world (the paper's 1-DOF comparison, Fig. 13): one prismatic joint whose
body presses into an elastic object, a unilateral spring at the surface."""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.scenario import Scenario, SliderTask
from hlcmp_drake.systems.control_loop import ControlTick
from hlcmp_drake.systems.environment import UnilateralSpring
from hlcmp_drake.systems.monitor import saturation_check
from hlcmp_drake.systems.slider_tick import slider_control_tick
from hlcmp_drake.systems.task_space import PrismaticTaskModel, TaskSpaceDynamics
from hlcmp_drake.worlds.common import (
    BuiltDiagram,
    add_control_loop,
    add_loggers,
    add_reference,
    add_safety_monitor,
    add_torque_map,
    modular_log_ports,
)
from hlcmp_drake.worlds.controllers import WorldPorts, add_controller, controller_kind
from hlcmp_drake.worlds.models import add_plant

if TYPE_CHECKING:
    from hlcmp_drake.core.dmp import Dmp
    from hlcmp_drake.core.orientation_dmp import OrientationDmp


def prepare(
    scenario: Scenario, dmp: Dmp | None = None, orientation_dmp: OrientationDmp | None = None
) -> None:
    """Nothing is shared between the slider's diagrams (no DMP, no start posture).

    Parameters
    ----------
    scenario : Scenario
        Unused (the same signature as the arm world's `prepare`).
    dmp : Dmp, optional
        Unused.
    orientation_dmp : OrientationDmp, optional
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
    """The 1-DOF diagram: the slider plant, the unilateral spring, one controller, put in
    as task.control_path says: "fast" (one `ControlLoop` call per plant step) or "modular".

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
        The diagram, with the plant's default positions, the plant-state safety checks and
        the saturation watchdog (`slider_check`).
    """
    task: SliderTask = scenario.task
    builder = DiagramBuilder()
    plant, _ = add_plant(builder, scenario)
    frame = plant.GetBodyByName(task.body).body_frame()
    spring = builder.AddSystem(
        UnilateralSpring(task.surface_position_m, task.environment_stiffness_N_per_m)
    )
    spring.set_name("environment")
    builder.Connect(plant.get_state_output_port(), spring.plant_state)
    builder.Connect(
        spring.GetOutputPort("generalized_force"), plant.get_applied_generalized_force_input_port()
    )
    reaction = spring.GetOutputPort("reaction_force")
    start = np.zeros(scenario.n_axes)
    if task.control_path == "fast":
        controller, log_ports, saturated = add_control_loop(
            builder,
            scenario,
            controller_name,
            tick=slider_tick(scenario, controller_name, plant=plant),
            plant=plant,
            reference=add_reference(builder, scenario, compiled=True),
            contact_force=reaction,
            theta0=theta0,
            initial_position=start,
        )
    else:
        controller, log_ports, saturated = _add_modular_controller(
            builder, scenario, controller_name, plant, frame, reaction, start, theta0
        )
    add_safety_monitor(
        builder,
        scenario,
        plant,
        extra_inputs={"saturated": saturated},
        extra_check=slider_check(task),
    )
    loggers = add_loggers(builder, scenario, log_ports)
    diagram = builder.Build()
    diagram.set_name(f"{scenario.name}_{controller_name}")
    return BuiltDiagram(diagram, plant, controller, loggers)


def slider_tick(scenario: Scenario, controller_name: str, *, plant: MultibodyPlant) -> ControlTick:
    """The slider's whole controller at one instant (`systems.slider_tick.slider_control_tick`:
    one compiled call for the laws it fuses, else `ControlTick`): the controller's law
    on the body's task-space terms (`PrismaticTaskModel`), nothing below the task, the
    actuator's effort limit.

    Parameters
    ----------
    scenario : Scenario
        With a SliderTask; its controller `controller_name` must have a `core.laws` law.
    controller_name : str
        The controller's label.
    plant : MultibodyPlant
        Finalized, with the scenario's slider.

    Returns
    -------
    ControlTick
    """
    task: SliderTask = scenario.task
    frame = plant.GetBodyByName(task.body).body_frame()
    effort = [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
    law = controller_kind(scenario, controller_name).law(
        scenario.controllers[controller_name], scenario
    )
    return slider_control_tick(PrismaticTaskModel(plant, frame, axes=[task.axis]), law, effort)


def slider_check(task: SliderTask) -> Callable[[float, dict], str | None]:
    """The slider's own safety check for the run's SafetyMonitor (after the plant-state
    checks every world has): the joint force at its effort limit at every check for longer
    than task.max_saturation_s.

    Parameters
    ----------
    task : SliderTask
        Its max_saturation_s.

    Returns
    -------
    callable(t, values) -> str or None
        Reads values "saturated" (the number of joints at their effort limit). It keeps the
        time saturation began, so use one per simulation, called in time order.
    """
    saturation = saturation_check(task.max_saturation_s, "joint forces")

    def check(t, values):
        return saturation(t, values["saturated"][0])

    return check


def _add_modular_controller(builder, scenario, name, plant, frame, reaction, start, theta0):
    """TaskSpaceDynamics -> the controller's modular system -> the J^T torque map; returns
    the controller, its log ports and the map's number of saturated joints."""
    task_space = builder.AddSystem(TaskSpaceDynamics(plant, frame, axes=[scenario.task.axis]))
    task_space.set_name("task_space")
    builder.Connect(plant.get_state_output_port(), task_space.plant_state)
    reference = add_reference(builder, scenario)
    world = WorldPorts(reference, task_space, reaction, start)
    controller = add_controller(builder, scenario, name, world, theta0)
    torque_map = add_torque_map(
        builder, scenario, plant=plant, controller=controller.system, task_space=task_space
    )
    log_ports = modular_log_ports(
        plant=plant,
        task_space=task_space,
        reference=reference,
        controller=controller,
        force_port=reaction,
        torque_map=torque_map,
    )
    return controller, log_ports, torque_map.GetOutputPort("saturated")
