"""World physics extras: effects a world adds to the plant that Drake's contact does not
model by itself (the first is the foam's puncture: the tear and the torn hole's friction).

The registry maps an extra's config type to the function that adds it to a diagram being
built. A task lists its configured extras (`ArmTask.physics_extras`); every arm diagram
(the runs, the driven world, the probe) adds them through `add_tool_sensing`, so a new
effect is its config (a field of the task, listed by `physics_extras`), one module with
its `add` function, and one entry in PHYSICS_EXTRAS.
"""

from __future__ import annotations

import dataclasses as dc
from typing import TYPE_CHECKING, Any, Callable

from pydrake.systems.primitives import Adder

from hlcmp_drake.config.scenario import ArmTask, PunctureConfig
from hlcmp_drake.systems.arm import ToolContactForce
from hlcmp_drake.worlds.puncture import add_puncture

if TYPE_CHECKING:
    from pydrake.geometry import SceneGraph
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import Frame
    from pydrake.systems.framework import Context, DiagramBuilder, OutputPort


@dc.dataclass
class AddedExtra:
    """A physics extra in a diagram.

    Attributes
    ----------
    tool_force : OutputPort, optional
        The force (3, world [N]) the extra applies to the tool, which the wrist sensor
        feels beside the contact.
    after_step : callable(root_context), optional
        What the simulation must do after every step that no system can (e.g. the tear,
        which changes SceneGraph's collision filters).
    """

    tool_force: OutputPort | None = None
    after_step: Callable[[Context], None] | None = None


# add(builder, plant, scene_graph, config, tool_frame, tool_axis) -> AddedExtra
AddExtra = Callable[[Any, Any, Any, Any, Any, list], AddedExtra]


def _add_puncture(builder, plant, scene_graph, config, tool_frame, tool_axis) -> AddedExtra:
    puncture = add_puncture(builder, plant, scene_graph, config, tool_frame, tool_axis)
    return AddedExtra(puncture.system.GetOutputPort("force"), puncture.apply_tear)


PHYSICS_EXTRAS: dict[type, AddExtra] = {PunctureConfig: _add_puncture}


@dc.dataclass
class ToolSensing:
    """The wrist force sensor and the world's physics extras of an arm diagram.

    Attributes
    ----------
    sensor : ToolContactForce
        The wrist force sensor (contact plus the extras' forces on the tool).
    extras : list of AddedExtra
        In the order the task lists them.
    """

    sensor: ToolContactForce
    extras: list[AddedExtra]

    def after_step(self) -> Callable[[Context], None] | None:
        """What must run after every step: every extra's `after_step`, or None.

        Returns
        -------
        callable(root_context) or None
        """
        hooks = [extra.after_step for extra in self.extras if extra.after_step is not None]
        if len(hooks) <= 1:  # it runs after every plant step: no wrapper around a lone hook
            return hooks[0] if hooks else None

        def run_all(root_context: Context) -> None:
            for hook in hooks:
                hook(root_context)

        return run_all


def add_tool_sensing(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    task: ArmTask,
    tool_frame: Frame,
    *,
    axes: tuple[int, ...] = (0, 1, 2),
) -> ToolSensing:
    """Add the task's physics extras and the wrist force sensor that feels them.

    Parameters
    ----------
    builder : DiagramBuilder
    plant : MultibodyPlant
        Finalized, discrete.
    scene_graph : SceneGraph
        The plant's.
    task : ArmTask
        Its `physics_extras()` and tool direction (the tool's axis, into the object).
    tool_frame : Frame
        The tool point's frame.
    axes : tuple of int
        The world axes of the sensor's `task_force` output.

    Returns
    -------
    ToolSensing
        The sensor (named "wrist_force_sensor") and the added extras.
    """
    extras = [
        PHYSICS_EXTRAS[type(config)](
            builder, plant, scene_graph, config, tool_frame, task.tool_direction
        )
        for config in task.physics_extras()
    ]
    forces = [extra.tool_force for extra in extras if extra.tool_force is not None]
    sensor = builder.AddSystem(
        ToolContactForce(plant, tool_frame, axes, applied_force=bool(forces))
    )
    sensor.set_name("wrist_force_sensor")
    builder.Connect(plant.get_contact_results_output_port(), sensor.contact_results)
    builder.Connect(plant.get_body_poses_output_port(), sensor.body_poses)
    if len(forces) == 1:
        builder.Connect(forces[0], sensor.applied_force)
    elif forces:
        total = builder.AddSystem(Adder(len(forces), 3))
        for k, force in enumerate(forces):
            builder.Connect(force, total.get_input_port(k))
        builder.Connect(total.get_output_port(), sensor.applied_force)
    return ToolSensing(sensor, extras)
