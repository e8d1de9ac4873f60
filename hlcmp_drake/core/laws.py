"""The task-space control laws at one instant: the Hl-CMP (Eqs. 4-5, 14, 16, 29, 31,
33-34) and the constant impedance it is compared with, composed from the functions that
hold those equations. Pure numpy.

Every law has the shape of `ControlLaw`. Both ways of putting a law in a Drake diagram
evaluate these objects: the modular system `systems.law_controller.LawController` (θ its
continuous state) and the arm's one-call control loop (`systems.arm_loop`). A new law is a
class here and an entry in the controller registry (`worlds.controllers`); it needs no
LeafSystem of its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Callable, Protocol

import numpy as np

from hlcmp_drake.core.adaptation import adaptation_rates, compliant_profiles, forgetting_rates
from hlcmp_drake.core.control_law import commanded_force, impedance_force, nominal_command
from hlcmp_drake.core.dmp import normalized_basis


@dataclass(frozen=True)
class TaskSpaceInstant:
    """What a law reads at one instant: the measured and desired motion, the phase, and
    the task-space dynamics terms of Eq. 2 (from Drake).

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
        Whether it has weights θ that adapt (then `command` returns their rates).
    log_fields : dict of str to str
        Its own series: the key in `LawOutput.logs` (and the modular system's output
        port) -> the series name in timeseries.npz.
    n_axes : int
        M, the task-space axes.
    theta_size : int
        The length of the flattened θ (0 for a law that does not learn).
    """

    learns: bool
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
            impedance_force u [N], sliding_error ε [m/s]; rates θ'.
        """
        gains = self.gains
        g = normalized_basis(now.phase, self.centers, self.widths)
        e, edot, eps, f0 = nominal_command(
            now.x,
            now.xdot,
            now.xd,
            now.xd_dot,
            now.xd_ddot,
            now.inertia,
            now.coriolis,
            now.gravity,
            gains.pi,
            gains.gain_l,
        )
        k_s, k_d, v = compliant_profiles(*self.unflatten(theta), g)
        u = impedance_force(k_s, k_d, e, edot)

        def rates():
            return np.concatenate(
                [
                    r.ravel()
                    for r in adaptation_rates(eps, e, edot, g, gains.q_k, gains.q_d, gains.q_v)
                ]
            )

        return LawOutput(
            commanded_force(f0, u, v),
            dict(stiffness=k_s, damping=k_d, feedforward=v, impedance_force=u, sliding_error=eps),
            rates,
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

    def command(self, now: TaskSpaceInstant, theta: np.ndarray) -> LawOutput:
        """As `HlcmpLaw.command`, with the forgetting term in θ'.

        Parameters
        ----------
        now : TaskSpaceInstant
        theta : (3 M N,) array

        Returns
        -------
        LawOutput
        """
        paper = super().command(now, theta)
        paper_rates = paper.rates_of
        assert paper_rates is not None

        def rates() -> np.ndarray:
            return forgetting_rates(paper_rates(), theta, self.forgetting_per_s)

        return LawOutput(paper.force, paper.logs, rates)


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
    log_fields: dict[str, str] = {}

    def __init__(self, stiffness: np.ndarray, damping: np.ndarray, pi: float, gain_l: np.ndarray):
        self.k_s, self.k_d = np.asarray(stiffness, float), np.asarray(damping, float)
        self.pi, self.gain_l = float(pi), np.asarray(gain_l, float)
        self.n_axes = len(self.k_s)

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
        e, edot, _, f0 = nominal_command(
            now.x,
            now.xdot,
            now.xd,
            now.xd_dot,
            now.xd_ddot,
            now.inertia,
            now.coriolis,
            now.gravity,
            self.pi,
            self.gain_l,
        )
        return LawOutput(
            commanded_force(
                f0, impedance_force(self.k_s, self.k_d, e, edot), np.zeros(self.n_axes)
            ),
            {},
        )
