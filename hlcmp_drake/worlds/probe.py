"""The probe world: a scenario's tool and objects without the arm, the tool on a stiff
prescribed-motion carriage (three prismatic joints held by Drake's PD actuators) -- welded
to it, or on a wrist about the tool point (three revolute joints, PD-held, stiff or free)
-- so that the world itself can be measured with no controller under test (`hlcmp probe`)."""

from __future__ import annotations

import dataclasses as dc
from typing import Callable

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    PdControllerGains,
    PrismaticJoint,
    RevoluteJoint,
    RotationalInertia,
    SpatialInertia,
)
from pydrake.systems.framework import Context, DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from hlcmp_drake.config.models import tool_mount
from hlcmp_drake.config.scenario import ArmTask, ProbeConfig, Scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.worlds.extras import add_tool_sensing
from hlcmp_drake.worlds.models import add_plant, scoped_frame

CARRIAGE_STIFFNESS_N_PER_M = 1.0e6  # stiff enough that contact forces of 20 N move it by 20 um
CARRIAGE_MASS_KG = 0.05


@dc.dataclass
class ProbeWorld:
    """A built probe: the diagram, its plant, the carriage's path and the loggers of the
    tool point's state [q (3), v (3)] and of the force on the tool (3, world); with a wrist,
    the logger of its joint angles and rates [q (3), v (3)] and the tool's start
    orientation."""

    diagram: object
    plant: object
    waypoints: np.ndarray  # (K, 3) tool point positions [m]
    times: np.ndarray  # (K,) when the carriage is at each [s]
    push: tuple  # (start time, end time) of the measured push [s]
    state_log: object
    force_log: object
    after_step: Callable[[Context], None] | None  # the physics extras' (e.g. the tear)
    wrist_log: object = None
    tool_rotation: RotationMatrix | None = None  # the tool frame in the world at wrist angles 0


def _without_arm(scenario: Scenario, arm: str) -> tuple[list, str]:
    """The scenario's directives less the arm (its model, welds, collision filters), and
    the tool's frame that was welded to the arm."""
    kept, mount = [], tool_mount(scenario.directives, arm)
    for directive in scenario.directives:
        model, weld, group = (
            directive.add_model,
            directive.add_weld,
            directive.add_collision_filter_group,
        )
        if model is not None and model.name == arm:
            continue
        if weld is not None and (
            weld.parent.startswith(f"{arm}::") or weld.child.startswith(f"{arm}::")
        ):
            continue
        if group is not None and any(m.startswith(f"{arm}::") for m in group.members):
            continue
        kept.append(directive)
    if mount is None:
        raise InputError(
            f"scenario '{scenario.name}': probe.arm_model '{arm}' has no tool welded to it"
        )
    return kept, mount


def tool_orientation(task: ArmTask, tilt_rad: float = 0.0) -> RotationMatrix:
    """The tool's orientation in the world: task.tool_rpy_rad, or +z along
    task.tool_direction; then tilted by `tilt_rad` about the world y axis.

    Parameters
    ----------
    task : ArmTask
    tilt_rad : float
        A deliberate tilt [rad], to show whether the contact depends on it.
    """
    if task.tool_rpy_rad:
        rotation = RotationMatrix(RollPitchYaw(task.tool_rpy_rad))
    else:
        rotation = RotationMatrix.MakeFromOneVector(np.asarray(task.tool_direction, float), 2)
    return RotationMatrix.MakeYRotation(tilt_rad) @ rotation


def probe_path(probe: ProbeConfig, speed: float) -> tuple[np.ndarray, np.ndarray, tuple]:
    """The carriage's waypoints: start, the approach's end, the push's end, and back to
    where the push started; the times at `speed` [m/s] and the push's time window.

    Parameters
    ----------
    probe : ProbeConfig
    speed : float
        The carriage's speed [m/s].
    """
    start = np.asarray(probe.start_m, float)
    approach = np.asarray(probe.approach_m or [0.0, 0.0, 0.0], float)
    push = np.asarray(probe.push_m, float)
    points = [start, start + approach, start + approach + push, start + approach]
    if not np.any(approach):  # no approach: the push starts at the start
        points = [start, start + push, start]
    points = np.array(points)
    times = np.concatenate(
        [[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1) / speed)]
    )
    push_index = 0 if len(points) == 3 else 1
    return points, times, (times[push_index], times[push_index + 1])


