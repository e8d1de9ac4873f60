"""The foam's give-way as a Drake system (scenario `task.puncture`; the law is in
`hlcmp_drake.core.puncture`)."""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import BasicVector, Context, EventStatus, LeafSystem

from hlcmp_drake.core.puncture import (
    AT_THE_FACE_M,
    came_in_from_above,
    deep_enough_to_tear,
    depth_below,
    hole_friction,
    over_the_face,
    tears,
)


class HoleFriction(LeafSystem):
    """Tears the foam once and then applies the torn hole's friction to the tool.

    One periodic unrestricted update per `period` (the plant's step), handled before the
    plant's discrete update at the same time: from the tool point's position and velocity
    at t_k it computes the hole's friction with the stage before the update, holds it for
    the plant's step, then advances the stage -- 0 until the tool point, having come in
    through the object's top face (`core.puncture.came_in_from_above`: from above its
    plane, then over the face), first reaches the tear depth while moving in; then 1, when
    the contact between tool and object must end (whoever runs the simulation does that on
    reading `punctured`: a collision filter lives in SceneGraph's context, which a system's
    own events cannot change); one period later 2. The friction, computed from the stage before
    each update, acts from the update after that; the steps in between keep it from adding
    to a contact force not yet ended.

    Input ports:

    - ``plant_state`` (nq + nv): the plant's positions q and velocities v (its state
      output).

    Output ports (both the held values of the last update):

    - ``force`` (3): the hole's friction on the tool, world [N]; zero before the tear
      (for `ToolContactForce`'s ``applied_force``).
    - ``spatial_forces`` (abstract, list of one `ExternallyAppliedSpatialForce`): the same
      force at the tool point, on the tool body, for the plant's applied_spatial_force
      input.

    Parameters
    ----------
    plant : MultibodyPlant
        Finalized; the tool point's motion is computed on a context of it.
    tool_frame : Frame
        The tool point's frame (on the tool body).
    tool_axis : (3,) array
        The tool's axis in the world, pointing into the object (unit after normalizing).
    top_point, top_normal : (3,) arrays
        A point of the object's top face [m] and its unit normal out of the object.
    top_rotation : (3, 3) array
        The top face frame's orientation in the world (its z is `top_normal`).
    footprint : ((2,), (2,)) arrays or None
        The face's extent along its frame's x and y [m] (`core.puncture.over_the_face`):
        a tool point outside it is in no hole, whatever its depth. None: unbounded.
    thickness, tear_depth : float
        The object's thickness and the depth of the tear [m].
    friction_per_m, sliding_speed : float
        The hole's friction per unit length inside [N/m] and its smoothing speed [m/s].
    period : float
        How often the tear is checked and the force updated [s] (the plant's time step).
    """

    def __init__(
        self,
        plant,
        tool_frame,
        tool_axis,
        top_point,
        top_normal,
        top_rotation,
        footprint,
        thickness: float,
        tear_depth: float,
        friction_per_m: float,
        sliding_speed: float,
        period: float,
    ):
        super().__init__()
        self._plant, self._frame = plant, tool_frame
        self._plant_context = plant.CreateDefaultContext()
        self._nq = plant.num_positions()
        axis = np.asarray(tool_axis, dtype=float)
        self._axis = axis / np.linalg.norm(axis)
        self._top_point, self._top_normal = (
            np.asarray(top_point, float),
            np.asarray(top_normal, float),
        )
        self._top_rotation, self._footprint = np.asarray(top_rotation, float), footprint
        self._thickness, self._tear_depth = float(thickness), float(tear_depth)
        self._friction_per_m, self._sliding_speed = float(friction_per_m), float(sliding_speed)
        self.plant_state = self.DeclareVectorInputPort(
            "plant_state", BasicVector(plant.num_positions() + plant.num_velocities())
        )
        self._stage_index = self.DeclareDiscreteState(1)
        self._came_in_index = self.DeclareDiscreteState(1)  # 0 until known to have come in
        self._force_index = self.DeclareDiscreteState(3)
        self._spatial_index = self.DeclareAbstractState(
            AbstractValue.Make([self._applied(np.zeros(3))])
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._update)
        self.DeclareStateOutputPort("force", self._force_index)
        self.DeclareStateOutputPort("spatial_forces", self._spatial_index)

    def punctured(self, context: Context) -> bool:
        """Whether the foam has torn (stage 1 or 2), at this system's `context`.

        Parameters
        ----------
        context : Context
            This system's context.
        """
        return self._stage(context) >= 1

    def _stage(self, context):
        return context.get_discrete_state(self._stage_index).get_value()[0]

    def _applied(self, force):
        applied = ExternallyAppliedSpatialForce()
        applied.body_index = self._frame.body().index()
        applied.p_BoBq_B = self._frame.GetFixedPoseInBodyFrame().translation()
        applied.F_Bq_W = SpatialForce(np.zeros(3), force)
        return applied

    def _tool_position(self, plant_state):
        """The tool point's world position [m] at the plant state (its positions set)."""
        self._plant.SetPositions(self._plant_context, plant_state[: self._nq])
        return self._frame.CalcPoseInWorld(self._plant_context).translation()

    def _tool_velocity(self, plant_state):
        """The tool point's world velocity [m/s] at the plant state, after `_tool_position`
        (its velocities set)."""
        self._plant.SetVelocities(self._plant_context, plant_state[self._nq :])
        return self._frame.CalcSpatialVelocityInWorld(self._plant_context).translational()

    def _inward_speed(self, plant_state) -> float:
        """The tool point's speed into the object [m/s] (positive: going in), after
        `_tool_position`."""
        return -float(np.dot(self._tool_velocity(plant_state), self._top_normal))

    def _beside(self, position) -> bool:
        """Whether the tool point is beside the object (outside its top face's extent)."""
        if self._footprint is None:
            return False
        lower, upper = self._footprint
        return not over_the_face(position, self._top_point, self._top_rotation, lower, upper)

    def _update(self, context, state):
        plant_state = self.plant_state.Eval(context)
        position = self._tool_position(plant_state)
        depth = depth_below(position, self._top_point, self._top_normal)
        stage = self._stage(context)
        if stage == 0.0:
            # Before the tear nothing is held (the friction acts from stage 2): the update
            # only follows whether the tool point came in through the top face and asks
            # whether the foam tears now, reading the velocity only once it is deep enough
            # to. Changing nothing, it says so: the Simulator then spares writing the whole
            # diagram's state back (and recomputing everything that depends on it).
            came_in_before = bool(context.get_discrete_state(self._came_in_index).get_value()[0])
            # The footprint matters only below the face (`came_in_from_above`).
            over = depth < AT_THE_FACE_M or not self._beside(position)
            came_in = came_in_from_above(came_in_before, depth, over)
            torn = (
                came_in
                and deep_enough_to_tear(depth, self._tear_depth)
                and tears(depth, self._inward_speed(plant_state), self._tear_depth)
            )
            if came_in == came_in_before and not torn:
                return EventStatus.DidNothing()
            state.get_mutable_discrete_state(self._came_in_index).set_value([float(came_in)])
            if torn:
                state.get_mutable_discrete_state(self._stage_index).set_value([1.0])
            return EventStatus.Succeeded()
        force = np.zeros(3)
        if stage >= 2 and depth > 0.0 and self._beside(position):
            depth = 0.0  # out of the hole sideways: nothing of the tool inside
        if stage >= 2:
            velocity = self._tool_velocity(plant_state)
            force = self._axis * hole_friction(
                depth,
                self._thickness,
                float(np.dot(velocity, self._axis)),
                self._friction_per_m,
                self._sliding_speed,
            )
        held_force = context.get_discrete_state(self._force_index).get_value()
        if stage == 2.0 and not force.any() and not held_force.any():
            return EventStatus.DidNothing()
        state.get_mutable_discrete_state(self._stage_index).set_value([2.0])
        if force.any() or held_force.any():
            state.get_mutable_discrete_state(self._force_index).set_value(force)
            state.get_mutable_abstract_state(self._spatial_index).set_value([self._applied(force)])
        return EventStatus.Succeeded()
