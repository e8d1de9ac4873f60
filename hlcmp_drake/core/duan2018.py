"""Baseline control laws the paper compares against, pure numpy.

- Constant impedance: the paper's Eq. 4 with fixed K_s, K_d (see `control_law`).
- The force-tracking adaptive variable-impedance controller standing in for the
  paper's ref. [21], which the paper does not identify:

  J. Duan, Y. Gan, M. Chen, X. Dai, "Adaptive variable impedance control for dynamic
  contact force tracking in uncertain environment", Robotics and Autonomous Systems
  102 (2018) 54-65.

  Position-based (admittance) impedance with zero target stiffness in the force-tracked
  direction and an adaptive damping term:

      m e_c'' + (b + Delta_b(t)) e_c' = Delta_f(t),     e_c = x_c - x_r
      Delta_b(t) = b Phi(t) / e_c'(t)
      =>  m e_c'' + b (e_c' + Phi(t)) = Delta_f(t)
      Phi(t) = Phi(t - lambda) + sigma Delta_f(t - lambda) / b

  with sampling period lambda and update rate sigma. Here the force is the reaction
  f_e of the environment on the robot along the axis (the wrist sensor's reading), so
  Delta_f = f_d - f_e with f_d the desired reaction, and the sign of the position error
  is the one that makes the robot press harder when f_e < f_d. At rest in contact
  e_c' = 0 and Phi is stationary only when Delta_f = 0: the contact force tracks f_d
  whatever the environment's stiffness and location, which is the point of [21].
  Where the task asks for no force (f_d = 0: the retreat of the 1-DOF experiment) the
  controller is a plain impedance m e'' + b e' + k e = 0 about x_r with Phi held at 0,
  because with zero stiffness nothing would bring it back to x_r in free space.
  The commanded x_c is tracked by an inner inverse-dynamics PD loop.
"""

import numpy as np

from hlcmp_drake.core.control_law import tracking_errors
from hlcmp_drake.core.kernels import jitable


@jitable
def duan_adaptation_step(
    phi: np.ndarray, delta_f: np.ndarray, sigma: float, b: np.ndarray
) -> np.ndarray:
    """Duan et al. 2018: Phi(t) = Phi(t - lambda) + sigma Delta_f(t - lambda) / b.

    Parameters
    ----------
    phi : (M,) array
        Phi(t - lambda) [m/s].
    delta_f : (M,) array
        Force error Delta_f(t - lambda) [N].
    sigma : float
        Update rate [-].
    b : (M,) array
        Target damping [N s/m].

    Returns
    -------
    (M,) array
        Phi(t) [m/s].
    """
    return phi + sigma * delta_f / b


@jitable
def duan_force_error(f_desired: np.ndarray, f_measured: np.ndarray) -> np.ndarray:
    """Delta_f = f_d - f_e (desired minus measured reaction force), per axis.

    Parameters
    ----------
    f_desired : (M,) array
        Desired reaction force f_d [N].
    f_measured : (M,) array
        Measured reaction force f_e [N].

    Returns
    -------
    (M,) array
        Delta_f [N].
    """
    return np.asarray(f_desired) - f_measured


@jitable
def duan_admittance_acceleration(
    e_c: np.ndarray,
    e_c_dot: np.ndarray,
    phi: np.ndarray,
    delta_f: np.ndarray,
    mass: np.ndarray,
    damping: np.ndarray,
    stiffness: np.ndarray,
) -> np.ndarray:
    """Duan et al. 2018 target impedance solved for e_c'':

        m e_c'' + b (e_c' + Phi) + k e_c = -Delta_f

    (k = 0 while tracking a force; the minus sign makes the robot move against the
    reaction, i.e. press harder, when the measured reaction is below the desired one).

    Parameters
    ----------
    e_c, e_c_dot : (M,) arrays
        e_c = x_c - x_r [m] and its rate [m/s].
    phi : (M,) array
        Phi [m/s].
    delta_f : (M,) array
        Force error Delta_f [N].
    mass : (M,) array
        Target mass m [kg].
    damping : (M,) array
        Target damping b [N s/m].
    stiffness : (M,) array
        Target stiffness k [N/m].

    Returns
    -------
    (M,) array
        e_c'' [m/s^2].
    """
    return (-delta_f - damping * (e_c_dot + phi) - stiffness * e_c) / mass


