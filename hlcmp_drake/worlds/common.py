"""The pieces every world's diagram shares: the reference, the torque map, the loggers,
and the handles a run needs to read a built diagram back.

    reference (DMP source / steps) --x_d, x_d', x_d'', s--> controller --f_c--> J^T map --> plant
    plant state --> TaskSpaceDynamics --x, x', M, C, G, J--> controller, J^T map

Every diagram is the plant + the world's extras + exactly one controller, so runs of
different controllers never share state. Loggers are Drake VectorLogSinks.
"""

from __future__ import annotations

import dataclasses as dc
import math
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Integrator, LogVectorOutput, MatrixGain, Multiplexer

from hlcmp_drake.config.scenario import DemonstrationConfig, Scenario, StepReferenceConfig
from hlcmp_drake.core import quaternion
from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.io.demos import read_demonstration
from hlcmp_drake.io.errors import InputError, located
from hlcmp_drake.systems.control_loop import ControlLoop, ControlTick
from hlcmp_drake.systems.monitor import SafetyMonitor, plant_state_check
from hlcmp_drake.systems.references import (
    DmpSource,
    StepReference,
    compiled_step_reference,
    linear_dmp_source,
)
from hlcmp_drake.systems.task_space import TaskForceToJointTorque
from hlcmp_drake.worlds.controllers import (
    AddedController,
    controller_kind,
    initial_theta,
    kind_of,
)

if TYPE_CHECKING:
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.systems.framework import Context, Diagram, LeafSystem, OutputPort, System
    from pydrake.systems.primitives import VectorLogSink

    from hlcmp_drake.systems.task_space import TaskSpaceDynamics


@dc.dataclass
class BuiltDiagram:
    """A finished diagram and the handles a run needs to read it back.

    Attributes
    ----------
    diagram : Diagram
        It holds a SafetyMonitor, which stops a simulation at the first problem.
    plant : MultibodyPlant
    controller : AddedController
        The controller's system, its logs and (learning) its theta reader.
    loggers : dict of str to (VectorLogSink, slice)
        One per series of the timeseries.npz contract: its logger and its columns there.
    initial_positions : (nq,) array or None
        Plant positions at t = 0 (None: the model's default).
    after_step : callable(root_context), optional
        What the world must do after every step that no system can (the foam's tear,
        which changes SceneGraph's collision filters).
    """

    diagram: Diagram
    plant: MultibodyPlant
    controller: AddedController | None
    loggers: dict[str, tuple[VectorLogSink, slice]]
    initial_positions: np.ndarray | None = None
    after_step: Callable[[Context], None] | None = None


def read_scenario_demonstration(
    scenario: Scenario,
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...], list[int]]:
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
    t, positions, axes, quaternions, lines = read_demonstration(
        reference.file, with_lines=True, with_orientation=True
    )
    if axes != ("x", "y", "z")[: len(axes)] or len(axes) != scenario.n_axes:
        raise InputError(
            f"{reference.file}: has columns {','.join(axes)}, the scenario "
            f"'{scenario.name}' needs x,y,z"
        )
    translational = any(not kind_of(config).pose for config in scenario.controllers.values())
    if quaternions is not None and translational:
        check_held_orientation(reference.file, quaternions, scenario.task.tool_direction, lines)
    return t, positions, axes, lines


def read_scenario_orientations(scenario: Scenario) -> tuple[np.ndarray, np.ndarray] | None:
    """The demonstrated tool orientations of the scenario's demonstration, if it has them.

    Parameters
    ----------
    scenario : Scenario
        With a DemonstrationConfig reference (its file resolved).

    Returns
    -------
    (t (T,) [s], quaternions (T, 4) w x y z, unit, hemisphere-continuous), or None for a
    position-only demonstration.
    """
    t, _, _, quaternions = read_demonstration(scenario.reference.file, with_orientation=True)
    return None if quaternions is None else (t, quaternions)


# How far a pose demonstration's tool axis may stray from the one the arm holds.
HELD_AXIS_TOLERANCE_RAD = math.radians(1.0)