def build_probe(
    scenario: Scenario, speed: float | None = None, tilt_rad: float | None = None
) -> ProbeWorld:
    """The probe diagram of an arm scenario.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask and a `probe` section (start_m, push_m, ...).
    speed : float, optional
        The carriage's speed [m/s] (default probe.speed_m_per_s).
    tilt_rad : float, optional
        Tilt of the tool about the world y axis [rad] (default probe.tilt_rad).
    """
    task, probe = scenario.task, scenario.probe
    if not isinstance(task, ArmTask) or not probe.start_m or not probe.push_m:
        raise InputError(
            f"scenario '{scenario.name}' has no probe: it needs an arm task and probe.start_m, "
            "probe.push_m"
        )
    speed = probe.speed_m_per_s if speed is None else speed
    tilt_rad = probe.tilt_rad if tilt_rad is None else tilt_rad
    directives, mount = _without_arm(scenario, probe.arm_model)
    builder = DiagramBuilder()
    plant, scene_graph = add_plant(
        builder, dc.replace(scenario, directives=directives), finalize=False
    )
    plant.mutable_gravity_field().set_gravity_vector(
        [0.0, 0.0, 0.0]
    )  # the carriage carries contact only
    instance = plant.AddModelInstance("probe_carriage")
    inertia = SpatialInertia.MakeFromCentralInertia(
        CARRIAGE_MASS_KG, np.zeros(3), RotationalInertia(1e-5, 1e-5, 1e-5)
    )
    parent = plant.world_body()
    for axis in range(
        3
    ):  # carriage joints along world x, y, z: their positions are the tool point's
        body = plant.AddRigidBody(f"carriage_{'xyz'[axis]}", instance, inertia)
        joint = plant.AddJoint(
            PrismaticJoint(
                f"carriage_{'xyz'[axis]}",
                parent.body_frame(),
                body.body_frame(),
                np.eye(3)[axis],
                -10.0,
                10.0,
            )
        )
        actuator = plant.AddJointActuator(f"carriage_{'xyz'[axis]}", joint)
        actuator.set_controller_gains(
            PdControllerGains(
                p=CARRIAGE_STIFFNESS_N_PER_M, d=2.0 * np.sqrt(CARRIAGE_STIFFNESS_N_PER_M * 0.5)
            )
        )
        parent = body
    tool_point = scoped_frame(plant, task.tool_frame)
    mount_frame = scoped_frame(plant, mount)
    X_mount_point = (
        mount_frame.GetFixedPoseInBodyFrame().inverse() @ tool_point.GetFixedPoseInBodyFrame()
    )
    rotation = tool_orientation(task, tilt_rad)
    wrist = bool(probe.wrist_stiffness_Nm_per_rad)
    if wrist:
        parent = _add_wrist(plant, parent, rotation, probe)
    X_carriage_mount = (
        X_mount_point.inverse() if wrist else RigidTransform(rotation) @ X_mount_point.inverse()
    )
    plant.WeldFrames(parent.body_frame(), mount_frame, X_carriage_mount)
    plant.Finalize()

    points, times, push = probe_path(probe, speed)
    trajectory = PiecewisePolynomial.FirstOrderHold(times, points.T)
    source = builder.AddSystem(TrajectorySource(trajectory, output_derivative_order=1))
    builder.Connect(source.get_output_port(), plant.get_desired_state_input_port(instance))
    sensing = add_tool_sensing(builder, plant, scene_graph, task, tool_point)
    sensor = sensing.sensor
    period = plant.time_step()
    state_log = LogVectorOutput(plant.get_state_output_port(instance), builder, period)
    force_log = LogVectorOutput(sensor.GetOutputPort("force"), builder, period)
    wrist_log = None
    if wrist:
        wrist_instance = plant.GetModelInstanceByName(WRIST_INSTANCE)
        hold = builder.AddSystem(ConstantVectorSource(np.zeros(6)))  # every angle 0, at rest
        builder.Connect(hold.get_output_port(), plant.get_desired_state_input_port(wrist_instance))
        wrist_log = LogVectorOutput(plant.get_state_output_port(wrist_instance), builder, period)
    diagram = builder.Build()
    diagram.set_name(f"{scenario.name}_probe")
    return ProbeWorld(
        diagram,
        plant,
        points,
        times,
        push,
        state_log,
        force_log,
        sensing.after_step(),
        wrist_log,
        rotation if wrist else None,
    )


WRIST_INSTANCE = "probe_wrist"


def _add_wrist(plant, carriage, rotation: RotationMatrix, probe: ProbeConfig):
    """Three revolute joints about the tool point, along the tool frame's x, y, z at the
    start (`rotation`), each held at 0 by a PD actuator of probe.wrist_stiffness_Nm_per_rad
    and probe.wrist_damping_Nms_per_rad; returns the last joint's body, whose frame is the
    tool frame at the tool point."""
    instance = plant.AddModelInstance(WRIST_INSTANCE)
    inertia = SpatialInertia.MakeFromCentralInertia(
        CARRIAGE_MASS_KG, np.zeros(3), RotationalInertia(1e-6, 1e-6, 1e-6)
    )
    parent_frame = plant.AddFrame(
        FixedOffsetFrame("wrist_base", carriage.body_frame(), RigidTransform(rotation))
    )
    body = carriage
    for axis, stiffness in enumerate(probe.wrist_stiffness_Nm_per_rad):
        name = f"wrist_{'xyz'[axis]}"
        body = plant.AddRigidBody(name, instance, inertia)
        joint = plant.AddJoint(
            RevoluteJoint(name, parent_frame, body.body_frame(), np.eye(3)[axis])
        )
        actuator = plant.AddJointActuator(name, joint)
        actuator.set_controller_gains(
            PdControllerGains(p=stiffness, d=probe.wrist_damping_Nms_per_rad)
        )
        parent_frame = body.body_frame()
    return body