@jitable
def inner_position_loop(
    inertia: np.ndarray,
    coriolis_term: np.ndarray,
    gravity: np.ndarray,
    xc_ddot: np.ndarray,
    xc_dot: np.ndarray,
    xc: np.ndarray,
    x: np.ndarray,
    xdot: np.ndarray,
    kp: np.ndarray,
    kv: np.ndarray,
    f_ext: np.ndarray,
) -> np.ndarray:
    """Inverse-dynamics PD tracking of the admittance output x_c (the inner loop of a
    position-based impedance controller), with the measured external force cancelled:
    f = M (x_c'' + kv (x_c' - x') + kp (x_c - x)) + C x' + G - f_ext.

    Parameters
    ----------
    inertia : (M, M) array
        Task-space inertia [kg], from Drake.
    coriolis_term : (M,) array
        C x' [N]: the task-space Coriolis matrix [kg/s] times the measured velocity.
    gravity : (M,) array
        Task-space gravity force [N].
    xc_ddot, xc_dot, xc : (M,) arrays
        Commanded acceleration [m/s^2], velocity [m/s] and position [m].
    x, xdot : (M,) arrays
        Measured position [m] and velocity [m/s].
    kp : (M,) array
        Position gain [1/s^2].
    kv : (M,) array
        Velocity gain [1/s].
    f_ext : (M,) array
        Measured external (reaction) force [N].

    Returns
    -------
    (M,) array
        Commanded task-space force f [N].
    """
    return (
        inertia @ (xc_ddot + kv * (xc_dot - xdot) + kp * (xc - x)) + coriolis_term + gravity - f_ext
    )


@jitable
def duan_commanded_motion(
    xc: np.ndarray,
    xc_dot: np.ndarray,
    phi: np.ndarray,
    xr: np.ndarray,
    xr_dot: np.ndarray,
    xr_ddot: np.ndarray,
    f_desired: np.ndarray,
    f_measured: np.ndarray,
    mass: np.ndarray,
    damping: np.ndarray,
    free_stiffness: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The admittance of Duan et al. 2018 at one instant, per axis: where a force is asked
    for (f_d != 0) the force-tracking impedance with zero stiffness and Phi, elsewhere the
    plain impedance about x_r with `free_stiffness` and Phi and Delta_f taken as 0.

    Parameters
    ----------
    xc, xc_dot : (M,) arrays
        The commanded position x_c [m] and velocity x_c' [m/s].
    phi : (M,) array
        Phi [m/s].
    xr, xr_dot, xr_ddot : (M,) arrays
        The reference [m], [m/s], [m/s^2].
    f_desired, f_measured : (M,) arrays
        f_d and the measured reaction f_e [N].
    mass, damping, free_stiffness : (M,) arrays
        m [kg], b [N s/m], k where f_d = 0 [N/m].

    Returns
    -------
    xc_ddot : (M,) array
        x_c'' = x_r'' + e_c'' [m/s^2].
    delta_f : (M,) array
        Delta_f where a force is tracked, 0 elsewhere [N].
    tracking : (M,) bool array
        Where a force is asked for.
    """
    tracking = np.asarray(f_desired) != 0
    delta_f = np.where(tracking, duan_force_error(f_desired, f_measured), 0.0)
    e_c, e_c_dot = tracking_errors(xc, xc_dot, xr, xr_dot)
    ec_ddot = duan_admittance_acceleration(
        e_c,
        e_c_dot,
        np.where(tracking, phi, 0.0),
        delta_f,
        mass,
        damping,
        np.where(tracking, 0.0, free_stiffness),
    )
    return xr_ddot + ec_ddot, delta_f, tracking


@jitable
def duan_phi_update(
    phi: np.ndarray, delta_f: np.ndarray, tracking: np.ndarray, sigma: float, b: np.ndarray
) -> np.ndarray:
    """Phi after one sample period: `duan_adaptation_step` where a force is tracked, 0
    (held) elsewhere.

    Parameters
    ----------
    phi, delta_f : (M,) arrays
        Phi(t - lambda) [m/s] and Delta_f(t - lambda) [N].
    tracking : (M,) bool array
        Where a force is asked for.
    sigma : float
        Update rate [-].
    b : (M,) array
        Target damping [N s/m].

    Returns
    -------
    (M,) array
        Phi(t) [m/s].
    """
    return np.where(tracking, duan_adaptation_step(phi, delta_f, sigma, b), 0.0)
