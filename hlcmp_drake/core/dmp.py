"""Discrete Dynamic Movement Primitives, one per Cartesian axis (paper Eqs. 6-13, 15, 18-21).

Pure numpy; nothing here needs Drake. Each paper equation lives in exactly one function
below, named in its docstring. The Drake DMP source system calls `transformation_rates`
and `canonical_phase_rate`; the offline rollout integrates the very same functions.

Defaults (the paper leaves them open):
- alpha = 25, beta = alpha / 4 (critically damped transformation system),
- alpha_s = 4, so the phase has decayed to exp(-4) ~ 0.018 at t = tau,
- N = 30 basis functions, centres equally spaced in *time* over [0, tau] and mapped
  through s(t) = exp(-alpha_s t / tau), widths h_n = 2 / (c_{n+1} - c_n)^2 so that
  neighbouring kernels cross at exp(-1) of their peak.
"""

import dataclasses
import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from hlcmp_drake.core.kernels import jitable

# Axes with |g - p0| below this fraction of the demonstration's range are "g ~ p0" axes
# (reach down, cut, come back up): their Eq. 13 amplitude would vanish; the range is used.
DEGENERATE_GOAL_FRACTION = 0.1
# The regression also sees the demonstration's end held at rest for this fraction of tau.
TAIL_FRACTION = 0.5


# The most basis functions a DMP may have: the fit solves an N x N system per axis (8 MB at
# 1000; 100 000 would need 80 GB). The bundled scenarios use 10 to 30.
MAX_BASIS_FUNCTIONS = 1000
# How many feature values (samples x axes x N) are held at once (32 MB): the fit and a
# rollout's forcing take the features of a long demonstration or rollout this many at a
# time (an hour at 1 kHz, 3 axes and 30 basis functions: 2.6 GB at once).
FEATURE_CHUNK_VALUES = 2**22


