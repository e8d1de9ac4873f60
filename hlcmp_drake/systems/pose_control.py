"""A 6-D controller at one instant, for a one-call control loop: the tool frame's 6-D
task-space terms, a `core.rotation_law.PoseLaw`, the posture below the task and the
saturation -- the 6-D counterpart of `systems.control_loop.ControlTick`:

    plant state --SpatialTaskSpaceModel--> x, R, V, J, Λ, C_x, p, N^T, G(q)
    + reference (x_d, x_d', x_d'', R_d, ω_d, ω_d', s) + θ  --PoseLaw.command--> F, θ'
    τ = sat(J^T F + BelowTaskImpedance(orientation gains 0))
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from hlcmp_drake.core.laws import LawOutput
from hlcmp_drake.core.rotation_law import PoseInstant, PoseLaw
from hlcmp_drake.systems.arm import BelowTaskImpedance
from hlcmp_drake.systems.spatial_task_space import (
    SpatialTaskSpaceModel,
    SpatialTerms,
    wrench_to_joint_torque,
)


@dc.dataclass
class PoseReference:
    """The desired motion of the tool at one instant.

    Attributes
    ----------
    position, velocity, acceleration : (3,) arrays
        x_d [m], x_d' [m/s], x_d'' [m/s^2] of the tool point, world.
    orientation : (4,) array
        R_d, unit quaternion (w, x, y, z), world.
    angular_velocity, angular_acceleration : (3,) arrays
        omega_d [rad/s], omega_d' [rad/s^2], world.
    phase : float
        s [-].
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    orientation: np.ndarray
    angular_velocity: np.ndarray
    angular_acceleration: np.ndarray
    phase: float


@dc.dataclass
class PoseTickResult:
    """One tick: the 6-D terms it read, the law's output and the joint torque.

    Attributes
    ----------
    terms : SpatialTerms
    law : LawOutput
        The wrench [tau_c; f_c] [N m; N], the series and (learning) θ'.
    torque : (nv,) array
        The saturated joint torque [N m].
    saturated : int
        The number of joints at their effort limit.
    """

    terms: SpatialTerms
    law: LawOutput
    torque: np.ndarray
    saturated: int


class PoseControlTick:
    """The 6-D controller at one plant state.

    Parameters
    ----------
    model : SpatialTaskSpaceModel
        The tool frame's 6-D terms.
    below_task : BelowTaskImpedance
        The posture held below the task; its orientation gains should be 0 (the
        orientation is the task's).
    law : PoseLaw
    effort_limits : (nv,) array
        [N m].
    """

    def __init__(
        self,
        model: SpatialTaskSpaceModel,
        below_task: BelowTaskImpedance,
        law: PoseLaw,
        effort_limits: np.ndarray,
    ):
        self.model, self.below_task, self.law = model, below_task, law
        self.effort_limits = np.asarray(effort_limits, dtype=float)

    def evaluate(
        self, state: np.ndarray, reference: PoseReference, theta: np.ndarray | None
    ) -> PoseTickResult:
        """The controller's output at one plant state.

        Parameters
        ----------
        state : (nq + nv,) array
            The plant's positions [rad] and velocities [rad/s].
        reference : PoseReference
        theta : (law.theta_size,) array, or None for a law without θ

        Returns
        -------
        PoseTickResult
        """
        terms = self.model.terms(state, coriolis_matrix=False)
        velocity = terms.spatial_velocity
        now = PoseInstant(
            terms.position,
            velocity[3:],
            reference.position,
            reference.velocity,
            reference.acceleration,
            terms.orientation,
            velocity[:3],
            reference.orientation,
            reference.angular_velocity,
            reference.angular_acceleration,
            reference.phase,
            terms.inertia,
            terms.coriolis,
            terms.gravity,
        )
        out = self.law.command(now, theta)
        below = self.below_task.torque(
            state, terms.null_space, terms.joint_gravity, self.model.context
        )
        torque, saturated = wrench_to_joint_torque(terms, out.force, below, self.effort_limits)
        return PoseTickResult(terms, out, torque, saturated)
