"""A 6-D controller at one instant, for a one-call control loop: the tool frame's 6-D
task-space terms, a `core.rotation_law.PoseLaw`, the posture below the task and the
saturation -- the 6-D counterpart of `systems.control_loop.ControlTick`:

    plant state --SpatialTaskSpaceModel--> x, R, V, J, Λ, C_x, p, N^T, G(q)
    + reference (x_d, x_d', x_d'', R_d, ω_d, ω_d', s) + θ  --PoseLaw.command--> F, θ'
    τ = sat(J^T F + BelowTaskImpedance(orientation gains 0))

Between the plant queries, the arithmetic is `core`'s functions, compiled by numba or plain
numpy, as for the translational tick (`core.kernels.kernel_path` when the model, the law,
the torque below the task and the tick are made).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from hlcmp_drake.core.kernels import implementation, kernel_path
from hlcmp_drake.core.laws import LawOutput
from hlcmp_drake.core.operational_space import task_joint_torque
from hlcmp_drake.core.rotation_law import PoseInstant, PoseLaw
from hlcmp_drake.systems.arm import BelowTaskImpedance
from hlcmp_drake.systems.ports import REFERENCE_PORTS
from hlcmp_drake.systems.spatial_task_space import SpatialTaskSpaceModel, SpatialTerms


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

    @property
    def joint_gravity(self) -> np.ndarray:
        """G(q) at the tick's state [N m] (`terms.joint_gravity`), as `TickResult`'s."""
        return self.terms.joint_gravity


# The 6-D tick's reference inputs beyond the translational ones, and their sizes.
ORIENTATION_REFERENCE_PORTS = (
    ("desired_orientation", 4),
    ("desired_angular_velocity", 3),
    ("desired_angular_acceleration", 3),
)


class PoseControlTick:
    """The 6-D controller at one plant state, with `systems.control_loop.ControlTick`'s
    interface: `systems.control_loop.ControlLoop` runs it once per plant step.

    Parameters
    ----------
    model : SpatialTaskSpaceModel
        The tool frame's 6-D terms.
    below_task : BelowTaskImpedance
        The posture held below the task, of the model's tool frame (it reads that frame's
        orientation and J_w from the model's terms); its orientation gains should be 0 (the
        orientation is the task's). It must carry the null-space share N^T G(q) of the
        gravity compensation (the task's share J^T Jbar^T G is in F's p).
    law : PoseLaw
    effort_limits : (nv,) array
        [N m].

    Attributes
    ----------
    kernel : str
        ``compiled`` or ``numpy``: the path of the tick's arithmetic.
    reference_ports : tuple of (str, int)
        x_d, x_d', x_d'' (3 each), s (1), then `ORIENTATION_REFERENCE_PORTS`.
    n_axes : int
        3: the translational task axes (f_c's size; the torque is an extra series).
    extra_series : dict of str to str
        The commanded torque tau_c (3, world [N m]) as "tau_c" and the tool's orientation
        (4, w x y z, world) as "q_tool".

    Raises
    ------
    ValueError
        When `below_task` holds another frame than the model's.
    """

    n_axes = 3
    extra_series = {"torque": "tau_c", "orientation": "q_tool"}

    def __init__(
        self,
        model: SpatialTaskSpaceModel,
        below_task: BelowTaskImpedance,
        law: PoseLaw,
        effort_limits: np.ndarray,
    ):
        if below_task.frame.index() != model.frame.index():
            raise ValueError(
                f"the torque below the task holds {below_task.frame.name()!r}, the task "
                f"model's frame is {model.frame.name()!r}: the tick reads the orientation "
                "and J_w from the model's terms, so they must be one frame"
            )
        self.model, self.below_task, self.law = model, below_task, law
        self.effort_limits = np.asarray(effort_limits, dtype=float)
        self.kernel = kernel_path()
        self._task_joint_torque = implementation(task_joint_torque, self.kernel)
        self.reference_ports = (
            *((name, 1 if name == "phase" else 3) for name in REFERENCE_PORTS),
            *ORIENTATION_REFERENCE_PORTS,
        )
        columns = {"position": 3, "force": 3, "saturated": 1}
        columns.update({name: 3 for name in law.log_fields})
        columns.update({"torque": 3, "orientation": 4})
        self.log_columns, start = {}, 0
        for name, size in columns.items():
            self.log_columns[name] = slice(start, start + size)
            start += size
        self.log_size = start

    def evaluate(
        self,
        state: np.ndarray,
        reference: PoseReference | tuple,
        theta: np.ndarray | None,
        *,
        time: float = 0.0,
        external_force: np.ndarray | None = None,
    ) -> PoseTickResult:
        """The controller's output at one plant state.

        Parameters
        ----------
        state : (nq + nv,) array
            The plant's positions [rad] and velocities [rad/s].
        reference : PoseReference, or its values in the order of `reference_ports`
        theta : (law.theta_size,) array, or None for a law without θ
        time, external_force
            Unused (the 6-D laws have no schedule and read no force): `ControlTick`'s
            signature.

        Returns
        -------
        PoseTickResult
        """
        if not isinstance(reference, PoseReference):
            xd, xd_dot, xd_ddot, phase, q_d, omega_d, omega_d_dot = reference
            reference = PoseReference(xd, xd_dot, xd_ddot, q_d, omega_d, omega_d_dot, phase[0])
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
        below = self.below_task.torque_at(
            state, terms.null_space, terms.joint_gravity, terms.rotation, terms.angular_jacobian
        )
        torque, saturated = self._task_joint_torque(
            terms.jacobian, out.force, below, self.effort_limits
        )
        return PoseTickResult(terms, out, torque, saturated)

    def held_command(
        self,
        state: np.ndarray,
        reference: PoseReference | tuple,
        theta: np.ndarray | None,
        time: float = 0.0,
        external_force: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """As `ControlTick.held_command`: `evaluate`'s torque and θ'.

        Parameters
        ----------
        state, reference, theta, time, external_force
            As for `evaluate`.

        Returns
        -------
        torque : (nv,) array
        rates : (P,) array or None
        """
        result = self.evaluate(state, reference, theta)
        return result.torque, result.law.rates

    def log_row(self, result: PoseTickResult) -> np.ndarray:
        """The tick's loggable values in the layout of `log_columns`: P, f_c, the number of
        saturated joints, the law's series, tau_c and the tool's orientation.

        Parameters
        ----------
        result : PoseTickResult

        Returns
        -------
        (log_size,) array
        """
        return np.concatenate(
            [
                result.terms.position,
                result.law.force[3:],
                [result.saturated],
                *(result.law.logs[name] for name in self.law.log_fields),
                result.law.force[:3],
                result.terms.orientation,
            ]
        )
