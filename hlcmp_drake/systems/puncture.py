"""The foam's give-way as a Drake system (scenario `task.puncture`; the law is in
`hlcmp_drake.core.puncture`)."""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from hlcmp_drake.core.puncture import depth_below, hole_friction, tears


class HoleFriction(LeafSystem):
    """Tears the foam once and then applies the torn hole's friction to the tool.

    Discrete state `stage` (1), checked every `period` s: 0 until the tool point first
    reaches the tear depth below the object's top face while moving in; then 1, when the
    contact between tool and object must end -- whoever runs the simulation does that on
    reading `punctured` (a collision filter lives in SceneGraph's context, which a system's
    own events cannot change); one period later 2, when the hole's friction starts. The
    period in between keeps the friction from adding to a contact force not yet ended.

    Inputs `tool_position`, `tool_velocity` (3 each, world) of the tool point. Outputs
    `force` (3, world [N]): the hole's friction on the tool (zero before the tear), and
    `spatial_forces`: the same force at the tool point, for the plant's
    applied_spatial_force input.

    Parameters
    ----------
    tool_body_index : BodyIndex
        The tool's body.
    tool_point_in_body : (3,) array
        The tool point in the body frame [m].
    tool_axis : (3,) array
        The tool's axis in the world, pointing into the object (unit after normalizing).
    top_point, top_normal : (3,) arrays
        A point of the object's top face [m] and its unit normal out of the object.
    thickness, tear_depth : float
        The object's thickness and the depth of the tear [m].
    friction_per_m, sliding_speed : float
        The hole's friction per unit length inside [N/m] and its smoothing speed [m/s].
    period : float
        How often the tear is checked [s] (the plant's time step).
    """

    def __init__(self, tool_body_index, tool_point_in_body, tool_axis, top_point, top_normal,
                 thickness: float, tear_depth: float, friction_per_m: float, sliding_speed: float,
                 period: float):
        super().__init__()
        self._body_index = tool_body_index
        self._point_in_body = np.asarray(tool_point_in_body, dtype=float)
        axis = np.asarray(tool_axis, dtype=float)
        self._axis = axis / np.linalg.norm(axis)
        self._top_point, self._top_normal = np.asarray(top_point, float), np.asarray(top_normal, float)
        self._thickness, self._tear_depth = float(thickness), float(tear_depth)
        self._friction_per_m, self._sliding_speed = float(friction_per_m), float(sliding_speed)
        self.tool_position = self.DeclareVectorInputPort("tool_position", BasicVector(3))
        self.tool_velocity = self.DeclareVectorInputPort("tool_velocity", BasicVector(3))
        self._stage_index = self.DeclareDiscreteState(1)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        prereq = {self.all_input_ports_ticket(), self.all_state_ticket()}
        self._force_port = self.DeclareVectorOutputPort("force", 3, self._calc_force, prereq)
        self.DeclareAbstractOutputPort(
            "spatial_forces", lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]),
            self._calc_spatial_forces, prereq)

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

    def _depth(self, context):
        return depth_below(self.tool_position.Eval(context), self._top_point, self._top_normal)

    def _update(self, context, discrete_state):
        if self.punctured(context):
            stage = 2.0
        else:
            inward = -float(np.dot(self.tool_velocity.Eval(context), self._top_normal))
            stage = 1.0 if tears(self._depth(context), inward, self._tear_depth) else 0.0
        discrete_state.get_mutable_vector(self._stage_index).SetFromVector([stage])

    def _force(self, context):
        if self._stage(context) < 2:
            return np.zeros(3)
        axial = float(np.dot(self.tool_velocity.Eval(context), self._axis))
        return self._axis * hole_friction(self._depth(context), self._thickness, axial,
                                          self._friction_per_m, self._sliding_speed)

    def _calc_force(self, context, output):
        output.SetFromVector(self._force(context))

    def _calc_spatial_forces(self, context, output):
        applied = ExternallyAppliedSpatialForce()
        applied.body_index = self._body_index
        applied.p_BoBq_B = self._point_in_body
        # the `force` output is cached by Drake: the friction is computed once per step
        applied.F_Bq_W = SpatialForce(np.zeros(3), self._force_port.Eval(context))
        output.set_value([applied])
