"""An orientation DMP on SO(3): the DMP of `core.dmp` in the rotation vector of the
orientation relative to the goal.

Ude et al. (2014) integrate the orientation itself, driven by 2 Log(q_g q*) as the
"position error" of Eq. 15, which makes the second-order system nonlinear in its state;
Koutras & Doulgeri (2020) showed that this formulation does not converge as the position
DMP does (it can oscillate about the goal) and that writing the DMP in

.. math:: e(t) = 2 \\operatorname{Log}(q_g \\otimes \\bar q(t)) \\in \\mathbb{R}^3,
          \\qquad q(t) = \\operatorname{Exp}(-e(t)/2) \\otimes q_g

makes it exactly the linear position DMP with goal 0: Eqs. 7 and 15 with p = e, g = 0 and
forcing term f on the same phase and basis (Eqs. 8, 10, 13). This module does that,
reusing `core.dmp`'s functions, and adds:

- **Regression on the trajectory.** The weights are fitted so that the DMP's own e(t)
  matches the demonstrated one (`fit_trajectory_weights`), not Eq. 19's f_target, which
  needs the demonstration's second derivative: beyond a rotation of pi the coordinates e
  stretch a rotation's noise by up to (theta/2) / sin(theta/2) (3.3 at 270 deg), and
  differentiating twice amplifies it further. On the seeded noisy demonstrations of
  tests/test_core_orientation_dmp.py (0.2 deg noise, turns of 190-330 deg) Eq. 19's
  regression gave a geodesic RMS error of 0.8-1.7 deg, this one 0.10-0.15 deg.

- **Rotations beyond pi.** The principal log is at most pi, so a demonstration that turns
  270 deg would be read as 90 deg the other way. The demonstration's e(t) is unwrapped from
  its end (e = 0) backwards, each sample the representative nearest the next
  (`quaternion.unwrap_rotation_vectors`): e is continuous and its length may exceed pi. The
  DMP lives in R^3 and maps back through Exp, which is smooth everywhere, so nothing is
  special at a rotation of pi, nor at 2 pi, in the rollout.
- **New goals.** A goal q_g' gives a start e0' = 2 Log(q_g' q0*), taken as the
  representative nearest the demonstrated e0 (so a new goal near the demonstrated one keeps
  a 270 deg turn's direction; a new goal exactly halfway between two representatives
  picks one by rounding). The forcing term is mapped by the spatial scaling
  S = (|e0'| / |e0|) R, R the smallest rotation turning e0 onto e0': the rolled-out e(t)
  is then S times the demonstrated one, rotated and stretched as a whole (a per-axis ratio
  e0'_i / e0_i, as in Ude et al., flips or blows up an axis whose component is small). On
  a demonstration that comes back to where it started (|e0| below
  DEGENERATE_GOAL_FRACTION of its largest |e|) S = I: a new goal moves the end, not the
  shape, as for the position DMP's flat axes.
- **A goal switched mid-rollout.** The goal a rollout aims at moves to a new one through a
  goal filter: the same critically damped Eq. 15 with f = 0 in d = 2 Log(q_new q_g*)
  (q_g = Exp(-d/2) q_new), started with the goal's present angular velocity. So q_g, its
  angular velocity, e and z stay continuous, and with them the rolled-out angular
  velocity; the angular acceleration steps at the switch. d starts at its principal
  value: the goal turns the short way; a switch by exactly pi turns about the axis
  `quaternion.to_rotation_vector` returns.
- **Temporal scaling**: another tau, as for the position DMP.
- **The goal from the settled end.** A demonstration ends at rest at its goal (the DMP's
  premise, as `core.dmp`'s settled tail), so the goal is the mean orientation of the
  samples in the last `smoothing_s` seconds (`settled_goal`), not the last sample alone,
  whose noise would be the rollout's end error: on the seeded demonstrations at 0.5 deg
  noise per axis the end error was 0.85 deg with the last sample as the goal.

The angular velocity is in the world frame: with R = Exp(-e) R_g,

.. math:: \\omega = J_l(-e)(-\\dot e) + \\operatorname{Exp}(-e)\\, \\omega_g

(`quaternion.left_jacobian`), omega_g the goal's (zero unless it is switched).

References
----------
A. Ude, B. Nemec, T. Petric, J. Morimoto, "Orientation in Cartesian space dynamic movement
primitives", IEEE ICRA 2014, pp. 2997-3004.
L. Koutras, Z. Doulgeri, "A correct formulation for the orientation dynamic movement
primitives for robot control in the Cartesian space", Conference on Robot Learning
(CoRL 2019), PMLR 100, pp. 293-302, 2020.
"""

