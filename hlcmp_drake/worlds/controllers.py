"""The controller registry: a controller config's type -> what kind of controller it is
(its role in the comparison, whether it learns), which `core.laws` law it evaluates, what
it logs, and how it goes into a diagram. This is the one place that dispatches on a
controller's config type; everything else asks the registry (`controller_kind`,
`kind_of`, `labels_with_role`, `learners`). Labels in the YAML are free text.

Adding a controller kind with a `core.laws` law: its config class in
`hlcmp_drake.config.scenario` (with a `check`, and in the ControllerConfig Union), its law
in `hlcmp_drake.core.laws`, and one entry in CONTROLLER_KINDS; the modular path wraps the
law in `systems.law_controller.LawController` and the arm's fast path evaluates it in
its one-call loop, so it needs no LeafSystem of its own.
"""

from __future__ import annotations

import dataclasses as dc
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from hlcmp_drake.config.scenario import (
    ConstantImpedanceConfig,
    ConstantPoseImpedanceConfig,
    ControllerConfig,
    HlcmpConfig,
    HlcmpForgettingConfig,
    PoseHlcmpConfig,
    Scenario,
    StepReferenceConfig,
    VariableImpedanceConfig,
)
from hlcmp_drake.core.dmp import basis_centers_and_widths
from hlcmp_drake.core.laws import (
    ConstantImpedanceLaw,
    ControlLaw,
    HlcmpForgettingLaw,
    HlcmpGains,
    HlcmpLaw,
    VariableImpedanceLaw,
)
from hlcmp_drake.core.rotation_law import (
    PoseImpedance,
    PoseLaw,
    RotationalHlcmp,
    RotationalImpedance,
    constant_pose_impedance,
)
from hlcmp_drake.systems.baselines import VariableImpedanceController
from hlcmp_drake.systems.law_controller import LawController
from hlcmp_drake.systems.ports import REFERENCE_PORTS

if TYPE_CHECKING:
    from pydrake.systems.framework import DiagramBuilder, LeafSystem, OutputPort, System

    from hlcmp_drake.systems.task_space import TaskSpaceDynamics

# A learner's weights as three (M, N) arrays (θ_k, θ_d, θ_v).
Theta = tuple[np.ndarray, np.ndarray, np.ndarray]

# The roles a controller plays in an experiment's comparison (ControllerKind.role).
LEARNER = "learner"
CONSTANT_IMPEDANCE = "constant_impedance"
FORCE_TRACKING = "force_tracking"

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

    reference: System
    task_space: TaskSpaceDynamics
    contact_force: OutputPort
    initial_position: np.ndarray


@dc.dataclass
class AddedController:
    """A controller in a diagram.

    Attributes
    ----------
    system : LeafSystem
        The controller's system (the modular controller, or the arm's one-call loop).
    logs : dict of str to OutputPort or (OutputPort, columns)
        The series to log from it, by series name.
    read_theta : callable(root_context) -> tuple of (M, N) arrays, optional
        A learning controller's weights read back from the diagram's root context.
    """

    system: LeafSystem
    logs: dict[str, Any]
    read_theta: Callable[[Any], tuple[np.ndarray, ...]] | None = None


def hlcmp_gains(config: HlcmpConfig) -> HlcmpGains:
    """The Hl-CMP's gains with Q as rates per second, whichever reading the config asks for.

    Parameters
    ----------
    config : HlcmpConfig
        The learning rates (read as its `q_units` say), pi and L.

    Returns
    -------
    HlcmpGains
    """
    return _gains_per_second(config, (config.q_k, config.q_d, config.q_v), config.pi, config.gain_l)


def _gains_per_second(config: HlcmpConfig, rates, pi: float, gain_l) -> HlcmpGains:
    """HlcmpGains with the learning rates (Q_k, Q_d, Q_v) read as the config's `q_units`
    say, per second."""
    scale = config.rate_scale()
    q_k, q_d, q_v = (np.asarray(q, float) * scale for q in rates)
    return HlcmpGains(q_k, q_d, q_v, pi, np.asarray(gain_l, float))


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
    return HlcmpLaw(centers, widths, hlcmp_gains(config))


