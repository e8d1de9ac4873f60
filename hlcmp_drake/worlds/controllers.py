"""The controller registry: a controller config's type -> how to build its system, what
else to wire to it and what to log. This is the one place that dispatches on a
controller's kind; labels in the YAML are free text.

Adding a controller kind: its config class in `hlcmp_drake.config.scenario` (with a
`check`), its LeafSystem in `hlcmp_drake.systems`, and one entry in CONTROLLER_KINDS.
"""

from __future__ import annotations

import dataclasses as dc
from typing import TYPE_CHECKING, Callable

import numpy as np

from hlcmp_drake.config.scenario import (
    ConstantImpedanceConfig,
    HlcmpConfig,
    Scenario,
    StepReferenceConfig,
    VariableImpedanceConfig,
)
from hlcmp_drake.core.dmp import basis_centers_and_widths
from hlcmp_drake.core.laws import ConstantImpedanceLaw, HlcmpGains, HlcmpLaw
from hlcmp_drake.systems.baselines import ConstantImpedanceController, VariableImpedanceController
from hlcmp_drake.systems.hlcmp_controller import HlcmpController
from hlcmp_drake.systems.ports import REFERENCE_PORTS

if TYPE_CHECKING:
    from pydrake.systems.framework import DiagramBuilder

# The task-space inputs every controller reads (systems.ports), and where they come from.
TASK_SPACE_INPUTS = ("position", "velocity", "task_inertia", "task_coriolis", "task_gravity")


@dc.dataclass(frozen=True)
class WorldPorts:
    """What a world offers a controller.

    Attributes
    ----------
    reference : System
        The desired-motion source (DMP source or steps): x_d, x_d', x_d'', s.
    task_space : TaskSpaceDynamics
        Measured x, x' and the task-space M, C, G.
    contact_force : OutputPort
        The measured reaction force of the environment on the tool, (M,) [N].
    initial_position : (M,) array
        The task-space position at t = 0 [m].
    """

    reference: object
    task_space: object
    contact_force: object
    initial_position: np.ndarray


@dc.dataclass
class AddedController:
    """A controller in a diagram: its system, the series to log from it (name -> output
    port) and, for a learning controller, a reader of its theta from the root context."""

    system: object
    logs: dict
    read_theta: Callable | None = None


def hlcmp_law(config: HlcmpConfig, scenario: Scenario) -> HlcmpLaw:
    """The Hl-CMP law (Eqs. 14, 16, 29, 31, 33-34) on the scenario's phase basis.

    Parameters
    ----------
    config : HlcmpConfig
        The learning rates (read as its `q_units` say), pi and L.
    scenario : Scenario
        Its DMP settings (the N basis functions, alpha_s).

    Returns
    -------
    HlcmpLaw
        With Q as rates per second, whichever reading the config asks for.
    """
    centers, widths = basis_centers_and_widths(scenario.dmp.n_basis, scenario.dmp.alpha_s)
    scale = config.rate_scale()
    return HlcmpLaw(
        centers,
        widths,
        HlcmpGains(
            np.asarray(config.q_k, float) * scale,
            np.asarray(config.q_d, float) * scale,
            np.asarray(config.q_v, float) * scale,
            config.pi,
            np.asarray(config.gain_l, float),
        ),
    )