import dataclasses
import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.core.dmp import (
    DEGENERATE_GOAL_FRACTION,
    FEATURE_CHUNK_VALUES,
    Dmp,
    DmpSettings,
    basis_centers_and_widths,
    forcing_basis,
    phase_at,
    resample_and_differentiate,
    rollout_times,
    solve_forcing_weights,
    step_transformation_system,
    with_settled_tail,
)

# The axis names of `OrientationDmp.error_dmp`: the components of e.
ERROR_AXES = ("ex", "ey", "ez")


def goal_error(goal: np.ndarray, q: np.ndarray) -> np.ndarray:
    """e = 2 Log(q_g q*), the principal rotation vector from q to the goal [rad].

    Parameters
    ----------
    goal : (4,) array
        q_g, a unit quaternion.
    q : (..., 4) array
        Orientation(s).

    Returns
    -------
    (..., 3) array
        e with |e| <= pi; q = Exp(-e/2) q_g (`orientation_from_error`).
    """
    return quat.to_rotation_vector(quat.multiply(goal, quat.conjugate(q)))


def orientation_from_error(error: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """q = Exp(-e/2) q_g, the orientation whose error to the goal is e (any representative).

    Parameters
    ----------
    error : (..., 3) array
        e [rad].
    goal : (..., 4) array
        q_g.

    Returns
    -------
    (..., 4) array
    """
    return quat.multiply(quat.from_rotation_vector(-np.asarray(error)), goal)


def angular_velocity(
    error: np.ndarray, error_rate: np.ndarray, goal_angular_velocity: np.ndarray
) -> np.ndarray:
    """omega = J_l(-e)(-e') + Exp(-e) omega_g, the world-frame angular velocity of
    q = Exp(-e/2) q_g.

    Parameters
    ----------
    error, error_rate : (..., 3) arrays
        e [rad] and e' [rad/s].
    goal_angular_velocity : (..., 3) array
        omega_g [rad/s], the goal's own (world frame).

    Returns
    -------
    (..., 3) array
        omega [rad/s], world frame.
    """
    error = np.asarray(error, dtype=float)
    own = np.einsum("...ij,...j->...i", quat.left_jacobian(-error), -np.asarray(error_rate))
    return own + quat.rotate(quat.from_rotation_vector(-error), goal_angular_velocity)


def angular_acceleration(
    error: np.ndarray, error_rate: np.ndarray, error_acceleration: np.ndarray
) -> np.ndarray:
    """omega' = J_l(-e)(-e'') + (d/dt J_l(-e))(-e'), the world-frame angular acceleration
    of q = Exp(-e/2) q_g for a goal at rest (`angular_velocity` with omega_g = 0, differentiated;
    `quaternion.left_jacobian_rate`).

    Parameters
    ----------
    error, error_rate, error_acceleration : (..., 3) arrays
        e [rad], e' [rad/s] and e'' [rad/s^2].

    Returns
    -------
    (..., 3) array
        omega' [rad/s^2], world frame.
    """
    error = np.asarray(error, dtype=float)
    own = np.einsum("...ij,...j->...i", quat.left_jacobian(-error), -np.asarray(error_acceleration))
    return own + quat.left_jacobian_rate(-error, -np.asarray(error_rate))


def settled_goal(t: np.ndarray, quaternions: np.ndarray, window: float) -> np.ndarray:
    """The goal of a demonstration that ends at rest: the chordal mean of the orientations
    sampled in its last `window` seconds (each made hemisphere-consistent with the last
    sample, summed and normalised), the last sample alone for `window` = 0.

    Parameters
    ----------
    t : (T,) array
        Sample times [s], increasing.
    quaternions : (T, 4) array
        Unit quaternions (w, x, y, z), either sign.
    window : float
        [s], >= 0.

    Returns
    -------
    (4,) array
        Unit quaternion, in the last sample's hemisphere.
    """
    tail = np.asarray(quaternions, float)[np.asarray(t) >= t[-1] - window]
    signs = np.where(tail @ tail[-1] < 0.0, -1.0, 1.0)
    mean = (signs[:, None] * tail).sum(axis=0)
    return mean / np.linalg.norm(mean)


def fit_trajectory_weights(
    t: np.ndarray, error: np.ndarray, amplitude: float, settings: DmpSettings
) -> np.ndarray:
    """The forcing weights whose rollout best matches a demonstrated e(t), by least squares
    on e itself (Eq. 21's solver, `core.dmp.solve_forcing_weights`).

    Eqs. 7 and 15 with g = 0 are linear, so the rollout from e(0) is the free response to
    e(0) plus sum_n theta_n Phi_n(t), Phi_n the response (from rest at 0) to the n-th
    column of Eq. 13's features. Those responses are stepped exactly as a rollout steps
    (`core.dmp.step_transformation_system`). As in `core.dmp.fit_demonstration_weights`,
    the demonstration is extended by its settled tail (`core.dmp.with_settled_tail`), held
    at its goal (e = 0).

    Parameters
    ----------
    t : (T,) array
        Uniform sample times [s] from 0; tau = t[-1].
    error : (T, 3) array
        The demonstrated e(t) [rad], e(tau) = 0.
    amplitude : float
        The Eq. 13 amplitude of every component [rad].
    settings : DmpSettings

    Returns
    -------
    (3, N) array
        The weights [-].
    """
    tau, dt = float(t[-1]), t[1] - t[0]
    s = phase_at(with_settled_tail(t), tau, settings.alpha_s)
    centers, widths = basis_centers_and_widths(settings.n_basis, settings.alpha_s)
    alpha, beta, n = settings.alpha, settings.beta_value, settings.n_basis
    free, _ = step_transformation_system(
        error[0], np.zeros(3), np.zeros((len(s), 3)), tau, dt, alpha, beta
    )
    target = np.concatenate([error, np.zeros((len(s) - len(t), 3))]) - free
    # The responses, stepped and summed into the normal equations chunk by chunk (those of
    # an hour at 1 kHz would take gigabytes at once); each chunk starts from the state the
    # one before ended in, at the sample they share, so the responses are those of one
    # pass, and a demonstration of one chunk is fitted with the arithmetic of
    # `fit_forcing_weights` on all of it.
    chunk = max(2, FEATURE_CHUNK_VALUES // n)
    gram, moment = np.zeros((n, n)), np.zeros((n, 3))
    first, position, rate = 0, np.zeros(n), np.zeros(n)
    while True:
        end = min(first + chunk, len(s))
        features = forcing_basis(s[first:end], centers, widths, np.array([amplitude]))[:, 0, :]
        responses, rates = step_transformation_system(
            position, np.zeros(n), features, tau, dt, alpha, beta, start_rate=rate
        )
        new = responses if first == 0 else responses[1:]  # the shared sample counted once
        gram += new.T @ new
        for m in range(3):
            moment[:, m] += new.T @ target[end - len(new) : end, m]
        if end == len(s):
            return np.stack([solve_forcing_weights(gram, moment[:, m]) for m in range(3)])
        first, position, rate = end - 1, responses[-1], rates[-1]


def spatial_scaling(demonstrated: np.ndarray, new: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """S = (|e0'| / |e0|) R: the scale and the quaternion of the smallest rotation R
    turning e0 onto e0'. Opposite vectors: R is the half turn about an axis normal to e0.

    Parameters
    ----------
    demonstrated : (3,) array
        e0 [rad], nonzero.
    new : (..., 3) array
        e0' [rad].

    Returns
    -------
    scale : (...) array
    rotation : (..., 4) array
        S f = scale * quaternion.rotate(rotation, f).
    """
    length = float(np.linalg.norm(demonstrated))
    unit = demonstrated / length
    new = np.asarray(new, dtype=float)
    new_length = np.linalg.norm(new, axis=-1)
    normal = np.cross(unit, new)
    angle = np.arctan2(np.linalg.norm(normal, axis=-1), new @ unit)
    sin_angle = np.linalg.norm(normal, axis=-1, keepdims=True)
    # Any normal of e0 serves when e0' is opposite to it: the axis among x, y, z least along e0.
    fallback = np.cross(unit, np.eye(3)[np.argmin(np.abs(unit))])
    axis = np.where(sin_angle > 1e-12, normal / np.maximum(sin_angle, 1e-300), fallback)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    return new_length / length, quat.from_rotation_vector(axis * angle[..., None])


@dataclass(frozen=True)
class OrientationDmp:
    """A fitted orientation DMP (module docstring), on the phase and basis of `core.dmp`.

    Attributes
    ----------
    settings : DmpSettings
        N, alpha, beta, alpha_s and the smoothing, as for the position DMP.
    tau : float
        The demonstration's duration [s].
    start : (4,) array
        q0, the first orientation (unit quaternion, w x y z).
    goal : (4,) array
        q_g, the orientation aimed at (the demonstration's settled end; another after
        `with_goal`).
    demonstrated_rotation : (3,) array
        e0 = 2 Log(q_g q0*) of the demonstration, unwrapped [rad]: the rotation it makes
        from start to goal, |e0| possibly beyond pi. Kept under a new goal: it picks the
        new e0's representative and defines S.
    theta : (3, N) array
        The forcing term's weights, one row per component of e [-].
    amplitude : float
        The Eq. 13 amplitude of every component [rad]: |e0|, or on a demonstration that
        comes back near its start the largest |e| (then `goal_scaled` is False).
    goal_scaled : bool
        Whether a new goal applies S (False: S = I).
    """

    settings: DmpSettings
    tau: float
    start: np.ndarray
    goal: np.ndarray
    demonstrated_rotation: np.ndarray
    theta: np.ndarray
    amplitude: float
    goal_scaled: bool

    @functools.cached_property
    def basis(self) -> tuple[np.ndarray, np.ndarray]:
        """(centers, widths) of the phase basis, each (N,) [-]."""
        return basis_centers_and_widths(self.settings.n_basis, self.settings.alpha_s)

    @classmethod
    def fit(
        cls, t: np.ndarray, quaternions: np.ndarray, settings: DmpSettings | None = None
    ) -> "OrientationDmp":
        """Fit to a demonstration: normalise, take e(t) relative to the settled end's mean
        (`settled_goal`) unwrapped from the end, resample and smooth e as the position
        DMP does (`core.dmp.resample_and_differentiate`), and regress the forcing weights
        on e (`fit_trajectory_weights`).

        Parameters
        ----------
        t : (T,) array
            Sample times [s], strictly increasing (uneven sampling is resampled).
        quaternions : (T, 4) array
            Orientations (w, x, y, z), nonzero; either sign.
        settings : DmpSettings, optional
            A copy is kept (default DmpSettings()).

        Returns
        -------
        OrientationDmp
            q0 = the first sample, q_g = the mean of the settled end (`settled_goal`).
        """
        settings = dataclasses.replace(settings) if settings is not None else DmpSettings()
        q = np.asarray(quaternions, dtype=float)
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)  # either sign: the log ignores it
        goal = settled_goal(t, q, settings.smoothing_s)
        error = quat.unwrap_rotation_vectors(goal_error(goal, q)[::-1], np.zeros(3))[::-1]
        t_u, e, _, _ = resample_and_differentiate(t, error, settings.smoothing_s)
        tau = float(t_u[-1])
        rotation = e[0].copy()
        largest = float(np.max(np.linalg.norm(e, axis=-1)))
        goal_scaled = bool(
            largest > 0 and np.linalg.norm(rotation) >= DEGENERATE_GOAL_FRACTION * largest
        )
        amplitude = float(np.linalg.norm(rotation)) if goal_scaled else max(largest, 1e-12)
        theta = fit_trajectory_weights(t_u, e, amplitude, settings)
        return cls(settings, tau, q[0].copy(), goal.copy(), rotation, theta, amplitude, goal_scaled)

    def with_goal(self, goal: np.ndarray) -> "OrientationDmp":
        """The same skill aimed at another goal orientation.

        Parameters
        ----------
        goal : (4,) array
            q_g' (w, x, y, z), nonzero; normalised here.

        Returns
        -------
        OrientationDmp
            A copy; this one is unchanged.
        """
        goal = np.asarray(goal, dtype=float).reshape(4)
        return dataclasses.replace(self, goal=goal / np.linalg.norm(goal))

    def start_errors(self, goals: np.ndarray) -> np.ndarray:
        """e0' = 2 Log(q_g' q0*) for a sequence of goals, each the representative nearest
        the one before, the first the one nearest the demonstrated e0.

        Parameters
        ----------
        goals : (T, 4) array

        Returns
        -------
        (T, 3) array [rad]
        """
        return quat.unwrap_rotation_vectors(
            goal_error(goals, self.start[None]), self.demonstrated_rotation
        )

    def error_dmp(self) -> Dmp:
        """The transformation system in e for the present goal as a position DMP with goal
        0: start e0' (`start_errors`), weights S theta (S is linear, so it moves into the
        weights), the fixed amplitude on every component. Its rollout is this DMP's e(t)
        while the goal stays; `systems.references.orientation_dmp_source` runs it as
        Drake's C++ systems.

        Returns
        -------
        Dmp
            Axes ("ex", "ey", "ez") [rad].
        """
        start = self.start_errors(self.goal[None])[0]
        theta = self.theta
        if self.goal_scaled:
            scale, rotation = spatial_scaling(self.demonstrated_rotation, start)
            theta = scale * quat.rotate(rotation, theta.T).T
        return Dmp(
            self.settings,
            self.tau,
            start,
            np.zeros(3),
            theta,
            np.full(3, self.amplitude),
            np.zeros(3, dtype=bool),
            ERROR_AXES,
        )

    def forcing(self, s: np.ndarray, start_errors: np.ndarray) -> np.ndarray:
        """f = S theta . g_p(s): Eq. 13's forcing term of e, mapped by the spatial scaling
        for the start error e0' of the goal in force (S = I when not `goal_scaled`).

        Parameters
        ----------
        s : (T,) array
            Phase [-].
        start_errors : (T, 3) or (3,) array
            e0' at each sample [rad].

        Returns
        -------
        (T, 3) array [rad]
        """
        centers, widths = self.basis
        basis = forcing_basis(s, centers, widths, np.full(3, self.amplitude))
        demonstrated = np.sum(self.theta * basis, axis=-1)
        if not self.goal_scaled:
            return demonstrated
        scale, rotation = spatial_scaling(self.demonstrated_rotation, start_errors)
        return np.asarray(scale)[..., None] * quat.rotate(rotation, demonstrated)

    def rollout(
        self,
        duration: float | None = None,
        dt: float = 0.001,
        tau: float | None = None,
        goal_changes: Sequence[tuple[float, np.ndarray]] = (),
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The DMP from q0, sampled every dt: t, q, omega, s.

        The transformation system in e is linear, so it is stepped exactly for a forcing
        term linear between samples (`core.dmp.step_transformation_system`).

        Parameters
        ----------
        duration : float, optional
            Length [s]; default tau.
        dt : float
            Sample period [s].
        tau : float, optional
            Time constant [s]; default the demonstration's (another: temporal scaling).
        goal_changes : sequence of (time [s], (4,) quaternion)
            Goals switched to mid-rollout, in increasing time; each takes effect at the
            first sample at or after its time, through the goal filter (module docstring).

        Returns
        -------
        t : (T,) array
            Times [s] from 0.
        q : (T, 4) array
            Orientations, hemisphere-continuous (w, x, y, z).
        omega : (T, 3) array
            Angular velocity [rad/s], world frame.
        s : (T,) array
            Phase [-].
        """
        tau = self.tau if tau is None else float(tau)
        t, s = rollout_times(tau, duration, dt, self.settings.alpha_s)
        n = len(t)
        goals, goal_omega = self._goal_trajectory(t, tau, dt, goal_changes)
        if goal_changes:
            start_errors = self.start_errors(goals)
        else:
            start_errors = np.tile(self.start_errors(goals[:1]), (n, 1))
        forcing = self.forcing(s, start_errors)
        alpha, beta = self.settings.alpha, self.settings.beta_value
        e, z = step_transformation_system(
            start_errors[0], np.zeros(3), forcing, tau, dt, alpha, beta
        )
        q = quat.hemisphere_continuous(orientation_from_error(e, goals))
        return t, q, angular_velocity(e, z / tau, goal_omega), s

    def _goal_trajectory(self, t, tau, dt, goal_changes):
        """q_g and omega_g at every sample: constant until a change, then the goal filter."""
        n = len(t)
        goals = np.tile(self.goal, (n, 1))
        omega = np.zeros((n, 3))
        alpha, beta = self.settings.alpha, self.settings.beta_value
        for when, target in goal_changes:
            k = min(int(np.ceil(when / dt - 1e-9)), n - 1)
            target = np.asarray(target, dtype=float) / np.linalg.norm(target)
            d0 = goal_error(target, goals[k])
            # z = tau d' with d' = -J_l(-d)^-1 omega_g: the goal's angular velocity carries on.
            z0 = -tau * np.linalg.solve(quat.left_jacobian(-d0), omega[k])
            d, z = step_transformation_system(
                d0, np.zeros(3), np.zeros((n - k, 3)), tau, dt, alpha, beta, start_rate=z0
            )
            goals[k:] = orientation_from_error(d, target)
            omega[k:] = angular_velocity(d, z / tau, np.zeros(3))
        return goals, omega