def hlcmp_forgetting_law(config: HlcmpForgettingConfig, scenario: Scenario) -> HlcmpForgettingLaw:
    """The Hl-CMP with the forgetting factor γ (Yang et al. 2011) on the scenario's phase basis.

    Parameters
    ----------
    config : HlcmpForgettingConfig
        The Hl-CMP's settings and γ = forgetting_per_s [1/s].
    scenario : Scenario
        Its DMP settings.

    Returns
    -------
    HlcmpForgettingLaw
    """
    centers, widths = basis_centers_and_widths(scenario.dmp.n_basis, scenario.dmp.alpha_s)
    return HlcmpForgettingLaw(centers, widths, hlcmp_gains(config), config.forgetting_per_s)


def constant_impedance_law(
    config: ConstantImpedanceConfig, scenario: Scenario
) -> ConstantImpedanceLaw:
    """The constant impedance (Eqs. 33-34 with v = 0) of the config.

    Parameters
    ----------
    config : ConstantImpedanceConfig
    scenario : Scenario
        Unused: the law has no phase basis.

    Returns
    -------
    ConstantImpedanceLaw
    """
    return ConstantImpedanceLaw(
        config.stiffness_N_per_m, config.damping_Ns_per_m, config.pi, config.gain_l
    )


def pose_hlcmp_law(config: PoseHlcmpConfig, scenario: Scenario) -> PoseLaw:
    """The 6-D Hl-CMP: the translational Hl-CMP (`hlcmp_law`) and the rotational one
    (`core.rotation_law.RotationalHlcmp`) on the same phase basis, Q of both read in the
    config's `q_units`.

    Parameters
    ----------
    config : PoseHlcmpConfig
    scenario : Scenario
        Its DMP settings (the phase basis).

    Returns
    -------
    PoseLaw
    """
    centers, widths = basis_centers_and_widths(scenario.dmp.n_basis, scenario.dmp.alpha_s)
    rotational = _gains_per_second(
        config, (config.q_kr, config.q_dr, config.q_vr), config.pi_r, config.gain_l_r
    )
    return PoseLaw(hlcmp_law(config, scenario), RotationalHlcmp(centers, widths, rotational))


def constant_pose_impedance_law(config: ConstantPoseImpedanceConfig, scenario: Scenario) -> PoseLaw:
    """The constant 6-D impedance of the config (`core.rotation_law.constant_pose_impedance`).

    Parameters
    ----------
    config : ConstantPoseImpedanceConfig
    scenario : Scenario
        Unused: the law has no phase basis.

    Returns
    -------
    PoseLaw
        With no θ.
    """
    impedance = PoseImpedance(
        np.asarray(config.stiffness_N_per_m, float),
        np.asarray(config.damping_Ns_per_m, float),
        np.asarray(config.rotational_stiffness_Nm_per_rad, float),
        np.asarray(config.rotational_damping_Nms_per_rad, float),
    )
    return constant_pose_impedance(
        impedance,
        config.pi,
        np.asarray(config.gain_l, float),
        config.pi_r,
        np.asarray(config.gain_l_r, float),
    )


def initial_theta(
    config: HlcmpConfig,
    scenario: Scenario,
    theta0: Theta | None = None,
) -> np.ndarray:
    """A learner's flattened initial weights [θ_k, θ_d, θ_v] (and, for the 6-D Hl-CMP,
    [θ_kr, θ_dr, θ_vr] after them).

    Parameters
    ----------
    config : HlcmpConfig or PoseHlcmpConfig
        Its uniform initial weights theta_k0, theta_d0, theta_v0 (theta_kr0, theta_dr0,
        theta_vr0).
    scenario : Scenario
        Its number of axes M and basis functions N.
    theta0 : tuple of (M, N) arrays (then three (3, N) arrays for the 6-D Hl-CMP), optional
        In place of the configured uniform weights: a learned skill, or the previous
        trial's result.

    Returns
    -------
    (3 M N,) array, or (3 M N + 9 N,) for the 6-D Hl-CMP

    Raises
    ------
    ValueError
        When `theta0` does not hold that many values.
    """
    n = scenario.dmp.n_basis
    sizes = [scenario.n_axes * n] * 3
    starts = [config.theta_k0, config.theta_d0, config.theta_v0]
    if isinstance(config, PoseHlcmpConfig):
        sizes += [3 * n] * 3
        starts += [config.theta_kr0, config.theta_dr0, config.theta_vr0]
    if theta0 is not None:
        flat = np.concatenate([np.ravel(t) for t in theta0])
        if flat.size != sum(sizes):
            raise ValueError(f"theta0 must hold {sum(sizes)} values, got {flat.size}")
        return flat
    return np.concatenate([np.full(size, start) for size, start in zip(sizes, starts)])


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


