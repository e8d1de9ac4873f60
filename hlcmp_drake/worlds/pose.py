"""The arm's 6-D controllers in a world (issue 19): the pose reference (the position DMP
and the orientation DMP, or the held orientation) and the 6-D tick
(`systems.pose_control.PoseControlTick`), which the arm's one-call loop runs like the
translational one.

    position DMP (C++) ------------------ x_d, x_d', x_d'', s --\\
    orientation DMP (C++ + OrientationFromError) -- R_d, ω_d, ω_d' --> PoseControlTick -> plant
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from hlcmp_drake.config.scenario import ArmTask, Scenario
from hlcmp_drake.systems.arm import BelowTaskImpedance
from hlcmp_drake.systems.ports import REFERENCE_PORTS
from hlcmp_drake.systems.pose_control import ORIENTATION_REFERENCE_PORTS, PoseControlTick
from hlcmp_drake.systems.references import orientation_dmp_source
from hlcmp_drake.systems.spatial_task_space import SpatialTaskSpaceModel
from hlcmp_drake.worlds.common import add_reference
from hlcmp_drake.worlds.controllers import controller_kind
from hlcmp_drake.worlds.models import scoped_frame

if TYPE_CHECKING:
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.systems.framework import Diagram

    from hlcmp_drake.worlds.arm_setup import ArmSetup

# The pose reference's outputs a run logs beyond x_d ("xd"), by port: the series name.
LOGGED_REFERENCE = {"desired_orientation": "q_tool_d"}


def add_pose_reference(builder: DiagramBuilder, scenario: Scenario, setup: ArmSetup) -> Diagram:
    """Add the 6-D controller's reference, named "reference": the compiled position DMP
    (its phase the tick's s) and the orientation DMP of a pose demonstration, or the
    orientation at the start posture held (ω_d = ω_d' = 0) for a position-only one.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
        With an ArmTask and a DemonstrationConfig (its duration_s replays both DMPs at
        another tau).
    setup : ArmSetup
        The DMPs and the start orientation.

    Returns
    -------
    Diagram
        Output ports: REFERENCE_PORTS, then ORIENTATION_REFERENCE_PORTS (R_d as w, x, y,
        z; ω_d [rad/s], ω_d' [rad/s^2], world).
    """
    inner = DiagramBuilder()
    position = add_reference(inner, scenario, dmp=setup.dmp, compiled=True)
    for port in REFERENCE_PORTS:
        inner.ExportOutput(position.GetOutputPort(port), port)
    if setup.orientation_dmp is not None:
        tau = scenario.reference.duration_s or None
        orientation = inner.AddSystem(
            orientation_dmp_source(setup.orientation_dmp, scenario.duration_s, tau)
        )
        for name, _ in ORIENTATION_REFERENCE_PORTS:
            inner.ExportOutput(orientation.GetOutputPort(name), name)
    else:
        held = setup.tool_orientation.ToQuaternion()
        values = {
            "desired_orientation": [held.w(), held.x(), held.y(), held.z()],
            "desired_angular_velocity": np.zeros(3),
            "desired_angular_acceleration": np.zeros(3),
        }
        for name, _ in ORIENTATION_REFERENCE_PORTS:
            source = inner.AddSystem(ConstantVectorSource(values[name]))
            source.set_name(f"held_{name}")
            inner.ExportOutput(source.get_output_port(), name)
    diagram = inner.Build()
    diagram.set_name("reference")
    return builder.AddSystem(diagram)


def pose_tick(
    scenario: Scenario, controller_name: str, *, plant: MultibodyPlant, setup: ArmSetup
) -> PoseControlTick:
    """The arm's 6-D controller at one instant: the controller's `PoseLaw`, the tool
    frame's 6-D task-space terms, the posture held below the task (the orientation is
    the task's, so the below-task orientation gains are 0) and the effort limits.

    Parameters
    ----------
    scenario : Scenario
        With an ArmTask; its controller `controller_name` is a 6-D one.
    controller_name : str
    plant : MultibodyPlant
        Finalized, with the scenario's models.
    setup : ArmSetup
        The start posture.

    Returns
    -------
    PoseControlTick
    """
    task: ArmTask = scenario.task
    tool_frame = scoped_frame(plant, task.tool_frame)
    kind = controller_kind(scenario, controller_name)
    assert kind.pose and kind.law is not None
    law = kind.law(scenario.controllers[controller_name], scenario)
    effort = [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
    posture = BelowTaskImpedance(
        plant,
        tool_frame,
        setup.tool_orientation,
        setup.q0,
        0.0,
        0.0,
        task.posture_stiffness_Nm_per_rad,
        task.posture_damping_Nms_per_rad,
    )
    return PoseControlTick(SpatialTaskSpaceModel(plant, tool_frame), posture, law, effort)
