"""The demonstration's force in the skill: the feed-forward weights theta_v a kinesthetic
demonstration's wrist force gives, encoded on the phase basis as theta_p is (paper Sec. VI's
"include demonstration force information into the Hl-CMPs model").

Pure numpy. Why the demonstrated force *is* the feed-forward force, sign included: with
the errors of Eq. 5 and the sliding error eps of Eq. 29, Eqs. 2, 33 and 34 give the
closed loop

    M eps' + (C + L) eps = f_ext - u - v,

f_ext the environment's force on the tool (what a wrist sensor reads; a run's `f_ext`).
The tool stays on its reference (eps = 0) when v = f_ext - u, and with theta_k(t0) = 0
(u = 0) when v = f_ext: the feed-forward v, which Eq. 33 subtracts from the command,
equals the force the environment exerts, so the arm pushes back with -f_ext. Eq. 31's
theta_v' = Q_v eps g(s) stops there. So theta_v(t0) is the demonstrated force f_demo
itself on the basis g(s) of Eq. 16, with a plus sign: a foam that pushes the tool up
(+z) gets v_z > 0, and the command f_c = f_0 - u - v presses down.
Abu-Dakka et al. 2015 and Kramberger et al. 2017 encode demonstrated force profiles on a
DMP's phase in the same way.
"""

import numpy as np

from hlcmp_drake.core.adaptation import compliant_profiles
from hlcmp_drake.core.dmp import (
    DmpSettings,
    basis_centers_and_widths,
    fit_weights_in_chunks,
    normalized_basis,
    phase_at,
    resample_and_differentiate,
    with_settled_tail,
)


def fit_feedforward_weights(t: np.ndarray, force: np.ndarray, settings: DmpSettings) -> np.ndarray:
    """theta_v of a demonstrated force: theta_v = argmin ||f_demo - theta_v . g(s)||^2, the
    feed-forward profile of Eq. 14 (v = theta_v . g(s), g of Eq. 16) fitted to the force by
    regression, as Eq. 21 fits theta_p to f_target.

    The force is prepared as the positions are for theta_p (`Dmp.fit`): resampled to the
    same uniform grid, smoothed by the same zero-phase Gaussian (settings.smoothing_s),
    over the demonstration's duration tau with its phase s(t) = exp(-alpha_s t / tau); and
    it is held at its last value over the settled tail (`core.dmp.with_settled_tail`, a
    further TAIL_FRACTION * tau), where the demonstration rests (the positions' fit sees the
    forcing term vanish there), so the last basis functions, which carry the profile after
    tau, hold the force the demonstration ends with. Solved per axis by the regularized
    least squares of `fit_weights_in_chunks`.

    Parameters
    ----------
    t : (T,) array
        The demonstration's sample times [s], strictly increasing.
    force : (T, M) array
        The force the environment exerted on the tool at those times [N] (a wrist sensor's
        reading, world frame; `hlcmp_drake.io.demos`).
    settings : DmpSettings
        The skill's basis (N, alpha_s) and smoothing.

    Returns
    -------
    (M, N) array
        theta_v [N]: the feed-forward weights whose profile follows the demonstrated force;
        see the module docstring for why the sign is +.
    """
    t = np.asarray(t, dtype=float)
    t_u, smoothed, _, _ = resample_and_differentiate(t, force, settings.smoothing_s)
    s = phase_at(with_settled_tail(t_u), float(t_u[-1]), settings.alpha_s)
    centers, widths = basis_centers_and_widths(settings.n_basis, settings.alpha_s)
    targets = np.vstack([smoothed, np.repeat(smoothed[-1:], len(s) - len(t_u), axis=0)])
    axes = targets.shape[1]

    def features_at(phases):  # g(s), the same for every axis
        g = normalized_basis(phases, centers, widths)
        return np.broadcast_to(g[:, None, :], (len(g), axes, g.shape[1]))

    return fit_weights_in_chunks(s, features_at, targets)


def feedforward_along(theta_v: np.ndarray, s: np.ndarray, settings: DmpSettings) -> np.ndarray:
    """The feed-forward force v(s) = theta_v . g(s) of Eq. 14 (`compliant_profiles`) at a
    sequence of phases, e.g. a demonstration's encoded force along a rollout.

    Parameters
    ----------
    theta_v : (M, N) array
        Feed-forward weights [N].
    s : (T,) array
        Phases [-].
    settings : DmpSettings
        The basis (N, alpha_s).

    Returns
    -------
    (T, M) array
        v [N] at each phase.
    """
    g = normalized_basis(s, *basis_centers_and_widths(settings.n_basis, settings.alpha_s))
    _, _, v = compliant_profiles(theta_v, theta_v, theta_v, g.T)  # g's columns: all phases
    return v.T