def check_held_orientation(
    path: str, quaternions: np.ndarray, tool_direction: list[float], lines: list[int]
) -> None:
    """A translational skill follows a pose demonstration's positions only, its tool held
    with +z along `tool_direction`: every demonstrated tool axis must be that one within
    HELD_AXIS_TOLERANCE_RAD, or the demonstration's orientation would be silently ignored.
    (Checked when a scenario has a translational controller; a 6-D one follows the
    demonstrated orientation.)

    Parameters
    ----------
    path : str
        The demonstration, for the message.
    quaternions : (T, 4) array
        The demonstrated tool orientations (w, x, y, z), unit.
    tool_direction : list of float
        The held tool +z, world (any length).
    lines : list of T int
        Each sample's line in the file.

    Raises
    ------
    InputError
        Naming the first line whose tool axis strays further.
    """
    held = np.asarray(tool_direction, float) / np.linalg.norm(tool_direction)
    axes = quaternion.rotate(quaternions, np.array([0.0, 0.0, 1.0]))
    angles = np.arccos(np.clip(axes @ held, -1.0, 1.0))
    stray = np.flatnonzero(angles > HELD_AXIS_TOLERANCE_RAD)
    if stray.size:
        k = int(stray[0])
        raise located(
            path,
            lines[k],
            f"the tool's +z is {math.degrees(angles[k]):.1f} deg from task.tool_direction "
            f"{list(tool_direction)}: a translational skill holds that orientation and "
            f"follows positions only (at most {math.degrees(HELD_AXIS_TOLERANCE_RAD):.0f} deg)",
        )


