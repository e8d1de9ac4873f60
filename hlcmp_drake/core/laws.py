"""The task-space control laws at one instant: the Hl-CMP (Eqs. 4-5, 14, 16, 29, 31,
33-34), the constant impedance and the variable impedance (Duan et al. 2018) it is
compared with, composed from the functions that
hold those equations. Pure numpy.

Each law's arithmetic at one instant is a composed `jitable` function here
(`impedance_motion`, `hlcmp_force`, `hlcmp_rates`, `hlcmp_command`, `impedance_command`,
`variable_impedance_command`), run compiled or as numpy as `core.kernels.kernel_path` says
when the law is made; only the Coriolis product C_x w, which the fast path has Drake
evaluate, is formed between them. Each returns one array (its parts one after the other):
a compiled function hands every array it returns back to Python at a cost, so one per
call.

Every law has the shape of `ControlLaw`. Both ways of putting a law in a Drake diagram
evaluate these objects: the modular system `systems.law_controller.LawController` (θ its
continuous state) and the arm's one-call control loop (`systems.control_loop`). A new law is a
class here and an entry in the controller registry (`worlds.controllers`); it needs no
LeafSystem of its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Callable, NamedTuple, Protocol

import numpy as np

from hlcmp_drake.core.adaptation import adaptation_rates, compliant_profiles, forgetting_rates
from hlcmp_drake.core.control_law import (
    commanded_force,
    impedance_force,
    nominal_force,
    sliding_motion,
)
from hlcmp_drake.core.dmp import normalized_basis
from hlcmp_drake.core.duan2018 import (
    duan_commanded_motion,
    duan_phi_update,
    inner_position_loop,
)
from hlcmp_drake.core.kernels import implementation, jitable, kernel_path


class TaskSpaceInstant(NamedTuple):
    """What a law reads at one instant: the measured and desired motion, the phase, and
    the task-space dynamics terms of Eq. 2 (from Drake). Immutable; a named tuple rather
    than a frozen dataclass because a tick makes one every millisecond (a third of the cost).

    Attributes
    ----------
    x, xdot : (M,) arrays
        Measured position [m] and velocity [m/s].
    xd, xd_dot, xd_ddot : (M,) arrays
        Desired position [m], velocity [m/s] and acceleration [m/s^2].
    phase : float
        The canonical phase s [-].
    inertia : (M, M) array
        Task-space inertia [kg].
    coriolis : (M, M) array, or an operator with `@`
        Task-space Coriolis matrix [kg/s]; the laws only form `coriolis @ x_e'`, so the fast
        path passes `systems.task_space.CoriolisProduct`.
    gravity : (M,) array
        Task-space gravity force [N].
    time : float
        The instant [s] (read by a law with a schedule: the variable impedance's f_d(t)).
    external_force : (M,) array or None
        The measured reaction force of the environment on the robot [N], for a law that
        reads it (`reads_external_force`).
    """

    x: np.ndarray
    xdot: np.ndarray
    xd: np.ndarray
    xd_dot: np.ndarray
    xd_ddot: np.ndarray
    phase: float
    inertia: np.ndarray
    coriolis: np.ndarray
    gravity: np.ndarray
    time: float = 0.0
    external_force: np.ndarray | None = None


@dataclass
class LawOutput:
    """A law's evaluation.

    Attributes
    ----------
    force : (M,) array
        The commanded task-space force f_c [N] (Eq. 33).
    logs : dict of str to (M,) array
        The law's own series, by the name of the modular system's output port.
    rates : (P,) array or None
        A learning law's θ' (flattened θ_k, θ_d, θ_v rates, Eq. 31); None otherwise.
        Computed when first read, so a torque loop can send f_c before it spends time on θ'.
    """

    force: np.ndarray
    logs: dict
    rates_of: Callable[[], np.ndarray] | None = None

    @cached_property
    def rates(self) -> np.ndarray | None:
        """θ' (flattened), or None for a law that does not learn."""
        return None if self.rates_of is None else self.rates_of()


class ControlLaw(Protocol):
    """What the diagrams need of a task-space law.

    Attributes
    ----------
    learns : bool
        Whether its state θ is weights learned online (read back as a skill).
    reads_external_force : bool
        Whether it reads `TaskSpaceInstant.external_force`.
    log_fields : dict of str to str
        Its own series: the key in `LawOutput.logs` (and the modular system's output
        port) -> the series name in timeseries.npz.
    n_axes : int
        M, the task-space axes.
    theta_size : int
        The length of the flattened θ, the state Drake integrates from the law's rates (0
        for a law without one).
    """

    learns: bool
    reads_external_force: bool
    log_fields: dict[str, str]
    n_axes: int

    @property
    def theta_size(self) -> int:
        """The length of the flattened θ."""
        ...

    def command(self, now: TaskSpaceInstant, theta: np.ndarray) -> LawOutput:
        """The law's force, series and (learning) θ' at one instant.

        Parameters
        ----------
        now : TaskSpaceInstant
        theta : (theta_size,) array
        """
        ...

    def unflatten(self, theta: np.ndarray) -> tuple[np.ndarray, ...]:
        """θ's parts, each (M, N), from the flattened θ.

        Parameters
        ----------
        theta : (theta_size,) array
        """
        ...


@jitable
def impedance_motion(
    x: np.ndarray,
    xdot: np.ndarray,
    xd: np.ndarray,
    xd_dot: np.ndarray,
    xd_ddot: np.ndarray,
    pi: float,
) -> np.ndarray:
    """`core.control_law.sliding_motion` in one array: [e, e', ε, x_e', x_e''] (5 M,),
    what the impedance laws compute before C_x x_e'.

    Parameters
    ----------
    x, xdot, xd, xd_dot, xd_ddot : (M,) arrays
        Measured and desired motion [m], [m/s], [m/s^2].
    pi : float
        Slope of the sliding surface [1/s].

    Returns
    -------
    (5 M,) array
        e [m], e' [m/s], ε [m/s], x_e' [m/s], x_e'' [m/s^2].
    """
    e, edot, eps, xe_dot, xe_ddot = sliding_motion(x, xdot, xd, xd_dot, xd_ddot, pi)
    return np.concatenate((e, edot, eps, xe_dot, xe_ddot))


@jitable
def learned_impedance(
    phase: float,
    theta: np.ndarray,
    centers: np.ndarray,
    widths: np.ndarray,
    error: np.ndarray,
    error_rate: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The learned impedance at the phase s: g(s) (Eq. 16), the profiles K, D, v of the
    weights (Eq. 14) and u = K e + D e' (Eq. 4); for the translation (e, e') and, with
    (e_r, omega_e), for the rotation (`rotation_law.rotational_hlcmp_torque`).

    Parameters
    ----------
    phase : float
        s [-].
    theta : (3 M N,) array
        [θ_k, θ_d, θ_v], each (M, N) row-major.
    centers, widths : (N,) arrays
        The phase basis.
    error, error_rate : (M,) arrays
        The tracking error and its rate.

    Returns
    -------
    g : (N,) array
    stiffness, damping, feedforward, impedance : (M,) arrays
    """
    g = normalized_basis(np.array([phase]), centers, widths)[0]
    weights = theta.reshape(3, error.shape[0], centers.shape[0])
    stiffness, damping, feedforward = compliant_profiles(weights[0], weights[1], weights[2], g)
    impedance = impedance_force(stiffness, damping, error, error_rate)
    return g, stiffness, damping, feedforward, impedance


@jitable
def hlcmp_force(
    motion: np.ndarray,
    inertia: np.ndarray,
    coriolis_term: np.ndarray,
    gravity: np.ndarray,
    gain_l: np.ndarray,
    phase: float,
    theta: np.ndarray,
    centers: np.ndarray,
    widths: np.ndarray,
) -> np.ndarray:
    """The Hl-CMP's command after `impedance_motion`: g(s) (Eq. 16), the profiles (Eq. 14),
    u (Eq. 4), f_0 (Eq. 34) and f_c (Eq. 33).

    Parameters
    ----------
    motion : (5 M,) array
        From `impedance_motion`.
    inertia : (M, M) array
        Λ [kg].
    coriolis_term : (M,) array
        C_x x_e' [N].
    gravity : (M,) array
        G_x [N].
    gain_l : (M,) array
        Diagonal of L [N s/m].
    phase : float
        The phase s [-].
    theta : (3 M N,) array
        [θ_k, θ_d, θ_v], each (M, N) row-major.
    centers, widths : (N,) arrays
        The phase basis.

    Returns
    -------
    (6 M + N,) array
        f_c [N], K_s [N/m], K_d [N s/m], v [N], u [N], ε [m/s] (M each), then g(s) (N).
    """
    m = motion.shape[0] // 5
    e, edot, eps, xe_ddot = motion[:m], motion[m : 2 * m], motion[2 * m : 3 * m], motion[4 * m :]
    g, k_s, k_d, v, u = learned_impedance(phase, theta, centers, widths, e, edot)
    f0 = nominal_force(inertia, coriolis_term, gravity, xe_ddot, gain_l, eps)
    return np.concatenate((commanded_force(f0, u, v), k_s, k_d, v, u, eps, g))


@jitable
def hlcmp_rates(
    motion: np.ndarray, g: np.ndarray, q_k: np.ndarray, q_d: np.ndarray, q_v: np.ndarray
) -> np.ndarray:
    """θ' of Eq. 31 (`adaptation_rates`), flattened as θ = [θ_k, θ_d, θ_v].

    Parameters
    ----------
    motion : (5 M,) array
        From `impedance_motion`.
    g : (N,) array
        g(s).
    q_k, q_d, q_v : (M,) arrays
        The learning rates.

    Returns
    -------
    (3 M N,) array
    """
    m = motion.shape[0] // 5
    e, edot, eps = motion[:m], motion[m : 2 * m], motion[2 * m : 3 * m]
    k, d, v = adaptation_rates(eps, e, edot, g, q_k, q_d, q_v)
    return np.concatenate((k.ravel(), d.ravel(), v.ravel()))


@jitable
def hlcmp_command(
    x: np.ndarray,
    xdot: np.ndarray,
    xd: np.ndarray,
    xd_dot: np.ndarray,
    xd_ddot: np.ndarray,
    phase: float,
    inertia: np.ndarray,
    coriolis: np.ndarray,
    gravity: np.ndarray,
    pi: float,
    gain_l: np.ndarray,
    theta: np.ndarray,
    centers: np.ndarray,
    widths: np.ndarray,
    q_k: np.ndarray,
    q_d: np.ndarray,
    q_v: np.ndarray,
) -> np.ndarray:
    """The Hl-CMP at one instant where C_x is a matrix: `impedance_motion`, `hlcmp_force`
    and `hlcmp_rates` in one call.

    Parameters
    ----------
    x, xdot, xd, xd_dot, xd_ddot : (M,) arrays
        Measured and desired motion [m], [m/s], [m/s^2].
    phase : float
        The phase s [-].
    inertia, coriolis : (M, M) arrays
        Λ [kg] and C_x [kg/s].
    gravity : (M,) array
        G_x [N].
    pi : float
        Slope of the sliding surface [1/s].
    gain_l : (M,) array
        Diagonal of L [N s/m].
    theta : (3 M N,) array
        [θ_k, θ_d, θ_v].
    centers, widths : (N,) arrays
        The phase basis.
    q_k, q_d, q_v : (M,) arrays
        The learning rates.

    Returns
    -------
    (6 M + 3 M N,) array
        `hlcmp_force`'s first 6 M values, then θ' (`hlcmp_rates`).
    """
    m = x.shape[0]
    motion = impedance_motion(x, xdot, xd, xd_dot, xd_ddot, pi)
    out = hlcmp_force(
        motion,
        inertia,
        coriolis @ motion[3 * m : 4 * m],
        gravity,
        gain_l,
        phase,
        theta,
        centers,
        widths,
    )
    return np.concatenate((out[: 6 * m], hlcmp_rates(motion, out[6 * m :], q_k, q_d, q_v)))


@jitable
def impedance_command(
    motion: np.ndarray,
    inertia: np.ndarray,
    coriolis_term: np.ndarray,
    gravity: np.ndarray,
    gain_l: np.ndarray,
    stiffness: np.ndarray,
    damping: np.ndarray,
) -> np.ndarray:
    """The constant impedance's command after `impedance_motion`: f_c = f_0 - K_s e - K_d e'
    (Eqs. 34, 4, 33 with v = 0).

    Parameters
    ----------
    motion, inertia, coriolis_term, gravity, gain_l
        As for `hlcmp_force`.
    stiffness, damping : (M,) arrays
        Diagonals of K_s [N/m] and K_d [N s/m].

    Returns
    -------
    (M,) array
        f_c [N].
    """
    m = motion.shape[0] // 5
    e, edot, eps, xe_ddot = motion[:m], motion[m : 2 * m], motion[2 * m : 3 * m], motion[4 * m :]
    f0 = nominal_force(inertia, coriolis_term, gravity, xe_ddot, gain_l, eps)
    return commanded_force(f0, impedance_force(stiffness, damping, e, edot), np.zeros(m))


@jitable
def variable_impedance_command(
    theta: np.ndarray,
    xd: np.ndarray,
    xd_dot: np.ndarray,
    xd_ddot: np.ndarray,
    desired_force: np.ndarray,
    external_force: np.ndarray,
    x: np.ndarray,
    xdot: np.ndarray,
    inertia: np.ndarray,
    coriolis_term: np.ndarray,
    gravity: np.ndarray,
    mass: np.ndarray,
    damping: np.ndarray,
    free_stiffness: np.ndarray,
    kp: np.ndarray,
    kv: np.ndarray,
    sigma: float,
    sample_period: float,
) -> np.ndarray:
    """The variable impedance at one instant: the admittance (`duan_commanded_motion`), the
    inner loop (`inner_position_loop`), and the rates of θ = [x_c, x_c', Φ]: [x_c', x_c'',
    (Φ(t + λ) - Φ(t)) / λ], Φ(t + λ) by `duan_phi_update`.

    Parameters
    ----------
    theta : (3 M,) array
        [x_c, x_c', Φ].
    xd, xd_dot, xd_ddot : (M,) arrays
        The reference [m], [m/s], [m/s^2].
    desired_force, external_force : (M,) arrays
        f_d and the measured reaction f_e [N].
    x, xdot : (M,) arrays
        Measured position [m] and velocity [m/s].
    inertia : (M, M) array
        Λ [kg].
    coriolis_term : (M,) array
        C_x x' [N].
    gravity : (M,) array
        G_x [N].
    mass, damping, free_stiffness, kp, kv : (M,) arrays
        As for `VariableImpedanceLaw`.
    sigma : float
        Φ's update rate [-].
    sample_period : float
        λ [s].

    Returns
    -------
    (4 M,) array
        The inner loop's force [N], then θ's rates.
    """
    m = xd.shape[0]
    xc, xc_dot, phi = theta[:m], theta[m : 2 * m], theta[2 * m :]
    xc_ddot, delta_f, tracking = duan_commanded_motion(
        xc,
        xc_dot,
        phi,
        xd,
        xd_dot,
        xd_ddot,
        desired_force,
        external_force,
        mass,
        damping,
        free_stiffness,
    )
    force = inner_position_loop(
        inertia, coriolis_term, gravity, xc_ddot, xc_dot, xc, x, xdot, kp, kv, external_force
    )
    next_phi = duan_phi_update(phi, delta_f, tracking, sigma, damping)
    return np.concatenate((force, xc_dot, xc_ddot, (next_phi - phi) / sample_period))


@dataclass(frozen=True)
class HlcmpGains:
    """Per-axis learning rates Q_k, Q_d, Q_v (M,), the sliding-surface slope pi > 0 and the
    diagonal of the feedback gain L (M,) of Eq. 34."""

    q_k: np.ndarray
    q_d: np.ndarray
    q_v: np.ndarray
    pi: float
    gain_l: np.ndarray


class HlcmpLaw:
    """The Hl-CMP at one instant: f_c = f_0 - u - v with K_s, K_d and v on the phase basis
    (Eqs. 14, 16, 4, 33-34), and the adaptation rates of θ (Eq. 31).

    Parameters
    ----------
    centers, widths : (N,) arrays
        The phase basis (see `core.dmp.basis_centers_and_widths`).
    gains : HlcmpGains
        Learning rates [per second], pi and L.
    """

    learns = True
    reads_external_force = False
    # The law's own series: its output name -> the series name in timeseries.npz.
    log_fields = {
        "stiffness": "Ks",
        "damping": "Kd",
        "feedforward": "v",
        "impedance_force": "u",
        "sliding_error": "eps",
    }

    def __init__(self, centers: np.ndarray, widths: np.ndarray, gains: HlcmpGains):
        self.centers, self.widths = np.asarray(centers, float), np.asarray(widths, float)
        self.gains = gains
        self.n_axes, self.n_basis = len(gains.q_k), len(self.centers)
        path = kernel_path()
        self._motion = implementation(impedance_motion, path)
        self._force = implementation(hlcmp_force, path)
        self._rates = implementation(hlcmp_rates, path)
        self._command = implementation(hlcmp_command, path)

    @property
    def theta_size(self) -> int:
        """3 M N: the length of the flattened θ = [θ_k, θ_d, θ_v], each (M, N) row-major."""
        return 3 * self.n_axes * self.n_basis

    def unflatten(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(θ_k, θ_d, θ_v), each (M, N), from the flattened θ.

        Parameters
        ----------
        theta : (3 M N,) array
            θ_k, θ_d and θ_v one after the other, each row-major.
        """
        k, d, v = np.asarray(theta, float).reshape(3, self.n_axes, self.n_basis)
        return k, d, v

    def command(self, now: TaskSpaceInstant, theta: np.ndarray) -> LawOutput:
        """f_c, the profiles, u, ε and θ' at this instant.

        Parameters
        ----------
        now : TaskSpaceInstant
            The motion, phase and task-space dynamics.
        theta : (3 M N,) array
            The current weights, flattened.

        Returns
        -------
        LawOutput
            force f_c [N]; logs stiffness [N/m], damping [N s/m], feedforward v [N],
            impedance_force u [N], sliding_error ε [m/s]; rates θ'. With C_x a matrix,
            all in one call (`hlcmp_command`); with C_x an operator (Drake's product), θ'
            when first read.
        """
        gains, theta, m = self.gains, np.asarray(theta, float), self.n_axes
        if isinstance(now.coriolis, np.ndarray):
            out = self._command(
                now.x,
                now.xdot,
                now.xd,
                now.xd_dot,
                now.xd_ddot,
                now.phase,
                now.inertia,
                now.coriolis,
                now.gravity,
                gains.pi,
                gains.gain_l,
                theta,
                self.centers,
                self.widths,
                gains.q_k,
                gains.q_d,
                gains.q_v,
            )
            return LawOutput(out[:m], self._logs(out), self._learning(lambda: out[6 * m :], theta))
        motion = self._motion(now.x, now.xdot, now.xd, now.xd_dot, now.xd_ddot, gains.pi)
        return self.command_from_motion(
            motion, now.inertia, now.coriolis @ motion[3 * m : 4 * m], now.gravity, now.phase, theta
        )

    def command_from_motion(
        self,
        motion: np.ndarray,
        inertia: np.ndarray,
        coriolis_term: np.ndarray,
        gravity: np.ndarray,
        phase: float,
        theta: np.ndarray,
    ) -> LawOutput:
        """`command` after `impedance_motion` and C_x x_e' are formed (as the 6-D
        `core.rotation_law.PoseLaw` forms them, with the rotation's coupling).

        Parameters
        ----------
        motion : (5 M,) array
            From `impedance_motion`.
        inertia : (M, M) array
            Λ [kg], contiguous.
        coriolis_term : (M,) array
            C_x x_e' [N].
        gravity : (M,) array
            G_x [N].
        phase : float
            s [-].
        theta : (3 M N,) array

        Returns
        -------
        LawOutput
            As `command`'s; θ' when first read.
        """
        gains, m = self.gains, self.n_axes
        out = self._force(
            motion,
            inertia,
            coriolis_term,
            gravity,
            gains.gain_l,
            phase,
            theta,
            self.centers,
            self.widths,
        )

        def rates():
            return self._rates(motion, out[6 * m :], gains.q_k, gains.q_d, gains.q_v)

        return LawOutput(out[:m], self._logs(out), self._learning(rates, theta))

    def _learning(
        self, paper_rates: Callable[[], np.ndarray], theta: np.ndarray
    ) -> Callable[[], np.ndarray]:
        """θ' as this law learns, from Eq. 31's: the paper's own here."""
        return paper_rates

    def _logs(self, out: np.ndarray) -> dict[str, np.ndarray]:
        """The series in `hlcmp_force`'s layout: f_c, K_s, K_d, v, u, ε."""
        m = self.n_axes
        return dict(
            stiffness=out[m : 2 * m],
            damping=out[2 * m : 3 * m],
            feedforward=out[3 * m : 4 * m],
            impedance_force=out[4 * m : 5 * m],
            sliding_error=out[5 * m : 6 * m],
        )


class HlcmpForgettingLaw(HlcmpLaw):
    """The Hl-CMP with the forgetting factor of Yang et al. 2011: the same profiles and
    command as `HlcmpLaw`, with θ' = Eq. 31 - γ θ (`core.adaptation.forgetting_rates`).

    Parameters
    ----------
    centers, widths : (N,) arrays
        The phase basis.
    gains : HlcmpGains
        Learning rates [per second], pi and L.
    forgetting_per_s : float
        γ >= 0 [1/s]; 0 gives the paper's law.
    """

    def __init__(
        self, centers: np.ndarray, widths: np.ndarray, gains: HlcmpGains, forgetting_per_s: float
    ):
        super().__init__(centers, widths, gains)
        self.forgetting_per_s = float(forgetting_per_s)

    def _learning(
        self, paper_rates: Callable[[], np.ndarray], theta: np.ndarray
    ) -> Callable[[], np.ndarray]:
        """θ' = Eq. 31 - γ θ, from Eq. 31's."""

        def rates() -> np.ndarray:
            return forgetting_rates(paper_rates(), theta, self.forgetting_per_s)

        return rates


class ConstantImpedanceLaw:
    """The Hl-CMP control structure with fixed profiles: f_c = f_0 - K_s e - K_d e'
    (Eqs. 33-34 with v = 0 and constant diagonal K_s, K_d), so that a comparison with the
    Hl-CMP differs only in whether the impedance is learned.

    Parameters
    ----------
    stiffness, damping : (M,) arrays
        Diagonals of K_s [N/m] and K_d [N s/m].
    pi : float
        Slope of the sliding surface [1/s] (Eq. 29).
    gain_l : (M,) array
        Diagonal of L [N s/m] (Eq. 34).
    """

    learns = False
    reads_external_force = False
    log_fields: dict[str, str] = {}

    def __init__(self, stiffness: np.ndarray, damping: np.ndarray, pi: float, gain_l: np.ndarray):
        self.k_s, self.k_d = np.asarray(stiffness, float), np.asarray(damping, float)
        self.pi, self.gain_l = float(pi), np.asarray(gain_l, float)
        self.n_axes = len(self.k_s)
        path = kernel_path()
        self._motion = implementation(impedance_motion, path)
        self._command = implementation(impedance_command, path)

    theta_size = 0

    def unflatten(self, theta: np.ndarray) -> tuple[np.ndarray, ...]:
        """No weights: an empty tuple.

        Parameters
        ----------
        theta : (0,) array
        """
        return ()

    def command(self, now: TaskSpaceInstant, theta: np.ndarray | None = None) -> LawOutput:
        """f_c at this instant.

        Parameters
        ----------
        now : TaskSpaceInstant
            The motion and the task-space dynamics (the phase is not used).
        theta : None
            Unused: this law does not learn.

        Returns
        -------
        LawOutput
            force f_c [N], no logs, no rates.
        """
        motion = self._motion(now.x, now.xdot, now.xd, now.xd_dot, now.xd_ddot, self.pi)
        m = self.n_axes
        return self.command_from_motion(
            motion, now.inertia, now.coriolis @ motion[3 * m : 4 * m], now.gravity, now.phase
        )

    def command_from_motion(
        self,
        motion: np.ndarray,
        inertia: np.ndarray,
        coriolis_term: np.ndarray,
        gravity: np.ndarray,
        phase: float,
        theta: np.ndarray | None = None,
    ) -> LawOutput:
        """`command` after `impedance_motion` and C_x x_e' are formed, as for
        `HlcmpLaw.command_from_motion`.

        Parameters
        ----------
        motion : (5 M,) array
        inertia : (M, M) array
        coriolis_term, gravity : (M,) arrays
        phase : float
            Unused.
        theta : None
            Unused.

        Returns
        -------
        LawOutput
            force f_c [N], no logs, no rates.
        """
        force = self._command(
            motion, inertia, coriolis_term, gravity, self.gain_l, self.k_s, self.k_d
        )
        return LawOutput(force, {})


class VariableImpedanceLaw:
    """The force-tracking variable impedance of Duan et al. 2018 (`core.duan2018`) at one
    instant, for a one-call loop: its state θ = [x_c, x_c', Φ] (M each) is integrated by
    Drake from the rates this law returns, held over the loop's period h.

    x_c and x_c' follow the admittance (`duan_commanded_motion`); Φ's update of one
    sample period λ (`duan_phi_update`) becomes the rate (Φ(t + λ) - Φ(t)) / λ, so that
    with h = λ Drake's step lands on exactly the discrete update of the modular
    `VariableImpedanceController` (the slider world checks h = λ). The force is the inner
    position loop's (`inner_position_loop`).

    Parameters
    ----------
    mass, damping, free_stiffness : (M,) arrays
        m [kg], b [N s/m], k where f_d = 0 [N/m].
    sigma : float
        Φ's update rate [-].
    sample_period : float
        λ [s].
    kp, kv : (M,) arrays
        Inner-loop gains [1/s^2], [1/s].
    desired_force : callable(t) -> (M,) array
        f_d at time t [N].
    """

    learns = False
    reads_external_force = True
    log_fields: dict[str, str] = {}

    def __init__(
        self,
        mass: np.ndarray,
        damping: np.ndarray,
        free_stiffness: np.ndarray,
        sigma: float,
        sample_period: float,
        kp: np.ndarray,
        kv: np.ndarray,
        desired_force: Callable[[float], np.ndarray],
    ):
        self.mass, self.damping = np.asarray(mass, float), np.asarray(damping, float)
        self.free_stiffness = np.asarray(free_stiffness, float)
        self.sigma, self.sample_period = float(sigma), float(sample_period)
        self.kp, self.kv = np.asarray(kp, float), np.asarray(kv, float)
        self.desired_force = desired_force
        self.n_axes = len(self.mass)
        self._command = implementation(variable_impedance_command, kernel_path())

    @property
    def theta_size(self) -> int:
        """3 M: x_c, x_c' and Φ."""
        return 3 * self.n_axes

    def initial_state(self, initial_position: np.ndarray) -> np.ndarray:
        """θ(0) = [x_c(0) = the start position, x_c'(0) = 0, Φ(0) = 0].

        Parameters
        ----------
        initial_position : (M,) array
            The task-space position at t = 0 [m].
        """
        m = self.n_axes
        return np.concatenate([np.asarray(initial_position, float), np.zeros(2 * m)])

    def unflatten(self, theta: np.ndarray) -> tuple[np.ndarray, ...]:
        """(x_c, x_c', Φ), each (M,).

        Parameters
        ----------
        theta : (3 M,) array
        """
        xc, xc_dot, phi = np.asarray(theta, float).reshape(3, self.n_axes)
        return xc, xc_dot, phi

    def command(self, now: TaskSpaceInstant, theta: np.ndarray) -> LawOutput:
        """The inner loop's force and the rates of [x_c, x_c', Φ].

        Parameters
        ----------
        now : TaskSpaceInstant
            With `time` and `external_force`.
        theta : (3 M,) array
            [x_c, x_c', Φ].

        Returns
        -------
        LawOutput
            force f [N], no logs, rates [x_c', x_c'', (Φ(t + λ) - Φ(t)) / λ].
        """
        assert now.external_force is not None, "the variable impedance reads the force"
        out = self._command(
            np.asarray(theta, float),
            now.xd,
            now.xd_dot,
            now.xd_ddot,
            np.asarray(self.desired_force(now.time), float),
            now.external_force,
            now.x,
            now.xdot,
            now.inertia,
            now.coriolis @ now.xdot,
            now.gravity,
            self.mass,
            self.damping,
            self.free_stiffness,
            self.kp,
            self.kv,
            self.sigma,
            self.sample_period,
        )
        m = self.n_axes
        return LawOutput(out[:m], {}, lambda: out[m:])