def variable_impedance_law(
    config: VariableImpedanceConfig, scenario: Scenario
) -> VariableImpedanceLaw:
    """The variable impedance (Duan et al. 2018) of the config as a law, for a one-call loop.

    Parameters
    ----------
    config : VariableImpedanceConfig
    scenario : Scenario
        Its step reference bounds the segments where a force is asked for.

    Returns
    -------
    VariableImpedanceLaw
    """
    return VariableImpedanceLaw(*_variable_impedance_settings(config, scenario))


def _variable_impedance_system(
    config: VariableImpedanceConfig, scenario: Scenario, initial_position: np.ndarray
) -> VariableImpedanceController:
    return VariableImpedanceController(
        *_variable_impedance_settings(config, scenario), initial_position
    )


def _variable_impedance_settings(config: VariableImpedanceConfig, scenario: Scenario) -> tuple:
    """m, b, k_free, sigma, lambda, kp, kv and f_d(t), in the order the law and the
    modular system take them."""
    return (
        config.mass_kg,
        config.damping_Ns_per_m,
        config.free_stiffness_N_per_m,
        config.sigma,
        config.sample_period_s,
        config.kp,
        config.kv,
        desired_force_schedule(config, scenario.reference),
    )


def _frozen_hlcmp(config: HlcmpConfig) -> HlcmpConfig:
    zeros = [0.0] * len(config.q_k)
    return dc.replace(config, q_k=zeros, q_d=zeros, q_v=zeros)


def _frozen_forgetting(config: HlcmpForgettingConfig) -> HlcmpForgettingConfig:
    return dc.replace(_frozen_hlcmp(config), forgetting_per_s=0.0)


def _frozen_pose_hlcmp(config: PoseHlcmpConfig) -> PoseHlcmpConfig:
    zeros = [0.0] * 3
    return dc.replace(_frozen_hlcmp(config), q_kr=zeros, q_dr=zeros, q_vr=zeros)


@dc.dataclass(frozen=True)
class ControllerKind:
    """What one kind of controller is and how it goes into a diagram.

    Attributes
    ----------
    role : str
        Its part in an experiment's comparison: LEARNER (learns θ online; the claims are
        judged for each), CONSTANT_IMPEDANCE or FORCE_TRACKING (the variable impedance of
        the paper's ref. [21]).
    law_type : type, optional
        Its `core.laws` class: what it logs (`log_fields`) and whether it learns.
    law : callable(config, scenario) -> ControlLaw, optional
        Builds that law; a world evaluates it in the modular `LawController` or in a
        one-call loop (a world's fast path).
    system : callable(config, scenario, initial_position) -> LeafSystem, optional
        Its own modular system, in place of a `LawController` of its law (the variable
        impedance, whose Φ is a discrete state there).
    uses_contact_force : bool
        Wire the world's measured force to the system's `external_force` input.
    frozen : callable(config) -> config, optional
        For a learner: the same config with its learning switched off (θ stays as it
        starts), for replaying a skill.
    rotation : type, optional
        For a 6-D controller (the tool's orientation its task too, `law` a
        `core.rotation_law.PoseLaw`): the class of the law's rotational half; what it logs
        and whether it learns add to `law_type`'s.
    """

    role: str
    law_type: type | None = None
    law: Callable[[Any, Scenario], ControlLaw] | None = None
    system: Callable[[Any, Scenario, np.ndarray], LeafSystem] | None = None
    uses_contact_force: bool = False
    frozen: Callable[[Any], Any] | None = None
    rotation: type | None = None

    @property
    def pose(self) -> bool:
        """Whether it controls the tool's orientation as well as its point (6-D)."""
        return self.rotation is not None

    @property
    def learns(self) -> bool:
        """Whether its weights θ adapt during a run (and are read back after it)."""
        halves = (self.law_type, self.rotation)
        return any(half is not None and half.learns for half in halves)

    @property
    def logs(self) -> dict[str, str]:
        """Its own series: the law's output name -> the series name in timeseries.npz."""
        halves = (self.law_type, self.rotation)
        return {k: v for half in halves if half is not None for k, v in half.log_fields.items()}