def initial_theta(
    config: HlcmpConfig,
    scenario: Scenario,
    theta0: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """A learner's flattened initial weights [θ_k, θ_d, θ_v].

    Parameters
    ----------
    config : HlcmpConfig
        Its uniform initial weights theta_k0, theta_d0, theta_v0.
    scenario : Scenario
        Its number of axes M and basis functions N.
    theta0 : tuple of three (M, N) arrays, optional
        In place of the configured uniform weights: a learned skill, or the previous
        trial's result.

    Returns
    -------
    (3 M N,) array

    Raises
    ------
    ValueError
        When `theta0` does not hold 3 M N values.
    """
    size = scenario.n_axes * scenario.dmp.n_basis
    if theta0 is not None:
        flat = np.concatenate([np.ravel(t) for t in theta0])
        if flat.size != 3 * size:
            raise ValueError(f"theta0 must hold 3*M*N = {3 * size} values, got {flat.size}")
        return flat
    return np.concatenate(
        [
            np.full(size, config.theta_k0),
            np.full(size, config.theta_d0),
            np.full(size, config.theta_v0),
        ]
    )


def hlcmp_controller(
    config: HlcmpConfig,
    scenario: Scenario,
    theta0: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> HlcmpController:
    """The Hl-CMP of `hlcmp_law` as one modular system, θ its continuous state.

    Parameters
    ----------
    config : HlcmpConfig
    scenario : Scenario
    theta0 : tuple of three (M, N) arrays, optional
        As for `initial_theta`.

    Returns
    -------
    HlcmpController
        The system (not yet added to a diagram).
    """
    law = hlcmp_law(config, scenario)
    return HlcmpController(
        law.centers, law.widths, law.gains, initial_theta(config, scenario, theta0)
    )


def _constant_law(config: ConstantImpedanceConfig, scenario: Scenario) -> ConstantImpedanceLaw:
    return ConstantImpedanceLaw(
        config.stiffness_N_per_m, config.damping_Ns_per_m, config.pi, config.gain_l
    )


def _make_constant(config: ConstantImpedanceConfig, scenario: Scenario, initial_position, theta0):
    return ConstantImpedanceController(
        config.stiffness_N_per_m, config.damping_Ns_per_m, config.pi, config.gain_l
    )


def desired_force_schedule(
    config: VariableImpedanceConfig, reference: StepReferenceConfig
) -> Callable[[float], np.ndarray]:
    """f_d(t): the configured force during the listed reference segments, 0 elsewhere.

    Parameters
    ----------
    config : VariableImpedanceConfig
        desired_force_N, (M,) [N], and force_segments, indices k of the segments
        [times_s[k], times_s[k + 1]) (the last one open-ended).
    reference : StepReferenceConfig
        Its times_s [s] bound the segments.

    Returns
    -------
    callable(t) -> (M,) array
        The desired force [N] at time t [s].
    """
    edges = list(reference.times_s) + [float("inf")]
    windows = [(edges[k], edges[k + 1]) for k in config.force_segments]
    force, zero = (
        np.asarray(config.desired_force_N, dtype=float),
        np.zeros(len(config.desired_force_N)),
    )

    def schedule(t):
        return force if any(start <= t < end for start, end in windows) else zero

    return schedule


def _make_variable(config: VariableImpedanceConfig, scenario: Scenario, initial_position, theta0):
    return VariableImpedanceController(
        config.mass_kg,
        config.damping_Ns_per_m,
        config.free_stiffness_N_per_m,
        config.sigma,
        config.sample_period_s,
        config.kp,
        config.kv,
        desired_force_schedule(config, scenario.reference),
        initial_position,
    )


@dc.dataclass(frozen=True)
class ControllerKind:
    """How to add one kind of controller: `make(config, scenario, x0, theta0)` builds the
    modular system; `logs` are (series name, output port) pairs to log besides the common
    ones; `uses_contact_force` wires the world's measured force to its `external_force`
    input; `learns` marks a controller whose theta is continuous state (read back after a
    run); `law(config, scenario)`, when given, is its `core.laws` law, which a world may
    evaluate in a one-call loop instead of the modular system."""

    make: Callable
    logs: tuple = ()
    uses_contact_force: bool = False
    learns: bool = False
    law: Callable | None = None


CONTROLLER_KINDS: dict[type, ControllerKind] = {
    HlcmpConfig: ControllerKind(
        lambda config, scenario, initial_position, theta0: hlcmp_controller(
            config, scenario, theta0
        ),
        logs=(
            ("Ks", "stiffness"),
            ("Kd", "damping"),
            ("v", "feedforward"),
            ("u", "impedance_force"),
            ("eps", "sliding_error"),
        ),
        learns=True,
        law=hlcmp_law,
    ),
    ConstantImpedanceConfig: ControllerKind(_make_constant, law=_constant_law),
    VariableImpedanceConfig: ControllerKind(_make_variable, uses_contact_force=True),
}


def controller_kind(scenario: Scenario, name: str) -> ControllerKind:
    """The registry entry of the scenario's controller `name`.

    Parameters
    ----------
    scenario : Scenario
    name : str
        A label of `scenario.controllers`.
    """
    return CONTROLLER_KINDS[type(scenario.controllers[name])]


def add_controller(
    builder: DiagramBuilder,
    scenario: Scenario,
    name: str,
    world: WorldPorts,
    theta0: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> AddedController:
    """Add the scenario's controller `name` to `builder` and wire it to `world`.

    Parameters
    ----------
    builder : DiagramBuilder
    scenario : Scenario
    name : str
        A label of `scenario.controllers`.
    world : WorldPorts
        The reference, task-space and force ports the controller reads.
    theta0 : tuple of three (M, N) arrays, optional
        Initial weights of a learning controller (ignored by the others).

    Returns
    -------
    AddedController
        The added system (named `name`), the series to log from it and, for a learning
        controller, its theta reader.
    """
    config = scenario.controllers[name]
    kind = controller_kind(scenario, name)
    system = builder.AddSystem(kind.make(config, scenario, world.initial_position, theta0))
    system.set_name(name)
    for port in REFERENCE_PORTS:
        builder.Connect(world.reference.GetOutputPort(port), system.GetInputPort(port))
    for port in TASK_SPACE_INPUTS:
        builder.Connect(world.task_space.GetOutputPort(port), system.GetInputPort(port))
    if kind.uses_contact_force:
        builder.Connect(world.contact_force, system.GetInputPort("external_force"))

    def read_theta(root_context):
        return system.theta(system.GetMyContextFromRoot(root_context))

    return AddedController(
        system,
        {series: system.GetOutputPort(port) for series, port in kind.logs},
        read_theta if kind.learns else None,
    )