def add_reference(
    builder: DiagramBuilder,
    scenario: Scenario,
    *,
    dmp: Dmp | None = None,
    compiled: bool = False,
) -> StepReference | DmpSource | Diagram:
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
    compiled : bool
        The source as Drake's C++ systems (`linear_dmp_source`, `compiled_step_reference`:
        no Python per step) instead of the Python `DmpSource` or `StepReference`.

    Returns
    -------
    StepReference or DmpSource or Diagram
        The added system: x_d [m], x_d' [m/s], x_d'' [m/s^2] and the phase s.
    """
    reference = scenario.reference
    if isinstance(reference, StepReferenceConfig):
        step = compiled_step_reference if compiled else StepReference
        system = step(
            reference.times_s, reference.positions_m, scenario.duration_s, scenario.dmp.alpha_s
        )
    elif compiled:
        system = linear_dmp_source(dmp, scenario.duration_s, tau=reference.duration_s or None)
    else:
        system = DmpSource(dmp, tau=reference.duration_s or None)
    system.set_name("reference")
    return builder.AddSystem(system)


def sample_reference(
    scenario: Scenario,
    add_source: Callable[[DiagramBuilder], System],
    ports: Sequence[str],
    period: float,
    duration: float,
) -> tuple[np.ndarray, ...]:
    """A reference source's `ports` sampled every `period` from 0 to `duration`, the
    source simulated alone with the scenario's simulator config: the values a diagram's
    controller would read at its ticks, for a controller outside any diagram (`hlcmp
    serve`).

    Parameters
    ----------
    scenario : Scenario
        Its simulator config.
    add_source : callable(builder) -> System
        Adds the reference (e.g. `add_reference`'s compiled DMP source) and returns it.
    ports : sequence of str
        Its output ports to sample, e.g. a tick's `reference_ports` names.
    period : float
        The tick period [s].
    duration : float
        The last tick's time [s].

    Returns
    -------
    tuple of arrays
        One (K, size) array per port, in the order of `ports`, at the K ticks
        k * period, k = 0 ... round(duration / period).
    """
    builder = DiagramBuilder()
    source = add_source(builder)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator_config, simulator)
    context = source.GetMyContextFromRoot(simulator.get_mutable_context())
    outputs = [source.GetOutputPort(port) for port in ports]
    samples = [[] for _ in ports]
    for k in range(int(round(duration / period)) + 1):
        simulator.AdvanceTo(k * period)
        for values, port in zip(samples, outputs):
            values.append(port.Eval(context).copy())
    return tuple(np.array(values) for values in samples)


def add_torque_map(
    builder: DiagramBuilder,
    scenario: Scenario,
    *,
    plant: MultibodyPlant,
    controller: LeafSystem,
    task_space: TaskSpaceDynamics,
    extra_torque_port: OutputPort | None = None,
) -> TaskForceToJointTorque:
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
    torque_map = builder.AddSystem(
        TaskForceToJointTorque(scenario.n_axes, effort, extra_torque=extra_torque_port is not None)
    )
    torque_map.set_name("task_force_to_joint_torque")
    builder.Connect(controller.GetOutputPort("force"), torque_map.force)
    builder.Connect(task_space.GetOutputPort("jacobian"), torque_map.jacobian)
    if extra_torque_port is not None:
        builder.Connect(extra_torque_port, torque_map.extra)
    builder.Connect(torque_map.GetOutputPort("joint_torque"), plant.get_actuation_input_port())
    return torque_map


def add_control_loop(
    builder: DiagramBuilder,
    scenario: Scenario,
    name: str,
    *,
    tick: ControlTick,
    plant: MultibodyPlant,
    reference: System,
    contact_force: OutputPort,
    theta0: tuple[np.ndarray, ...] | None,
    initial_position: np.ndarray,
    measured_state: OutputPort | None = None,
    period: float | None = None,
    sensed_force: OutputPort | None = None,
) -> tuple[AddedController, dict, OutputPort]:
    """A world's fast path: `tick` as a `ControlLoop` (one Python call per plant step)
    between the reference and the plant's actuation, the law's state θ in a C++
    Integrator fed the loop's held rate.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
    name : str
        The controller's label (the loop's name).
    tick : ControlTick or PoseControlTick
        The world's controller at one instant; its `reference_ports` are read from
        `reference` by name, its `extra_series` logged.
    plant : MultibodyPlant
    reference : System
        The compiled reference: x_d, x_d', x_d'', s.
    contact_force : OutputPort
        The measured environment force (M,) [N]: logged as f_ext, and read by a law that
        reads it.
    theta0 : tuple of (M, N) arrays, optional
        A learner's initial weights.
    initial_position : (M,) array
        The task-space position at t = 0 [m] (a variable impedance's x_c(0)).
    measured_state : OutputPort, optional
        The plant state as the controller reads it (a driver's estimate); default the
        plant's state.
    period : float, optional
        The controller's tick [s]; default the plant's time step.
    sensed_force : OutputPort, optional
        The force a law that reads it gets (a sensor's reading, noise and bias in it)
        (M,) [N]; default `contact_force`, which is logged either way.

    Returns
    -------
    controller : AddedController
    ports : dict
        {series name: port or (port, columns)} of the timeseries.npz contract.
    saturated : OutputPort
        The number of saturated joints, for the safety monitor.
    """
    config = scenario.controllers[name]
    kind = controller_kind(scenario, name)
    law = tick.law
    loop = builder.AddSystem(ControlLoop(tick, period or plant.time_step()))
    loop.set_name(name)
    if measured_state is None:
        measured_state = plant.get_state_output_port()
    builder.Connect(measured_state, loop.plant_state)
    for port, _ in tick.reference_ports:
        builder.Connect(reference.GetOutputPort(port), loop.GetInputPort(port))
    builder.Connect(loop.GetOutputPort("joint_torque"), plant.get_actuation_input_port())
    if loop.external_force is not None:
        builder.Connect(
            contact_force if sensed_force is None else sensed_force, loop.external_force
        )
    read_theta = None
    if law.theta_size:
        integrator = builder.AddSystem(Integrator(law.theta_size))
        integrator.set_name(f"{name}_theta")
        integrator.set_default_integral_value(
            initial_theta(config, scenario, theta0)
            if law.learns
            else law.initial_state(initial_position)
        )
        builder.Connect(loop.GetOutputPort("theta_rate"), integrator.get_input_port())
        builder.Connect(integrator.get_output_port(), loop.GetInputPort("theta"))

        def read_weights(root_context):
            flat = (
                integrator.GetMyContextFromRoot(root_context)
                .get_continuous_state_vector()
                .CopyToVector()
            )
            return law.unflatten(flat)

        read_theta = read_weights if law.learns else None
    logs = loop.GetOutputPort("logs")
    controller = AddedController(
        loop,
        {series: (logs, loop.log_columns[field]) for field, series in kind.logs.items()},
        read_theta,
    )
    ports = {
        "x": (logs, loop.log_columns["position"]),
        "xd": reference.GetOutputPort("desired_position"),
        "f_ext": contact_force,
        "fc": (logs, loop.log_columns["force"]),
        "plant_state": plant.get_state_output_port(),
        "saturated_joints": (logs, loop.log_columns["saturated"]),
        **controller.logs,
        **{series: (logs, loop.log_columns[field]) for field, series in tick.extra_series.items()},
    }
    # The saturated-joint count alone, for the safety monitor (a C++ selection).
    select = builder.AddSystem(MatrixGain(np.eye(logs.size())[loop.log_columns["saturated"]]))
    select.set_name("saturated_joints")
    builder.Connect(logs, select.get_input_port())
    return controller, ports, select.get_output_port()


def modular_log_ports(
    *,
    plant: MultibodyPlant,
    task_space: TaskSpaceDynamics,
    reference: StepReference | DmpSource,
    controller: AddedController,
    force_port: OutputPort,
    torque_map: TaskForceToJointTorque,
) -> dict[str, OutputPort]:
    """The ports of the timeseries.npz contract's series in a diagram of modular systems.

    Parameters
    ----------
    plant : MultibodyPlant
        Its state is logged (for the recording).
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
    dict of str to OutputPort
        {series name: port}: x, xd, f_ext, fc, plant_state, saturated_joints and the
        controller's own series.
    """
    return {
        "x": task_space.GetOutputPort("position"),
        "xd": reference.GetOutputPort("desired_position"),
        "f_ext": force_port,
        "fc": controller.system.GetOutputPort("force"),
        "plant_state": plant.get_state_output_port(),
        "saturated_joints": torque_map.GetOutputPort("saturated"),
        **controller.logs,
    }


def add_loggers(
    builder: DiagramBuilder, scenario: Scenario, ports: dict
) -> dict[str, tuple[VectorLogSink, slice]]:
    """Log every series at scenario.log_period_s with one Drake VectorLogSink.

    The distinct ports side by side in a Multiplexer, logged together (named "log"): one
    periodic event for the simulator to schedule every step and one to publish every
    sample, where a logger per port made one each (docs/performance.md, "One logger").
    Several series may be column ranges of one port.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        Its log_period_s [s].
    ports : dict of str to OutputPort or (OutputPort, slice)
        {series name: the port, or the port and the series' columns in it (a step of 1)}.

    Returns
    -------
    dict of str to (VectorLogSink, slice)
        {series name: the logger and the series' columns in what it logs}.
    """
    distinct: dict = {}  # (system, port) -> (port, its first column in the logged vector)
    placed = {}
    for name, port in ports.items():
        port, columns = port if isinstance(port, tuple) else (port, slice(None))
        key = (port.get_system().get_name(), port.get_name())
        if key not in distinct:
            distinct[key] = (port, sum(p.size() for p, _ in distinct.values()))
        first = distinct[key][1]
        start, stop, step = columns.indices(port.size())
        if step != 1:
            raise ValueError(f"series '{name}': columns {columns} need a step of 1")
        placed[name] = slice(first + start, first + stop)
    if len(distinct) == 1:
        ((logged, _),) = distinct.values()
    else:
        mux = builder.AddSystem(Multiplexer([p.size() for p, _ in distinct.values()]))
        mux.set_name("logged_series")
        for k, (port, _) in enumerate(distinct.values()):
            builder.Connect(port, mux.get_input_port(k))
        logged = mux.get_output_port(0)
    logger = LogVectorOutput(logged, builder, scenario.log_period_s)
    logger.set_name("log")
    return {name: (logger, columns) for name, columns in placed.items()}


def add_safety_monitor(
    builder: DiagramBuilder,
    scenario: Scenario,
    plant: MultibodyPlant,
    *,
    extra_inputs: dict | None = None,
    extra_check: Callable[[float, dict], str | None] | None = None,
) -> SafetyMonitor:
    """Add the run's SafetyMonitor: a finite plant state with positions within
    scenario.max_abs_position_m, then the world's own checks.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        Its max_abs_position_m.
    plant : MultibodyPlant
        Its state output is checked.
    extra_inputs : dict of str to OutputPort, optional
        More ports the world's check reads, by the name it reads them under.
    extra_check : callable(t, values) -> str or None, optional
        The world's check (see `SafetyMonitor`); values holds "plant_state" and the extra inputs.

    Returns
    -------
    SafetyMonitor
        The added system, named "safety_monitor".
    """
    extra_inputs = extra_inputs or {}
    state_check = plant_state_check(plant.num_positions(), scenario.max_abs_position_m)

    def check(t, values):
        problem = state_check(values["plant_state"])
        return problem if problem or extra_check is None else extra_check(t, values)

    sizes = {
        "plant_state": plant.num_multibody_states(),
        **{n: p.size() for n, p in extra_inputs.items()},
    }
    monitor = builder.AddSystem(SafetyMonitor(sizes, check))
    monitor.set_name("safety_monitor")
    builder.Connect(plant.get_state_output_port(), monitor.GetInputPort("plant_state"))
    for name, port in extra_inputs.items():
        builder.Connect(port, monitor.GetInputPort(name))
    return monitor