@dataclass
class DmpSettings:
    """Shape parameters of the DMP and of the phase basis it shares with the compliant
    profiles (Eqs. 13, 16). The scenario's YAML reads into this same class (its `dmp`
    field), so N has one default and one check.

    Attributes
    ----------
    n_basis : int
        N, the number of radial basis functions per axis (>= 2).
    alpha : float
        Gain of the transformation system (Eq. 15), > 0.
    beta : float or None
        Its second gain; None means alpha / 4 (critical damping), see `beta_value`.
    alpha_s : float
        Decay rate of the canonical system (Eq. 8), > 0.
    smoothing_s : float
        Std-dev [s] of the zero-phase Gaussian smoothing applied to a demonstration
        before differentiation; 0 turns smoothing off.
    """

    n_basis: int = 30
    alpha: float = 25.0
    beta: float | None = None
    alpha_s: float = 4.0
    smoothing_s: float = 0.01

    def __post_init__(self):
        self.check()

    def check(self) -> None:
        """Raise ValueError, naming the field, if a value is out of its range."""
        if not 2 <= self.n_basis <= MAX_BASIS_FUNCTIONS:
            raise ValueError(
                f"n_basis must be between 2 and {MAX_BASIS_FUNCTIONS}, got {self.n_basis}"
            )
        for name in ("alpha", "alpha_s", "beta"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive and finite, got {value}")
        if not (np.isfinite(self.smoothing_s) and self.smoothing_s >= 0):
            raise ValueError(f"smoothing_s must be >= 0 and finite, got {self.smoothing_s}")

    @property
    def beta_value(self) -> float:
        """beta of Eq. 15: as given, or alpha / 4 (critically damped)."""
        return self.alpha / 4.0 if self.beta is None else self.beta


# --------------------------------------------------------------------------------------
# Canonical system and basis
# --------------------------------------------------------------------------------------


def canonical_phase_rate(s: float | np.ndarray, tau: float, alpha_s: float) -> float | np.ndarray:
    """Eq. 8: tau * ds/dt = -alpha_s * s; returns ds/dt.

    Parameters
    ----------
    s : float or array
        Phase [-], any shape.
    tau : float
        Time constant [s] (the movement's duration).
    alpha_s : float
        Decay rate of the canonical system [-], > 0.

    Returns
    -------
    float or array
        ds/dt [1/s], the shape of `s`.
    """
    return -alpha_s * s / tau


def phase_at(t: float | np.ndarray, tau: float, alpha_s: float) -> np.ndarray:
    """The closed-form solution s(t) = exp(-alpha_s t / tau) of Eq. 8 with s(0) = 1.

    Parameters
    ----------
    t : float or (T,) array
        Time since the start [s].
    tau : float
        Time constant [s].
    alpha_s : float
        Decay rate of the canonical system [-], > 0.

    Returns
    -------
    array
        The phase s [-] in (0, 1], the shape of `t` (0-d for a scalar).
    """
    return np.exp(-alpha_s * np.asarray(t, dtype=float) / tau)


def basis_centers_and_widths(n_basis: int, alpha_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Centres c_n equally spaced in time, mapped through s(t); widths from the spacing.

    Parameters
    ----------
    n_basis : int
        N, the number of basis functions (>= 2).
    alpha_s : float
        Decay rate of the canonical system [-], > 0.

    Returns
    -------
    centers : (N,) array
        c_n = exp(-alpha_s n / (N - 1)), n = 0..N-1, in phase units [-], decreasing from 1.
    widths : (N,) array
        h_n = 2 / (c_{n+1} - c_n)^2 [-]; the last one repeats the last spacing.
    """
    centers = phase_at(np.linspace(0.0, 1.0, n_basis), 1.0, alpha_s)
    spacing = np.abs(np.diff(centers))
    spacing = np.append(spacing, spacing[-1])
    widths = 2.0 / spacing**2
    return centers, widths


@jitable
def rbf_activations(s: float | np.ndarray, centers: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """Eq. 10: omega_n(s) = exp(-0.5 h_n (s - c_n)^2). s scalar -> (N,), s (T,) -> (T, N).

    Parameters
    ----------
    s : float or (T,) array
        Phase [-].
    centers, widths : (N,) arrays
        Centres c_n [-] and widths h_n [-] (see `basis_centers_and_widths`).

    Returns
    -------
    (N,) or (T, N) array
        Activations omega_n(s) [-], in (0, 1].
    """
    return np.exp(rbf_exponents(s, centers, widths))


@jitable
def rbf_exponents(s: float | np.ndarray, centers: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """Eq. 10's exponents: -0.5 h_n (s - c_n)^2, so that omega_n(s) = exp of them.

    Parameters
    ----------
    s, centers, widths
        As for `rbf_activations`.

    Returns
    -------
    (N,) or (T, N) array
        [-], <= 0.
    """
    s = np.asarray(s, dtype=np.float64)
    return -0.5 * widths * (s[..., None] - centers) ** 2


@jitable
def normalized_basis(s: float | np.ndarray, centers: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """Eq. 16: [g(s)]_n = omega_n(s) / sum_k omega_k(s), the compliant-profile basis.

    Parameters
    ----------
    s, centers, widths
        As for `rbf_activations`.

    Returns
    -------
    (N,) or (T, N) array
        g(s) [-], each row summing to 1.
    """
    s = np.asarray(s, dtype=np.float64)
    exponents = rbf_exponents(s, centers, widths)
    # A common factor leaves the ratio as it is. Past the last centre (late in the phase)
    # every activation may underflow to 0, which would make it 0/0; there the last
    # centre's is the largest (`basis_centers_and_widths`), so it is divided out.
    past = np.expand_dims(s, -1) < centers[-1]
    omega = np.exp(exponents - np.where(past, exponents[..., -1:], 0.0))
    return omega / np.expand_dims(np.sum(omega, axis=-1), -1)


def forcing_basis(
    s: float | np.ndarray, centers: np.ndarray, widths: np.ndarray, amplitude: np.ndarray
) -> np.ndarray:
    """Eq. 13: [g_p(s)]_n = omega_n(s) s (g - p0) / sum_k omega_k(s).

    `amplitude` is (g - p0) per axis, or the documented substitute on a g ~ p0 axis
    (see `Dmp.amplitude`). Shapes: s scalar and amplitude (M,) -> (M, N).

    Parameters
    ----------
    s, centers, widths
        As for `rbf_activations`.
    amplitude : (M,) array
        The amplitude per axis [m].

    Returns
    -------
    (M, N) or (T, M, N) array
        g_p(s) [m], for a scalar `s` or a (T,) `s`.
    """
    g = normalized_basis(s, centers, widths)
    s = np.asarray(s, dtype=float)
    return (g * s[..., None])[..., None, :] * np.asarray(amplitude, dtype=float)[:, None]


# --------------------------------------------------------------------------------------
# Transformation system
# --------------------------------------------------------------------------------------


def transformation_rates(
    p: float | np.ndarray,
    z: float | np.ndarray,
    forcing: float | np.ndarray,
    goal: float | np.ndarray,
    tau: float,
    alpha: float,
    beta: float,
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """Eqs. 15 and 7: tau z' = alpha (beta (g - p) - z) + f,  tau p' = z.

    `forcing` is f = theta_p . g_p(s) per axis. Returns (dp/dt, dz/dt).

    Parameters
    ----------
    p : float or (M,) or (T, M) array
        Position [m].
    z : float or array, shaped like `p`
        Scaled velocity z = tau p' [m].
    forcing : float or array, shaped like `p`
        Forcing term f [m].
    goal : float or (M,) array
        Goal g [m].
    tau : float
        Time constant [s].
    alpha, beta : float
        Gains of the transformation system [-].

    Returns
    -------
    pdot, zdot : floats or arrays, broadcast shape of the inputs
        dp/dt [m/s] and dz/dt [m/s].
    """
    zdot = (alpha * (beta * (goal - p) - z) + forcing) / tau
    pdot = z / tau
    return pdot, zdot


def transformation_matrices(tau: float, alpha: float, beta: float) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. 7 and 15 of one axis as the linear system x' = A x + b w, x = [p, z], with the
    drive w = alpha beta g + f. A and b are read off `transformation_rates`, which is
    linear in p, z and w, so the equations stay in that one function.

    Parameters
    ----------
    tau, alpha, beta : float
        As for `transformation_rates`.

    Returns
    -------
    a : (2, 2) array
        The state matrix [1/s].
    b : (2,) array
        The drive's column [1/s].
    """
    a = np.column_stack(
        [
            np.asarray(transformation_rates(1.0, 0.0, 0.0, 0.0, tau, alpha, beta)),
            np.asarray(transformation_rates(0.0, 1.0, 0.0, 0.0, tau, alpha, beta)),
        ]
    )
    return a, np.array(transformation_rates(0.0, 0.0, 1.0, 0.0, tau, alpha, beta))


def forcing_target(
    p: np.ndarray,
    pdot: np.ndarray,
    pddot: np.ndarray,
    goal: float,
    tau: float,
    alpha: float,
    beta: float,
) -> np.ndarray:
    """Eq. 19: f_target = tau^2 p'' + alpha tau p' - alpha beta (g - p).

    Parameters
    ----------
    p, pdot, pddot : (T,) arrays
        Demonstrated position [m], velocity [m/s] and acceleration [m/s^2] of one axis.
    goal : float
        Goal g [m] of that axis.
    tau, alpha, beta : float
        The demonstration's duration [s] and the gains of Eq. 15 [-].

    Returns
    -------
    (T,) array
        f_target [m].
    """
    return tau**2 * pddot + alpha * tau * pdot - alpha * beta * (goal - p)


def solve_forcing_weights(gram: np.ndarray, moment: np.ndarray, ridge: float = 1e-9) -> np.ndarray:
    """Eq. 21: theta_p = argmin ||f_target - theta_p . g_p||^2, one axis, from its normal
    equations (G^T G) theta_p = G^T f_target, G the (T, N) features.

    Solved as regularized least squares over all samples at once (not per-kernel LWR):
    the ridge term is relative to the feature energy and only guards against kernels that
    see almost no samples.

    Parameters
    ----------
    gram : (N, N) array
        G^T G [m^2].
    moment : (N,) array
        G^T f_target [m^2].
    ridge : float
        Regularization relative to the mean diagonal of the Gram matrix [-].

    Returns
    -------
    (N,) array
        theta_p of the axis [-].
    """
    reg = ridge * np.trace(gram) / gram.shape[0]
    return np.linalg.solve(gram + reg * np.eye(gram.shape[0]), moment)


def fit_forcing_weights(
    features: np.ndarray, targets: np.ndarray, ridge: float = 1e-9
) -> np.ndarray:
    """Eq. 21 (`solve_forcing_weights`) for one axis's features and targets.

    Parameters
    ----------
    features : (T, N) array
        g_p(s) [m] of one axis at every sample.
    targets : (T,) array
        f_target [m] at every sample.
    ridge : float
        As for `solve_forcing_weights`.

    Returns
    -------
    (N,) array
        theta_p of the axis [-].
    """
    return solve_forcing_weights(features.T @ features, features.T @ targets, ridge)


def fit_weights_in_chunks(
    s: np.ndarray, features_at: Callable[[np.ndarray], np.ndarray], targets: np.ndarray
) -> np.ndarray:
    """Eq. 21 (`solve_forcing_weights`) for every axis, its normal equations summed over
    chunks of samples of at most FEATURE_CHUNK_VALUES features: those of an hour at 1 kHz would
    take gigabytes at once. A demonstration of one chunk (46 s at 1 kHz for 3 axes and 30
    basis functions) is fitted with the arithmetic of `fit_forcing_weights` on all of it.

    Parameters
    ----------
    s : (T,) array
        The phase at every sample [-].
    features_at : callable((c,) array) -> (c, M, N) array
        The features of each axis at those phases.
    targets : (T, M) array
        What each axis's features are fitted to.

    Returns
    -------
    (M, N) array
        The weights of each axis.
    """
    axes, n = targets.shape[1], len(features_at(s[:1])[0, 0])
    chunk = max(1, FEATURE_CHUNK_VALUES // (axes * n))
    gram, moment = np.zeros((axes, n, n)), np.zeros((axes, n))
    for start in range(0, len(s), chunk):
        rows = slice(start, start + chunk)
        features = features_at(s[rows])
        for m in range(axes):
            gram[m] += features[:, m, :].T @ features[:, m, :]
            moment[m] += features[:, m, :].T @ targets[rows, m]
    return np.stack([solve_forcing_weights(gram[m], moment[m]) for m in range(axes)])


# --------------------------------------------------------------------------------------
# Demonstration preprocessing
# --------------------------------------------------------------------------------------


def _smooth(values, sigma_samples):
    """Zero-phase Gaussian smoothing with odd reflection at both ends.

    Odd reflection (2 p_0 - p_k) keeps the end values and end slopes, so the start and goal
    of a demonstration are not pulled inward as plain zero/even padding would.
    """
    if sigma_samples <= 0 or len(values) < 3:
        return values
    half = min(int(np.ceil(4 * sigma_samples)), len(values) - 1)
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma_samples) ** 2)
    kernel /= kernel.sum()
    head = 2 * values[0] - values[half:0:-1]
    tail = 2 * values[-1] - values[-2 : -half - 2 : -1]
    return np.convolve(np.concatenate([head, values, tail]), kernel, mode="valid")


def _uniform_grid(t: np.ndarray, dt: float | None = None) -> np.ndarray:
    """The evenly spaced times `resample_and_differentiate` resamples a demonstration at:
    from t[0] to t[-1], `dt` apart (default the median spacing, at most 10 ms) adjusted to
    a whole number of steps."""
    if dt is None:
        dt = min(float(np.median(np.diff(t))), 0.01)
    return np.linspace(t[0], t[-1], int(round((t[-1] - t[0]) / dt)) + 1)


def with_settled_tail(t_uniform: np.ndarray) -> np.ndarray:
    """A resampled demonstration's times (from 0, evenly spaced) followed by TAIL_FRACTION
    * tau more at the same spacing, where the fit holds the demonstration at rest at its end.

    Parameters
    ----------
    t_uniform : (T,) array
        From `resample_and_differentiate`.

    Returns
    -------
    (T + K,) array
        The times the forcing weights are fitted at [s].
    """
    tau, dt = float(t_uniform[-1]), t_uniform[1] - t_uniform[0]
    return np.concatenate([t_uniform, tau + dt * np.arange(1, int(TAIL_FRACTION * tau / dt) + 1)])


def fit_sample_count(t: np.ndarray) -> int:
    """How many samples `Dmp.fit` sets the forcing weights from for a demonstration sampled
    at `t`: resampled (`resample_and_differentiate`) and with its settled tail. More basis
    functions than these leave the weights undetermined between the samples, where the
    fitted path then strays (with 201 samples over 2 s: within 0.02 mm at N = 300, the
    count, and 37 mm at N = 1000).

    Parameters
    ----------
    t : (K,) array
        The demonstration's sample times [s], increasing.

    Returns
    -------
    int
    """
    grid = _uniform_grid(np.asarray(t, dtype=float))
    return len(with_settled_tail(grid - grid[0]))


def resample_and_differentiate(
    t: np.ndarray, positions: np.ndarray, smoothing_s: float, dt: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Uniform resampling, smoothing and derivatives of a (possibly uneven, noisy) demo.

    1. Linear interpolation onto a uniform grid with the demonstration's median spacing
       (capped at 10 ms), starting at t[0].
    2. Zero-phase Gaussian smoothing of the positions (std-dev `smoothing_s`).
    3. Central differences (np.gradient) for velocity and acceleration.
    Returns (t_uniform - t[0], p, pdot, pddot), p of shape (T, M).

    Parameters
    ----------
    t : (K,) array
        Sample times [s], increasing.
    positions : (K,) or (K, M) array
        Positions [m] at those times.
    smoothing_s : float
        Std-dev of the smoothing [s]; 0 turns it off.
    dt : float, optional
        Grid spacing [s], adjusted to a whole number of steps over the demonstration;
        default as in step 1.

    Returns
    -------
    t_uniform : (T,) array
        Uniform times [s] from 0.
    p, pdot, pddot : (T, M) arrays
        Position [m], velocity [m/s] and acceleration [m/s^2].
    """
    t = np.asarray(t, dtype=float)
    positions = np.asarray(positions, dtype=float).reshape(len(t), -1)
    grid = _uniform_grid(t, dt)
    dt = grid[1] - grid[0]
    p = np.column_stack([np.interp(grid, t, positions[:, m]) for m in range(positions.shape[1])])
    p = np.column_stack([_smooth(p[:, m], smoothing_s / dt) for m in range(p.shape[1])])
    pdot = np.gradient(p, dt, axis=0)
    pddot = np.gradient(pdot, dt, axis=0)
    return grid - grid[0], p, pdot, pddot


# --------------------------------------------------------------------------------------
# The DMP of a whole demonstration
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Dmp:
    """A fitted per-axis DMP.

    theta_p: (M, N) forcing weights. amplitude: (M,) the Eq. 13 amplitude used in the fit.
    goal_scaled: (M,) bool; True where the amplitude is (g - p0) and scales with a new
    goal, False on a g ~ p0 axis, where the amplitude is the demonstration's range on that
    axis and stays fixed (Hoffmann/Pastor-style; a new goal then shifts the end point but
    does not rescale the shape).
    """

    settings: DmpSettings
    tau: float
    start: np.ndarray
    goal: np.ndarray
    theta_p: np.ndarray
    amplitude: np.ndarray
    goal_scaled: np.ndarray
    axis_names: tuple[str, ...]

    @property
    def n_axes(self) -> int:
        """M, the number of axes."""
        return len(self.axis_names)

    @functools.cached_property
    def basis(self) -> tuple[np.ndarray, np.ndarray]:
        """(centers, widths) of the phase basis, computed once per DMP, each (N,) [-]."""
        return basis_centers_and_widths(self.settings.n_basis, self.settings.alpha_s)

    @classmethod
    def fit(
        cls,
        t: np.ndarray,
        positions: np.ndarray,
        axis_names: Sequence[str],
        settings: DmpSettings | None = None,
    ) -> "Dmp":
        """Table I step II: fit theta_p to a demonstration (Eqs. 18-21), tau = its duration.

        Parameters
        ----------
        t : (T,) array
            Sample times [s], strictly increasing (uneven sampling is resampled).
        positions : (T, M) array
            Demonstrated positions [m], one column per axis.
        axis_names : sequence of M str
            Names of the axes, e.g. ("x", "y", "z").
        settings : DmpSettings, optional
            N, alpha, beta, alpha_s and the smoothing; a copy is kept (default DmpSettings()).

        Returns
        -------
        Dmp
            The fitted primitive, with g = the last sample and p0 = the first.
        """
        settings = dataclasses.replace(settings) if settings is not None else DmpSettings()
        t_u, p, pdot, pddot = resample_and_differentiate(t, positions, settings.smoothing_s)
        tau = float(t_u[-1])
        start, goal = p[0].copy(), p[-1].copy()
        span = np.ptp(p, axis=0)
        goal_scaled = np.abs(goal - start) >= DEGENERATE_GOAL_FRACTION * np.maximum(span, 1e-12)
        amplitude = np.where(goal_scaled, goal - start, np.maximum(span, 1e-12))
        centers, widths = basis_centers_and_widths(settings.n_basis, settings.alpha_s)
        # A settled tail: the demonstration ends at rest at its goal, so over a further
        # TAIL_FRACTION * tau (the phase still decaying) the forcing term must vanish. Without
        # these samples the last kernels, whose features s (g - p0) are tiny near the end, get
        # large weights from noise, and the DMP drifts away from the goal after t = tau.
        s = phase_at(with_settled_tail(t_u), tau, settings.alpha_s)
        targets = np.zeros((len(s), p.shape[1]))
        for m in range(p.shape[1]):
            targets[: len(t_u), m] = forcing_target(
                p[:, m], pdot[:, m], pddot[:, m], goal[m], tau, settings.alpha, settings.beta_value
            )
        theta_p = fit_weights_in_chunks(
            s, lambda phases: forcing_basis(phases, centers, widths, amplitude), targets
        )
        return cls(settings, tau, start, goal, theta_p, amplitude, goal_scaled, tuple(axis_names))

    def with_goal(self, goal: np.ndarray) -> "Dmp":
        """The same skill aimed at a new goal (amplitudes of goal-scaled axes follow it).

        Parameters
        ----------
        goal : (M,) array
            The new goal g [m].

        Returns
        -------
        Dmp
            A copy with `goal` replaced; this DMP is unchanged.
        """
        goal = np.asarray(goal, dtype=float).reshape(self.n_axes)
        return dataclasses.replace(self, goal=goal)

    def current_amplitude(self) -> np.ndarray:
        """Eq. 13 amplitude for the present goal: g - p0, or the fixed range on g ~ p0 axes.

        Returns
        -------
        (M,) array
            The amplitude per axis [m].
        """
        return np.where(self.goal_scaled, self.goal - self.start, self.amplitude)

    def rates(
        self, p: np.ndarray, z: np.ndarray, s: float, tau: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """Time derivatives (p', z', s') of the DMP state, Eqs. 7, 8, 13, 15.

        Parameters
        ----------
        p : (M,) array
            Position [m].
        z : (M,) array
            Scaled velocity z = tau p' [m].
        s : float
            Phase [-].
        tau : float, optional
            Time constant [s]; default the demonstration's duration.

        Returns
        -------
        pdot, zdot : (M,) arrays
            dp/dt [m/s] and dz/dt [m/s].
        sdot : float
            ds/dt [1/s].
        """
        tau = self.tau if tau is None else tau
        pdot, zdot = transformation_rates(
            p, z, self.forcing(s), self.goal, tau, self.settings.alpha, self.settings.beta_value
        )
        sdot = float(canonical_phase_rate(s, tau, self.settings.alpha_s))
        return np.asarray(pdot), np.asarray(zdot), sdot

    def forcing(self, s: float | np.ndarray) -> np.ndarray:
        """f = theta_p . g_p(s) per axis (Eqs. 9/13); s scalar -> (M,), s (T,) -> (T, M).

        Parameters
        ----------
        s : float or (T,) array
            Phase [-].

        Returns
        -------
        (M,) or (T, M) array
            The forcing term f [m].
        """
        centers, widths, amplitude = *self.basis, self.current_amplitude()
        s = np.asarray(s, dtype=float)
        if s.ndim == 0:
            return np.sum(self.theta_p * forcing_basis(s, centers, widths, amplitude), axis=-1)
        chunk = max(1, FEATURE_CHUNK_VALUES // self.theta_p.size)
        return np.concatenate(
            [
                np.sum(self.theta_p * forcing_basis(phases, centers, widths, amplitude), axis=-1)
                for phases in np.split(s, range(chunk, len(s), chunk))
            ]
        ).reshape(len(s), self.n_axes)

    def rollout(
        self, duration: float | None = None, dt: float = 0.001, tau: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The DMP from its start, sampled every dt; returns t, p, pdot, pddot, s.

        tau defaults to the demonstration's duration; another tau is temporal scaling.
        duration defaults to tau. The phase has a closed form (Eq. 8), so the forcing term
        is evaluated at every sample in one vectorized pass; the transformation system
        (Eqs. 7, 15) is linear, so it is stepped exactly for a forcing that varies
        linearly between samples (first-order hold), one 2 x 2 matrix product a step.

        Parameters
        ----------
        duration : float, optional
            Length of the rollout [s]; default tau.
        dt : float
            Sample period [s].
        tau : float, optional
            Time constant [s]; default the demonstration's duration.

        Returns
        -------
        t : (T,) array
            Sample times [s] from 0, T = round(duration / dt) + 1.
        p, pdot, pddot : (T, M) arrays
            Position [m], velocity [m/s] and acceleration [m/s^2].
        s : (T,) array
            Phase [-].
        """
        tau = self.tau if tau is None else float(tau)
        t, s = rollout_times(tau, duration, dt, self.settings.alpha_s)
        forcing = self.forcing(s)  # (n, M)
        alpha, beta, goal = self.settings.alpha, self.settings.beta_value, self.goal
        p, z = step_transformation_system(self.start, goal, forcing, tau, dt, alpha, beta)
        pdot, zdot = transformation_rates(p, z, forcing, goal, tau, alpha, beta)
        return t, p, np.asarray(pdot), np.asarray(zdot) / tau, s


def rollout_times(
    tau: float, duration: float | None, dt: float, alpha_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """A rollout's sample times and their phase (Eq. 8's closed form).

    Parameters
    ----------
    tau : float
        Time constant [s].
    duration : float or None
        Length [s]; None means tau.
    dt : float
        Sample period [s].
    alpha_s : float
        Decay rate of the canonical system [-].

    Returns
    -------
    t : (T,) array
        Times [s] from 0, T = round(duration / dt) + 1.
    s : (T,) array
        Phase [-].
    """
    n = int(round((tau if duration is None else float(duration)) / dt)) + 1
    t = np.arange(n) * dt
    return t, phase_at(t, tau, alpha_s)


def step_transformation_system(
    start: np.ndarray,
    goal: np.ndarray,
    forcing: np.ndarray,
    tau: float,
    dt: float,
    alpha: float,
    beta: float,
    start_rate: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. 7 and 15 from p = start and z = start_rate (default 0), stepped exactly for a
    forcing term sampled every dt and linear between samples (first-order hold): the
    system is linear (`transformation_matrices`), so each step is one 2 x 2 matrix product.

    Parameters
    ----------
    start : (M,) array
        p at the first sample.
    goal : (M,) array
        g of Eq. 15.
    forcing : (T, M) array
        f at every sample.
    tau, dt : float
        Time constant and sample period [s].
    alpha, beta : float
        Gains of Eq. 15 [-].
    start_rate : (M,) array, optional
        z at the first sample; default zero (at rest).

    Returns
    -------
    p, z : (T, M) arrays
        Position and scaled velocity z = tau p' at every sample.
    """
    n, m = forcing.shape
    a, b = transformation_matrices(tau, alpha, beta)
    phi, gamma0, gamma1 = _first_order_hold(a, b, dt)
    u = alpha * beta * goal + forcing  # (n, M)
    slope = np.diff(u, axis=0, append=u[-1:]) / dt
    drive = gamma0[:, None, None] * u[None] + gamma1[:, None, None] * slope[None]  # (2, n, M)
    x = np.empty((n, 2, m))
    x[0] = [start, np.zeros(m) if start_rate is None else start_rate]
    for k in range(n - 1):
        x[k + 1] = phi @ x[k] + drive[:, k]
    return x[:, 0], x[:, 1]


def _first_order_hold(a, b, dt):
    """Exact discretization of x' = A x + b u with u linear over a step:
    x(t + dt) = Phi x + Gamma0 u(t) + Gamma1 u'(t). From the exponential of the augmented
    matrix [[A, b, 0], [0, 0, 1], [0, 0, 0]] dt (scaling and squaring of a Taylor series)."""
    m = np.zeros((4, 4))
    m[:2, :2], m[:2, 2], m[2, 3] = a, b, 1.0
    m *= dt
    squarings = max(0, int(np.ceil(np.log2(max(np.abs(m).sum(axis=1).max(), 1e-16) / 0.5))))
    m /= 2.0**squarings
    term, result = np.eye(4), np.eye(4)
    for k in range(1, 16):
        term = term @ m / k
        result = result + term
    for _ in range(squarings):
        result = result @ result
    return result[:2, :2], result[:2, 2], result[:2, 3]