CONTROLLER_KINDS: dict[type, ControllerKind] = {
    HlcmpConfig: ControllerKind(LEARNER, law_type=HlcmpLaw, law=hlcmp_law, frozen=_frozen_hlcmp),
    HlcmpForgettingConfig: ControllerKind(
        LEARNER, law_type=HlcmpForgettingLaw, law=hlcmp_forgetting_law, frozen=_frozen_forgetting
    ),
    ConstantImpedanceConfig: ControllerKind(
        CONSTANT_IMPEDANCE, law_type=ConstantImpedanceLaw, law=constant_impedance_law
    ),
    VariableImpedanceConfig: ControllerKind(
        FORCE_TRACKING,
        law_type=VariableImpedanceLaw,
        law=variable_impedance_law,
        system=_variable_impedance_system,
        uses_contact_force=True,
    ),
    PoseHlcmpConfig: ControllerKind(
        LEARNER,
        law_type=HlcmpLaw,
        law=pose_hlcmp_law,
        frozen=_frozen_pose_hlcmp,
        rotation=RotationalHlcmp,
    ),
    ConstantPoseImpedanceConfig: ControllerKind(
        CONSTANT_IMPEDANCE,
        law_type=ConstantImpedanceLaw,
        law=constant_pose_impedance_law,
        rotation=RotationalImpedance,
    ),
}


def kind_of(config: ControllerConfig) -> ControllerKind:
    """The registry entry of a controller config.

    Parameters
    ----------
    config : controller config
        One of the ControllerConfig types.

    Returns
    -------
    ControllerKind
    """
    return CONTROLLER_KINDS[type(config)]


def controller_kind(scenario: Scenario, name: str) -> ControllerKind:
    """The registry entry of the scenario's controller `name`.

    Parameters
    ----------
    scenario : Scenario
    name : str
        A label of `scenario.controllers`.

    Returns
    -------
    ControllerKind
    """
    return kind_of(scenario.controllers[name])


def labels_with_role(scenario: Scenario, role: str) -> list[str]:
    """The labels of the scenario's controllers whose kind plays `role`, in file order.

    Parameters
    ----------
    scenario : Scenario
    role : str
        LEARNER, CONSTANT_IMPEDANCE or FORCE_TRACKING.

    Returns
    -------
    list of str
    """
    return [name for name, config in scenario.controllers.items() if kind_of(config).role == role]


def learners(scenario: Scenario) -> list[str]:
    """The labels of the scenario's learning controllers, in file order.

    Parameters
    ----------
    scenario : Scenario

    Returns
    -------
    list of str
    """
    return labels_with_role(scenario, LEARNER)


def modular_system(
    config: ControllerConfig,
    scenario: Scenario,
    initial_position: np.ndarray,
    theta0: Theta | None = None,
) -> LeafSystem:
    """A controller as one modular system: its law in a `LawController` (θ its continuous
    state), or the kind's own system.

    Parameters
    ----------
    config : controller config
    scenario : Scenario
    initial_position : (M,) array
        The task-space position at t = 0 [m] (for a kind with a state of its own).
    theta0 : tuple of three (M, N) arrays, optional
        As for `initial_theta` (learners only).

    Returns
    -------
    LeafSystem
        Not yet added to a diagram.
    """
    kind = kind_of(config)
    if kind.system is not None:
        return kind.system(config, scenario, initial_position)
    assert kind.law is not None
    law = kind.law(config, scenario)
    start = initial_theta(config, scenario, theta0) if kind.learns else None
    return LawController(law, start)


def add_controller(
    builder: DiagramBuilder,
    scenario: Scenario,
    name: str,
    world: WorldPorts,
    theta0: Theta | None = None,
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
    kind = kind_of(config)
    system = builder.AddSystem(modular_system(config, scenario, world.initial_position, theta0))
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
        {series: system.GetOutputPort(port) for port, series in kind.logs.items()},
        read_theta if kind.learns else None,
    )
