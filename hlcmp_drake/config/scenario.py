"""Typed scenario configuration: what a YAML scenario file holds.

A scenario reuses Drake's own config structs where one exists (MultibodyPlantConfig,
SimulatorConfig, ModelDirective) and the DMP's own settings (DmpSettings), and adds only
what is this project's own: the task, the reference motion and the controllers to
compare. Controllers are a label -> tagged config map, e.g.
``hlcmp: !HlcmpConfig {q_k: [2000], ...}``; the label is free text, the config's type
says what the controller is.

Each controller config checks its own values (`check`), so adding a controller kind means
adding its config class here and its factory in `hlcmp_drake.worlds.controllers`.
"""

import dataclasses as dc
import math
import os
from typing import Callable, NoReturn, Union

from pydrake.multibody.parsing import ModelDirective
from pydrake.multibody.plant import MultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import SimulatorConfig

from hlcmp_drake.config.models import body_problem, frame_problem, translation_axes
from hlcmp_drake.core.dmp import DmpSettings

# fail(key, problem): raises the InputError that names where `key` -- a dotted path such as
# "controllers.hlcmp.q_k" -- was set (the file's line, or the override).
Fail = Callable[[str, str], NoReturn]


# The rules `check_number` knows, and how a message says each.
NUMBER_RULES = {"any": "a finite number", ">= 0": "finite and >= 0", "> 0": "finite and > 0"}


def check_number(value: float, key: str, fail: Fail, rule: str = "> 0") -> None:
    """Check that the scenario's number at `key` is finite and keeps `rule`.

    Parameters
    ----------
    value : float
        The field's value.
    key : str
        Its dotted path, e.g. "recording.frames_per_second".
    fail : callable(dotted_key: str, problem: str)
        Raises the InputError that names where the key was set.
    rule : str
        "> 0" (positive, the default), ">= 0" (non-negative) or "any" (finite is enough).

    Raises
    ------
    InputError
        Through `fail`: "must be finite and > 0, got nan".
    """
    if not (
        math.isfinite(value)
        and (rule == "any" or (rule == ">= 0" and value >= 0) or (rule == "> 0" and value > 0))
    ):
        fail(key, f"must be {NUMBER_RULES[rule]}, got {value}")


def check_vector(
    values: list, key: str, fail: Fail, lengths: tuple = (3,), what: str = "", nonzero: bool = False
) -> None:
    """Check that the scenario's vector at `key` has one of `lengths` and finite values.

    Parameters
    ----------
    values : list of float
        The field's value.
    key : str
        Its dotted path, e.g. "recording.camera_position_m".
    fail : callable(dotted_key: str, problem: str)
        Raises the InputError that names where the key was set.
    lengths : tuple of int
        The lengths allowed, e.g. (3,) or (0, 3) (empty, or three values).
    what : str
        What the values are, for the message, e.g. " (x, y, z) [m]".
    nonzero : bool
        A non-empty vector must not be all zeros (a direction).

    Raises
    ------
    InputError
        Through `fail`, e.g. "needs 3 values (x, y, z) [m], got 2".
    """
    if len(values) not in lengths:
        counts = " or ".join("none" if n == 0 else str(n) for n in lengths)
        fail(key, f"needs {counts} values{what}, got {len(values)}")
    for value in values:
        if not math.isfinite(value):
            fail(key, f"every value must be finite, got {value}")
    if nonzero and values and not any(values):
        fail(key, f"must not be all zeros (a direction){what}")


def check_per_axis(
    config: object, name: str, key: str, m: int, fail: Fail, rule: str = ">= 0"
) -> None:
    """Check that controller `name`'s list field `key` holds one finite value per axis.

    Parameters
    ----------
    config : controller config dataclass
        Holds the list field `key`.
    name : str
        The controller's label in the scenario (for the message and the dotted key).
    key : str
        The field's name, e.g. "q_k".
    m : int
        The number of task-space axes M: the list's required length.
    fail : callable(dotted_key: str, problem: str)
        Raises the InputError that names where the key was set.
    rule : str
        ">= 0" (non-negative), "> 0" (positive) or "any" (finite is enough).

    Raises
    ------
    InputError
        Through `fail`, for the first problem found.
    """
    values = getattr(config, key)
    if len(values) != m:
        fail(
            f"controllers.{name}.{key}",
            f"controller '{name}' needs {m} value(s), one per axis, got {len(values)}",
        )
    for value in values:
        if (
            not math.isfinite(value)
            or (rule == ">= 0" and value < 0)
            or (rule == "> 0" and value <= 0)
        ):
            kind = {"> 0": "positive", ">= 0": "non-negative"}.get(rule, "a number")
            fail(
                f"controllers.{name}.{key}",
                f"controller '{name}': every value must be {kind} and finite, got {value}",
            )


class ControllerChecks:
    """What every controller config shares: `check` validates the per-axis lists its class
    names in PER_AXIS (field -> sign rule, in the order checked) after the class's own
    scalar rules (`_check_scalars`). PER_AXIS is a plain class attribute, not a field, so
    the YAML never sets it."""

    PER_AXIS: dict = {}
    pi: float  # the sliding-surface slope of Eq. 29, declared by each config

    def check(self, name: str, m: int, fail: Fail) -> None:
        """Check this controller's values.

        Parameters
        ----------
        name : str
            The controller's label in the scenario.
        m : int
            The number of task-space axes M: the length every per-axis list needs.
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.

        Raises
        ------
        InputError
            Through `fail`, for the first problem found.
        """
        self._check_scalars(name, fail)
        for key, rule in self.PER_AXIS.items():
            check_per_axis(self, name, key, m, fail, rule)

    def check_reference(self, name: str, reference: object, fail: Fail) -> None:
        """Check what this controller needs of the scenario's reference (nothing, unless a
        config says otherwise).

        Parameters
        ----------
        name : str
            The controller's label in the scenario.
        reference : StepReferenceConfig or DemonstrationConfig
            The scenario's reference.
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """

    def _check_scalars(self, name: str, fail: Fail) -> None:
        """The sliding-surface slope of Eq. 29, for the configs that have one."""
        if not (math.isfinite(self.pi) and self.pi > 0):
            fail(
                f"controllers.{name}.pi",
                f"controller '{name}': pi must be > 0 (Eq. 29) and finite, got {self.pi}",
            )


@dc.dataclass
class StepReferenceConfig:
    """Piecewise-constant set-points: positions_m[k] holds from times_s[k] on.

    Attributes
    ----------
    times_s : list of float
        The switch times [s], K of them: starting at 0 and increasing. Default [0]: one
        set-point for the whole run.
    positions_m : list of list of float
        K rows of M values: the desired position x_d [m] from times_s[k] on. Every row has
        the same length, which is M for a slider world. Default [[0]]: x_d = 0 on one axis.
    """

    times_s: list[float] = dc.field(default_factory=lambda: [0.0])
    positions_m: list[list[float]] = dc.field(default_factory=lambda: [[0.0]])


@dc.dataclass
class HlcmpConfig(ControllerChecks):
    """The Hl-CMP learner: learning rates Q per axis (Eq. 31), pi (Eq. 29), L (Eq. 34),
    and the initial value of every weight of theta_k, theta_d, theta_v. Checked: pi > 0,
    L and every Q per axis and non-negative, `q_units` one of Q_UNITS, control_step_s > 0,
    the initial weights finite.

    `q_units` says how to read Q, which the paper leaves open: "per_second" integrates
    Eq. 31 as written, theta' = Q eps e g; "per_step" is Table I's "for each time step t:
    compute the increment rates (Eq. 31) ... update these parameters", theta <- theta +
    Q eps e g once per control step of `control_step_s`, i.e. Q / control_step_s in
    continuous time. Either way theta is continuous state that Drake integrates."""

    PER_AXIS = {"gain_l": ">= 0", "q_k": ">= 0", "q_d": ">= 0", "q_v": ">= 0"}
    Q_UNITS = ("per_second", "per_step")

    q_k: list[float] = dc.field(default_factory=list)
    q_d: list[float] = dc.field(default_factory=list)
    q_v: list[float] = dc.field(default_factory=list)
    pi: float = 5.0
    gain_l: list[float] = dc.field(default_factory=list)
    theta_k0: float = 0.0
    theta_d0: float = 0.0
    theta_v0: float = 0.0
    q_units: str = "per_second"
    control_step_s: float = 0.001

    def rate_scale(self) -> float:
        """The factor from the configured Q to the rate Drake integrates [1, or 1/s per step].

        Returns
        -------
        float
            1 for "per_second"; 1 / control_step_s for "per_step".
        """
        return 1.0 if self.q_units == "per_second" else 1.0 / self.control_step_s

    def _check_scalars(self, name: str, fail: Fail) -> None:
        super()._check_scalars(name, fail)
        if self.q_units not in self.Q_UNITS:
            fail(
                f"controllers.{name}.q_units",
                f"controller '{name}': q_units must be one of {', '.join(self.Q_UNITS)}, got "
                f"'{self.q_units}'",
            )
        if not (math.isfinite(self.control_step_s) and self.control_step_s > 0):
            fail(
                f"controllers.{name}.control_step_s",
                f"controller '{name}': control_step_s must be positive and finite, got "
                f"{self.control_step_s}",
            )
        for key in ("theta_k0", "theta_d0", "theta_v0"):
            if not math.isfinite(getattr(self, key)):
                fail(
                    f"controllers.{name}.{key}",
                    f"controller '{name}': {key} must be finite, got {getattr(self, key)}",
                )


@dc.dataclass
class HlcmpForgettingConfig(HlcmpConfig):
    """The Hl-CMP learner with the forgetting factor of Yang et al. 2011: θ' = Eq. 31 - γ θ,
    so that a weight decays at the rate γ = `forgetting_per_s` [1/s] wherever the error
    vanishes. Every other field is the Hl-CMP's; γ = 0 gives its numbers exactly.
    Checked: as the Hl-CMP, and γ finite and >= 0."""

    forgetting_per_s: float = 0.0

    def _check_scalars(self, name: str, fail: Fail) -> None:
        super()._check_scalars(name, fail)
        if not (math.isfinite(self.forgetting_per_s) and self.forgetting_per_s >= 0):
            fail(
                f"controllers.{name}.forgetting_per_s",
                f"controller '{name}': forgetting_per_s must be finite and >= 0, "
                f"got {self.forgetting_per_s}",
            )


@dc.dataclass
class ConstantImpedanceConfig(ControllerChecks):
    """Fixed diagonal stiffness/damping in the same structure (Eqs. 33-34 with v = 0).
    Checked: pi > 0; L, stiffness and damping per axis and non-negative."""

    PER_AXIS = {"gain_l": ">= 0", "stiffness_N_per_m": ">= 0", "damping_Ns_per_m": ">= 0"}

    stiffness_N_per_m: list[float] = dc.field(default_factory=list)
    damping_Ns_per_m: list[float] = dc.field(default_factory=list)
    pi: float = 5.0
    gain_l: list[float] = dc.field(default_factory=list)


class RotationChecks:
    """What a controller that also acts on the tool's orientation (6-D, issue 19) checks:
    its rotational per-axis lists hold three values, one per tool axis (x, y, z of the tool
    frame, whatever the task's M), and pi_r > 0. It runs only on an arm's fast path
    (checked with the scenario in `config.validation`)."""

    ROTATIONAL_PER_AXIS: dict = {}
    pi_r: float

    def _check_rotation(self, name: str, fail: Fail) -> None:
        if not (math.isfinite(self.pi_r) and self.pi_r > 0):
            fail(
                f"controllers.{name}.pi_r",
                f"controller '{name}': pi_r must be > 0 (Eq. 29, rotational) and finite, got "
                f"{self.pi_r}",
            )
        for key, rule in self.ROTATIONAL_PER_AXIS.items():
            check_per_axis(self, name, key, 3, fail, rule)


@dc.dataclass
class PoseHlcmpConfig(RotationChecks, HlcmpConfig):
    """The Hl-CMP learning the tool point's translation (as `HlcmpConfig`, world axes) and
    the tool's orientation: rotational stiffness K_r [N m/rad], damping D_r [N m s/rad]
    and feed-forward torque v_r [N m] per tool axis on the same phase basis, learned by
    Eq. 31 with e_r = Log(R_d^T R) and eps_r = omega_e + pi_r e_r (`core.rotation_law`).
    q_kr, q_dr, q_vr are read in `q_units` like q_k, q_d, q_v; gain_l_r is L_r
    [N m s/rad]; theta_kr0, theta_dr0, theta_vr0 the rotational weights' initial value."""

    ROTATIONAL_PER_AXIS = {"gain_l_r": ">= 0", "q_kr": ">= 0", "q_dr": ">= 0", "q_vr": ">= 0"}

    q_kr: list[float] = dc.field(default_factory=list)
    q_dr: list[float] = dc.field(default_factory=list)
    q_vr: list[float] = dc.field(default_factory=list)
    pi_r: float = 5.0
    gain_l_r: list[float] = dc.field(default_factory=list)
    theta_kr0: float = 0.0
    theta_dr0: float = 0.0
    theta_vr0: float = 0.0

    def _check_scalars(self, name: str, fail: Fail) -> None:
        super()._check_scalars(name, fail)
        for key in ("theta_kr0", "theta_dr0", "theta_vr0"):
            if not math.isfinite(getattr(self, key)):
                fail(
                    f"controllers.{name}.{key}",
                    f"controller '{name}': {key} must be finite, got {getattr(self, key)}",
                )
        self._check_rotation(name, fail)


@dc.dataclass
class ConstantPoseImpedanceConfig(RotationChecks, ConstantImpedanceConfig):
    """A constant 6-D impedance: the translational `ConstantImpedanceConfig` (world axes)
    and fixed diagonal rotational stiffness K_r [N m/rad] and damping D_r [N m s/rad] per
    tool axis, with pi_r (Eq. 29) and L_r [N m s/rad] (`core.rotation_law.
    constant_pose_impedance`)."""

    ROTATIONAL_PER_AXIS = {
        "gain_l_r": ">= 0",
        "rotational_stiffness_Nm_per_rad": ">= 0",
        "rotational_damping_Nms_per_rad": ">= 0",
    }

    rotational_stiffness_Nm_per_rad: list[float] = dc.field(default_factory=list)
    rotational_damping_Nms_per_rad: list[float] = dc.field(default_factory=list)
    pi_r: float = 5.0
    gain_l_r: list[float] = dc.field(default_factory=list)

    def _check_scalars(self, name: str, fail: Fail) -> None:
        super()._check_scalars(name, fail)
        self._check_rotation(name, fail)


@dc.dataclass
class VariableImpedanceConfig(ControllerChecks):
    """Duan et al. 2018 force-tracking variable impedance (the paper's ref. [21]).

    desired_force_N is the desired reaction force per axis while the task asks for force
    (the reference segments listed in `force_segments`); elsewhere f_d = 0. Checked: one
    finite value per axis (mass and damping positive, the others non-negative, the force
    any), sigma >= 0 and a positive sample period, and a !StepReferenceConfig reference
    that has every segment `force_segments` lists."""

    PER_AXIS = {
        "desired_force_N": "any",
        "mass_kg": "> 0",
        "damping_Ns_per_m": "> 0",
        "free_stiffness_N_per_m": ">= 0",
        "kp": ">= 0",
        "kv": ">= 0",
    }

    desired_force_N: list[float] = dc.field(default_factory=list)
    force_segments: list[int] = dc.field(default_factory=lambda: [0])
    mass_kg: list[float] = dc.field(default_factory=list)
    damping_Ns_per_m: list[float] = dc.field(default_factory=list)
    free_stiffness_N_per_m: list[float] = dc.field(default_factory=list)
    sigma: float = 0.002
    sample_period_s: float = 0.001
    kp: list[float] = dc.field(default_factory=list)
    kv: list[float] = dc.field(default_factory=list)

    def _check_scalars(self, name: str, fail: Fail) -> None:
        """sigma >= 0 and a positive sample period (the adaptation's lambda), both finite."""
        if not (math.isfinite(self.sigma) and self.sigma >= 0):
            fail(
                f"controllers.{name}.sigma",
                f"controller '{name}': sigma must be finite and >= 0, got {self.sigma}",
            )
        if not (math.isfinite(self.sample_period_s) and self.sample_period_s > 0):
            fail(
                f"controllers.{name}.sample_period_s",
                f"controller '{name}': sample_period_s must be finite and > 0, got "
                f"{self.sample_period_s}",
            )

    def check_reference(self, name: str, reference: object, fail: Fail) -> None:
        """`force_segments` index the set-points' segments: a step reference is needed, and
        each index must be one of its segments.

        Parameters
        ----------
        name : str
            The controller's label in the scenario.
        reference : StepReferenceConfig or DemonstrationConfig
            The scenario's reference.
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        if not isinstance(reference, StepReferenceConfig):
            fail(
                f"controllers.{name}",
                f"controller '{name}': a !VariableImpedanceConfig asks for force during the "
                "set-points' segments (force_segments): it needs a !StepReferenceConfig reference",
            )
        count = len(reference.times_s)
        for k in self.force_segments:
            if not 0 <= k < count:
                fail(
                    f"controllers.{name}.force_segments",
                    f"controller '{name}': every segment must be one of 0..{count - 1} (one per "
                    f"entry of reference.times_s), got {k}",
                )


ControllerConfig = Union[
    HlcmpConfig,
    HlcmpForgettingConfig,
    ConstantImpedanceConfig,
    VariableImpedanceConfig,
    PoseHlcmpConfig,
    ConstantPoseImpedanceConfig,
]


# How a world puts its controller in the diagram (ArmTask.control_path,
# SliderTask.control_path).
CONTROL_PATHS = ("fast", "modular")


@dc.dataclass
class SliderTask:
    """A single-joint world (the 1-DOF experiment): the task space is the joint's body
    position along `axis`; the elastic object is a unilateral spring at the surface.

    Attributes
    ----------
    body : str
        The name of the plant's body that the joint moves (the model's; default "body",
        the body of models/one_dof_slider.sdf).
    axis : int
        The world axis of the body's translation that is the task space: 0 (x), 1 (y) or
        2 (z). Default 0.
    environment_stiffness_N_per_m : float
        The elastic object's stiffness k [N/m], >= 0. Default 10, the paper's.
    surface_position_m : float
        Where the object's surface is, in the joint's position q [m] (for the bundled
        slider, the body's x); the object fills q < surface and pushes the body out with
        k (surface - q) there (`UnilateralSpring`). Default 0.
    max_saturation_s : float
        How long [s], > 0, the joint force may stay at its actuator's effort limit (seen
        at every safety check: 100 Hz) before the run stops with status "unstable", as
        for an arm (`ArmTask.max_saturation_s`). Default 0.25.
    control_path : str
        How the controller is put in the diagram (CONTROL_PATHS): "fast" (default) -- one
        Python evaluation per plant step (`systems.control_loop.ControlLoop` with
        `PrismaticTaskModel`, the set-points and the phase in C++, the law's state in a
        C++ Integrator) -- or "modular" -- the task-space, controller and torque-map
        systems, each evaluated by Drake port by port. "fast" needs a discrete plant and,
        for a variable impedance, sample_period_s equal to the plant's time step (Φ is
        updated once per tick).
    """

    body: str = "body"
    axis: int = 0
    environment_stiffness_N_per_m: float = 10.0
    surface_position_m: float = 0.0
    max_saturation_s: float = 0.25
    control_path: str = "fast"

    def axis_count(self, reference: object) -> int:
        """M, the task-space axes: one per column of the set-points.

        Parameters
        ----------
        reference : StepReferenceConfig

        Returns
        -------
        int
        """
        assert isinstance(reference, StepReferenceConfig)
        return len(reference.positions_m[0])

    def check_scenario(self, scenario: "Scenario", fail: Fail) -> None:
        """The slider follows set-points; its axis is one of the joint's three; its numbers
        are finite, the stiffness >= 0 and the saturation time > 0.

        Parameters
        ----------
        scenario : Scenario
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        if not isinstance(scenario.reference, StepReferenceConfig):
            fail("reference", "the slider world follows a !StepReferenceConfig reference")
        if self.axis not in (0, 1, 2):
            fail("task.axis", f"must be 0 (x), 1 (y) or 2 (z), got {self.axis}")
        check_number(
            self.environment_stiffness_N_per_m, "task.environment_stiffness_N_per_m", fail, ">= 0"
        )
        check_number(self.surface_position_m, "task.surface_position_m", fail, "any")
        check_number(self.max_saturation_s, "task.max_saturation_s", fail, "> 0")
        if self.control_path not in CONTROL_PATHS:
            fail(
                "task.control_path",
                f"must be one of {', '.join(CONTROL_PATHS)}, got '{self.control_path}'",
            )
        step = scenario.plant_config.time_step
        if self.control_path == "fast":
            if not step > 0:
                fail(
                    "plant_config.time_step",
                    "the slider's fast path ticks once per plant step: it needs a discrete "
                    "plant (time_step > 0), or task.control_path: modular",
                )
            for name, config in scenario.controllers.items():
                period = getattr(config, "sample_period_s", step)
                if not math.isclose(period, step, rel_tol=1e-12):
                    fail(
                        f"controllers.{name}.sample_period_s",
                        f"the slider's fast path updates Φ once per plant step: {name}'s "
                        f"must equal plant_config.time_step ({step:g} s) (or "
                        f"task.control_path: modular), got {period:g}",
                    )
        if any(len(row) != 1 for row in scenario.reference.positions_m):
            fail(
                "reference.positions_m",
                "the slider moves along one axis: every row needs 1 value, got "
                f"{scenario.reference.positions_m}",
            )

    def check_models(self, plant: MultibodyPlant, fail: Fail) -> None:
        """The body the joint moves is one of the models', and the joints move it along
        `axis`.

        Parameters
        ----------
        plant : MultibodyPlant
            Finalized, with the scenario's models.
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        problem = body_problem(plant, self.body)
        if problem:
            fail("task.body", problem)
        moving = translation_axes(plant, self.body)
        if self.axis not in moving:
            names = " or ".join(f"{'xyz'[axis]} ({axis})" for axis in moving) or "no axis"
            fail(
                "task.axis",
                f"the joints move '{self.body}' along {names}, not along "
                f"{'xyz'[self.axis]} ({self.axis})",
            )


@dc.dataclass
class PunctureConfig:
    """A foam that gives way. The paper's insertion rests on it ("after the tool piercing the
    foam plank ... the external resistance becomes smaller"), but hydroelastic contact is
    elastic and has no memory of the hole a tool makes: past the mid-plane the field would
    pull the tool through. So the tear and the torn hole are modelled explicitly:

    - the tear: when the tool point, having come in through the object's top face (from
      above its plane, then over the face), first reaches `depth_m` below it while moving
      in, the contact between the tool and the object ends for the rest of the run (a
      collision filter set in the simulation). A tool point that starts below the face's
      plane (more than 1 mm: less is resting on it), or goes below it beside the object,
      tears nothing;
    - the hole: from then on, while the tool is in it, an axial friction force
      F = hole_friction_N_per_m * (length of tool inside the object) *
      tanh(v / sliding_speed_m_per_s)
      opposes the tool's motion v along its axis (the tool's `tool_direction`).

    `object_frame` names the object's frame at the centre of its top face with +z out of
    the object; empty means no puncture. The values are chosen with `hlcmp probe` alone
    (docs/worlds.md): the tear at the mid-plane is where the elastic force peaks, and
    150 N/m leaves a residual of about a third of the peak.

    Attributes
    ----------
    object_frame : str
        The object's frame, scoped "model::frame" (e.g. "foam_plank::plank"): origin at the
        centre of its top face, +z out of the object. Default "": no puncture, and the
        other fields must keep their defaults (they would not be used).
    thickness_m : float
        The object's thickness [m], > 0: it caps the length of tool inside the hole.
        Default 0.03, the foam plank's.
    depth_m : float
        The tear depth below the top face [m], in (0, thickness_m]. Default 0.015, the
        plank's mid-plane.
    hole_friction_N_per_m : float
        c, the hole's friction per metre of tool inside the object [N/m], >= 0 (0: the
        hole does not hold the tool). Default 150.
    sliding_speed_m_per_s : float
        v_s, the axial speed at which the friction reaches tanh(1) = 76 % of its full
        value [m/s], > 0 (it smooths the friction near v = 0). Default 0.002.
    """

    object_frame: str = ""
    thickness_m: float = 0.03
    depth_m: float = 0.015
    hole_friction_N_per_m: float = 150.0
    sliding_speed_m_per_s: float = 0.002

    def check(self, fail: Fail) -> None:
        """Positive thickness, a tear depth within it, non-negative friction, positive speed,
        all finite (checked with or without an object: a scenario's number is never junk);
        without an object, every field at its default.

        Parameters
        ----------
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        check_number(self.thickness_m, "task.puncture.thickness_m", fail, "> 0")
        if not 0 < self.depth_m <= self.thickness_m:  # two fields: the key of their section
            fail(
                "task.puncture",
                f"depth_m must be in (0, thickness_m = {self.thickness_m}], got {self.depth_m}",
            )
        check_number(
            self.hole_friction_N_per_m, "task.puncture.hole_friction_N_per_m", fail, ">= 0"
        )
        check_number(self.sliding_speed_m_per_s, "task.puncture.sliding_speed_m_per_s", fail, "> 0")
        if not self.object_frame:  # a setting the world would ignore (a sweep of identical runs)
            for field in dc.fields(self):
                if getattr(self, field.name) != field.default:
                    fail(
                        f"task.puncture.{field.name}",
                        f"this world has no puncture (task.puncture.object_frame is empty), so "
                        f"{field.name} would not be used: name the object's frame in "
                        "object_frame, or leave the puncture's settings out",
                    )


@dc.dataclass
class ArmTask:
    """A torque-controlled arm (the iiwa) whose task space is the translation of a tool
    point. The start posture comes from inverse kinematics at the demonstration's start
    with the tool frame's +z axis along `tool_direction` (world; the rotation about it is
    left to the solver, near the seed `ik_seed_rad`) -- or, for a tool whose rotation
    about its axis matters (a blade), with the whole tool orientation `tool_rpy_rad`
    (world roll, pitch, yaw) when given; that orientation and posture are then held below
    the translational task (NullSpaceImpedance).

    `control_path` says how the controller is put in the diagram: "fast" (default) -- the
    C++ DMP source, one Python evaluation of the whole controller per plant step
    (`systems.control_loop.ControlLoop`, θ in a C++ Integrator) -- or "modular" -- one
    system per role (DmpSource, TaskSpaceDynamics, the controller, NullSpaceImpedance,
    TaskForceToJointTorque), evaluated port by port. Both evaluate the same laws; a
    controller kind without a `core.laws` law (the variable impedance) is always modular.

    Attributes
    ----------
    tool_frame : str
        The tool point P's frame, scoped "model::frame": the task space is P's translation
        and the frame's +z is the tool's axis. Default "insertion_tool::tip", the rod's tip.
    axes : list of int
        The world axes of P's translation that make the task space, distinct values of
        0 (x), 1 (y), 2 (z); M = len(axes). Default [0, 1, 2]; a puncture needs all three.
    tool_direction : list of float
        A non-zero world 3-vector (any length): the tool frame's +z at the start posture
        when `tool_rpy_rad` is empty, and the tool's axis into the object for a puncture.
        Default [0, 0, -1]: pointing straight down.
    tool_rpy_rad : list of float
        Empty (the default: the rotation about `tool_direction` is free) or three angles
        (roll, pitch, yaw) [rad]: the tool frame's whole orientation in the world at the
        start posture.
    ik_seed_rad : list of float
        The joint positions [rad], one per joint of the arm (7 for the iiwa), that inverse
        kinematics starts from and stays close to, for the start posture and the check of
        the demonstration's reach. Default an elbow-up iiwa posture.
    orientation_stiffness_Nm_per_rad, orientation_damping_Nms_per_rad : float
        K_o [N m/rad] and D_o [N m s/rad], finite and >= 0: the rotational impedance that
        holds the start posture's tool orientation below the task (`BelowTaskImpedance`).
        Defaults 100 and 10.
    posture_stiffness_Nm_per_rad, posture_damping_Nms_per_rad : float
        K_p [N m/rad] and D_p [N m s/rad], finite and >= 0: the joint impedance that keeps
        the arm near its start posture q_0 in the task's null space. Defaults 20 and 5.
    max_contact_force_N : float
        The safety limit [N], > 0, on the norm of the force the wrist sensor reads (the
        tool's contacts, and a torn hole's friction): a run above it stops with status
        "unstable". Default 200.
    max_saturation_s : float
        How long [s], > 0, some joint torque may stay at its effort limit (seen at every
        safety check: 100 Hz in a simulation) before the run stops with status "unstable".
        Default 0.25.
    puncture : PunctureConfig
        The foam that gives way; the default (empty `object_frame`) has none.
    control_path : str
        "fast" (default) or "modular", as above (CONTROL_PATHS); "fast" needs a discrete
        plant (plant_config.time_step > 0).
    """

    tool_frame: str = "insertion_tool::tip"
    axes: list[int] = dc.field(default_factory=lambda: [0, 1, 2])
    tool_direction: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, -1.0])
    tool_rpy_rad: list[float] = dc.field(default_factory=list)
    ik_seed_rad: list[float] = dc.field(
        default_factory=lambda: [0.0, 0.6, 0.0, -1.5, 0.0, 1.0, 0.0]
    )
    orientation_stiffness_Nm_per_rad: float = 100.0
    orientation_damping_Nms_per_rad: float = 10.0
    posture_stiffness_Nm_per_rad: float = 20.0
    posture_damping_Nms_per_rad: float = 5.0
    max_contact_force_N: float = 200.0
    max_saturation_s: float = 0.25
    puncture: PunctureConfig = dc.field(default_factory=PunctureConfig)
    control_path: str = "fast"

    def physics_extras(self) -> list[PunctureConfig]:
        """The world physics extras this task configures, in the order they are added
        (`hlcmp_drake.worlds.extras`): the puncture when it names an object.

        Returns
        -------
        list of extra configs
        """
        return [self.puncture] if self.puncture.object_frame else []

    def axis_count(self, reference: object) -> int:
        """M, the task-space axes the controllers act on: the tool point's x, y, z.

        Parameters
        ----------
        reference : reference config
            Unused: the arm's axes are its own.

        Returns
        -------
        int
        """
        return len(self.axes)

    def check_scenario(self, scenario: "Scenario", fail: Fail) -> None:
        """The checks an arm world needs of the whole scenario: its own values (`check`),
        a demonstration to follow, and a plant the one-call controller can tick with.

        Parameters
        ----------
        scenario : Scenario
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        if not isinstance(scenario.reference, DemonstrationConfig):
            fail("reference", "an arm task needs a !DemonstrationConfig reference")
        self.check(fail)
        if self.control_path == "fast" and not scenario.plant_config.time_step > 0:
            fail(
                "plant_config.time_step",
                "the arm's fast path ticks once per plant step: it needs a "
                "discrete plant (time_step > 0), or task.control_path: modular",
            )
        if scenario.plant_config.use_sampled_output_ports:
            # The arm's controller and the foam's friction are unrestricted updates at the
            # plant's step; a sampled plant steps in the same pass and would see them a step late.
            fail(
                "plant_config.use_sampled_output_ports",
                "an arm world needs false (the controller's tick must come before the plant's "
                "step)",
            )

    def check_models(self, plant: MultibodyPlant, fail: Fail) -> None:
        """The frames the task names are the models' (the tool point's, the punctured
        object's), and the IK seed has one value per joint position of the plant.

        Parameters
        ----------
        plant : MultibodyPlant
            Finalized, with the scenario's models.
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        for key, name in (
            ("task.tool_frame", self.tool_frame),
            ("task.puncture.object_frame", self.puncture.object_frame),
        ):
            problem = frame_problem(plant, name) if name else None
            if problem:
                fail(key, problem)
        if len(self.ik_seed_rad) != plant.num_positions():
            fail(
                "task.ik_seed_rad",
                f"needs {plant.num_positions()} values, one per joint position of the "
                f"scenario's models, got {len(self.ik_seed_rad)}",
            )

    def check(self, fail: Fail) -> None:
        """Check the axes [0, 1, 2], the tool direction and orientation, finite gains >= 0
        and positive safety limits.

        Parameters
        ----------
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key (e.g. "task.axes") was set.

        Raises
        ------
        InputError
            Through `fail`, for the first problem found.
        """
        if list(self.axes) != [0, 1, 2]:
            # The demonstration, the start posture's inverse kinematics, the puncture and the
            # metrics are all of the tool point in 3-D; nothing would hold an axis left out.
            fail(
                "task.axes",
                f"an arm task controls the tool point in x, y and z: axes must be [0, 1, 2], "
                f"got {self.axes}",
            )
        if not self.tool_frame:
            fail("task.tool_frame", "must name the tool point's frame, 'model::frame'")
        if len(self.tool_direction) != 3 or not any(self.tool_direction):
            fail("task.tool_direction", "needs a non-zero 3-vector")
        check_vector(self.tool_direction, "task.tool_direction", fail, (3,), " (x, y, z)")
        if len(self.tool_rpy_rad) not in (0, 3):
            fail("task.tool_rpy_rad", "needs three angles (roll, pitch, yaw), or none")
        check_vector(self.tool_rpy_rad, "task.tool_rpy_rad", fail, (0, 3), " (roll, pitch, yaw)")
        check_vector(self.ik_seed_rad, "task.ik_seed_rad", fail, (len(self.ik_seed_rad),), " [rad]")
        for key in (
            "orientation_stiffness_Nm_per_rad",
            "orientation_damping_Nms_per_rad",
            "posture_stiffness_Nm_per_rad",
            "posture_damping_Nms_per_rad",
        ):
            check_number(getattr(self, key), f"task.{key}", fail, ">= 0")
        check_number(self.max_contact_force_N, "task.max_contact_force_N", fail, "> 0")
        check_number(self.max_saturation_s, "task.max_saturation_s", fail, "> 0")
        self.puncture.check(fail)
        if self.control_path not in CONTROL_PATHS:
            fail(
                "task.control_path",
                f"must be one of {', '.join(CONTROL_PATHS)}, got '{self.control_path}'",
            )


@dc.dataclass
class DemonstrationConfig:
    """The reference is a DMP fitted at start-up to a demonstration CSV (t,x,y,z; world
    frame, metres). `file` is relative to the scenario file's folder. The DMP's shape
    (N, alpha, alpha_s, smoothing) is the scenario's `dmp`; `duration_s` > 0 replays it
    at another tau (temporal scaling).

    Attributes
    ----------
    file : str
        The demonstration CSV (format in `hlcmp_drake.io.demos`: header ``t,x,y,z``, time
        [s], world positions [m]), relative to the scenario file's folder; loading resolves
        it to an absolute path. Required (the default "" fails validation).
    duration_s : float
        The DMP's time constant tau [s] for the runs, >= 0. Default 0: as demonstrated
        (tau = the demonstration's duration); another value runs the same path faster or
        slower. The simulated time is the scenario's `duration_s`.
    """

    file: str = ""
    duration_s: float = 0.0


# Above a display's refresh rate (60-240 Hz) frames are never seen; 1e9 fps hung the
# recording after the run, drawing and storing every frame.
MAX_FRAMES_PER_SECOND = 240.0


@dc.dataclass
class RecordingConfig:
    """The offline 3-D recording: the runs' copies of the world stand `spacing_m` apart
    along +y; the camera is placed relative to the middle copy.

    Attributes
    ----------
    spacing_m : float
        The distance between neighbouring copies along +y [m], in the order the scenario
        lists the controllers (the live view's too); finite and >= 0, > 0 keeps them
        apart. Default 0.6.
    camera_position_m, camera_target_m : list of float
        Two different world points (3 finite values each) [m]: only their difference is
        used, the direction from which the camera looks at the middle of all copies; its
        distance is chosen to keep every copy and its sign in view. Defaults
        [1.6, -1.8, 1.2] and [0, 0, 0.2].
    frames_per_second : float
        The recording's frame rate [1/s], finite, > 0 and at most MAX_FRAMES_PER_SECOND:
        the runs are sampled at it. Default 30.
    """

    spacing_m: float = 0.6
    camera_position_m: list[float] = dc.field(default_factory=lambda: [1.6, -1.8, 1.2])
    camera_target_m: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.2])
    frames_per_second: float = 30.0

    def check(self, fail: Fail) -> None:
        """Finite, non-negative spacing; two different camera points of 3 finite values; a
        positive frame rate.

        Parameters
        ----------
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        check_number(self.spacing_m, "recording.spacing_m", fail, ">= 0")
        for key in ("camera_position_m", "camera_target_m"):
            check_vector(getattr(self, key), f"recording.{key}", fail, (3,), " (x, y, z) [m]")
        if self.camera_position_m == self.camera_target_m:
            fail(
                "recording",
                "camera_position_m must differ from camera_target_m: their difference is the "
                "view direction",
            )
        check_number(self.frames_per_second, "recording.frames_per_second", fail, "> 0")
        if self.frames_per_second > MAX_FRAMES_PER_SECOND:
            fail(
                "recording.frames_per_second",
                f"must be at most {MAX_FRAMES_PER_SECOND:g}, got {self.frames_per_second:g}: "
                "a browser plays the recording at its display's rate, and every frame is "
                "drawn and stored in the HTML file",
            )


@dc.dataclass
class ProbeConfig:
    """`hlcmp probe`: the scenario's world measured alone. The tool, without the arm, rides a
    stiff prescribed-motion carriage (no controller under test): from `start_m` (the tool
    point, world), an unmeasured `approach_m` (e.g. down into the block before a cut), then
    the measured push `push_m` at `speed_m_per_s`, then back along the same path. The
    force across the push counts as lateral; with `lateral_axis` only its component along
    that axis does (cutting: the blade's normal, not the block's upward reaction).
    `tilt_rad` tilts the tool about the world y axis, to show whether the contact depends
    on a tilt a controller could cause. With `wrist_stiffness_Nm_per_rad` the tool is not
    welded to the carriage but hangs on a wrist of three revolute joints about the tool
    point, along the tool frame's x, y and z axes as it starts, each held at its start
    angle by a PD actuator (stiffness per joint, 0: free to turn; `wrist_damping_Nms_per_rad`
    on every joint): a remote centre of compliance at the tool point, so that the contact
    can turn the tool without moving the point off the path.

    Attributes
    ----------
    arm_model : str
        The model instance of the arm that the probe leaves out (its model, welds and
        collision filters); the tool welded to it rides the carriage. Default "iiwa".
    start_m : list of float
        The tool point's start, world (3 values) [m]. Required for a probe: empty (the
        default) means the scenario has none.
    approach_m : list of float
        An unmeasured move from the start before the push, world (3 values) [m]. Empty
        (the default) or zeros: the push starts at `start_m`.
    push_m : list of float
        The measured push, world displacement (3 values, non-zero) [m]; the carriage then
        goes back along it. Required for a probe.
    lateral_axis : list of float
        A world direction (3 values, any length): the lateral force is the force's
        component along it. Empty (the default): the norm of the force across the push.
    speed_m_per_s : float
        The carriage's speed along every leg of its path [m/s], > 0. Default 0.03.
    tilt_rad : float
        The tool's tilt about the world y axis [rad]. Default 0.
    wrist_stiffness_Nm_per_rad : list of float
        Empty (the default: the tool welded to the carriage) or three values, finite and
        >= 0: the wrist joints' stiffness about the tool's x, y, z axes [N m/rad].
    wrist_damping_Nms_per_rad : float
        The wrist joints' damping [N m s/rad], finite and >= 0 (used with a wrist only).
        Default 0.1.
    """

    arm_model: str = "iiwa"
    start_m: list[float] = dc.field(default_factory=list)
    approach_m: list[float] = dc.field(default_factory=list)
    push_m: list[float] = dc.field(default_factory=list)
    lateral_axis: list[float] = dc.field(default_factory=list)
    speed_m_per_s: float = 0.03
    tilt_rad: float = 0.0
    wrist_stiffness_Nm_per_rad: list[float] = dc.field(default_factory=list)
    wrist_damping_Nms_per_rad: float = 0.1

    @property
    def given(self) -> bool:
        """Whether the scenario has a probe (start_m given)."""
        return bool(self.start_m)

    def check(self, fail: Fail) -> None:
        """Each vector empty or 3 finite values (the push and the lateral axis not all
        zeros), start_m and push_m both given or neither, a positive speed, a finite tilt,
        the wrist's stiffness and damping >= 0; checked whether or not the scenario has a
        probe.

        Parameters
        ----------
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        for key, nonzero in (
            ("start_m", False),
            ("approach_m", False),
            ("push_m", True),
            ("lateral_axis", True),
        ):
            check_vector(getattr(self, key), f"probe.{key}", fail, (0, 3), " (x, y, z)", nonzero)
        if bool(self.start_m) != bool(self.push_m):
            fail("probe", "a probe needs both start_m and push_m (or neither: no probe)")
        check_number(self.speed_m_per_s, "probe.speed_m_per_s", fail, "> 0")
        check_number(self.tilt_rad, "probe.tilt_rad", fail, "any")
        key = "probe.wrist_stiffness_Nm_per_rad"
        check_vector(self.wrist_stiffness_Nm_per_rad, key, fail, (0, 3), " (x, y, z) [N m/rad]")
        for value in self.wrist_stiffness_Nm_per_rad:
            check_number(value, key, fail, ">= 0")
        damping = "probe.wrist_damping_Nms_per_rad"
        check_number(self.wrist_damping_Nms_per_rad, damping, fail, ">= 0")

    def speed_problem(self, speed: float, time_step: float) -> str | None:
        """Why the carriage cannot probe at `speed` with plant steps of `time_step`, or
        None: the push must span at least PROBE_PUSH_STEPS steps (its reading resolved to
        1 % of its length) and the whole path at most PROBE_PATH_STEPS (a probe of
        minutes, not hours).

        Parameters
        ----------
        speed : float
            The carriage's speed [m/s], > 0.
        time_step : float
            The plant's step [s]; 0 (continuous) bounds only the path's duration, at 1 ms.

        Returns
        -------
        str or None
        """
        step = time_step or 0.001
        push = math.hypot(*self.push_m)
        approach = math.hypot(*self.approach_m)
        path = approach + 2.0 * push
        fastest, slowest = push / (PROBE_PUSH_STEPS * step), path / (PROBE_PATH_STEPS * step)
        if time_step and speed > fastest:
            return (
                f"must be at most {fastest:.3g} m/s, got {speed:g}: the {1000 * push:g} mm "
                f"push needs {PROBE_PUSH_STEPS} or more plant steps of {1000 * time_step:g} ms"
            )
        if speed < slowest:
            return (
                f"must be at least {slowest:.3g} m/s, got {speed:g}: the {1000 * path:g} mm "
                f"path (approach_m's {1000 * approach:g} mm, then push_m's {1000 * push:g} mm "
                f"in and out) would take more than {PROBE_PATH_STEPS:.0e} plant steps"
            )
        return None


# Bounds of a probe's speed (ProbeConfig.speed_problem): its push in at least this many plant
# steps, its whole path in at most this many.
PROBE_PUSH_STEPS = 100
PROBE_PATH_STEPS = 1_000_000


# Where `hlcmp serve` reads the wrist force from (IiwaDriverConfig.force_source).
FORCE_SOURCES = ("wrist_sensor", "external_torque")


# The warm-up before each status by default (`IiwaDriverConfig.warm_up_lead`): measured
# against Drake's driver at 5 ms, a lead of 2-2.5 ms took a served tick's p50 down by a
# third and its p99 by a quarter to a half; at 1 ms on two cores it gained nothing and cost
# missed ticks (docs/iiwa.md, "A warm-up before each status").
AUTO_WARM_UP_FRACTION = 0.4
AUTO_WARM_UP_MIN_PERIOD_S = 0.004
# After the warm-up, the client polls for the status without sleeping until this long after
# it is expected (`IiwaDriverConfig.warm_up_poll`): a tick that starts from a sleep starts on
# caches the idle core has lost. Against Drake's driver at 5 ms, seven rounds alternating
# with it off, the served tick's p99 was above 400 µs in one run polling and three
# sleeping, 0 missed in every run (docs/iiwa.md, "Polling from the warm-up to the
# status"). Polling all the time loses statuses (`busy_wait`); this polls from the warm-up
# to the status, under half of a 5 ms period.
AUTO_WARM_UP_POLL_S = 0.0005


@dc.dataclass
class IiwaDriverConfig:
    """How `hlcmp serve` talks to an iiwa driver over LCM: drake-iiwa-driver in torque-only
    mode on a real arm, or `hlcmp sim-driver`. The driver publishes lcmt_iiwa_status on
    `status_channel` every `period_s` and compensates gravity itself; the client answers
    each status with an lcmt_iiwa_command on `command_channel` (joint torques, and the
    measured positions echoed).

    `force_source` is where the logged and checked wrist wrench comes from: "wrist_sensor",
    an lcmt_force_torque on `wrist_channel` (the environment's force on the tool [N] and
    its torque about the tool point [N m], both in the tool frame), or "external_torque",
    [τ; f] = pinv(J^T) tau_ext from the status's external joint torques (J: the tool
    point's 6 x nv spatial Jacobian). The controllers themselves do not read it; it feeds
    the metrics and the contact-force watchdog.

    Watchdogs: the client stops commanding when no status has come for `stale_status_s`
    (the driver then holds the arm after its own 50 ms), and waits `start_guard_s` after
    its first status before the first command (the driver aborts on a command within
    0.25 s of its start). The arm must start within `start_tolerance_rad` of the
    scenario's start posture on every joint.

    Attributes
    ----------
    status_channel : str
        The LCM channel of the driver's lcmt_iiwa_status, non-empty. Default
        "IIWA_STATUS".
    command_channel : str
        The LCM channel of the client's lcmt_iiwa_command, non-empty. Default
        "IIWA_COMMAND".
    wrist_channel : str
        The LCM channel of the wrist sensor's lcmt_force_torque, non-empty; read with
        `force_source` "wrist_sensor" only (`hlcmp sim-driver` publishes it). Default
        "IIWA_WRIST_FT".
    period_s : float
        The driver's status period [s], > 0: the client's tick, at which the reference is
        sampled; for `hlcmp sim-driver` a whole number of plant steps. Default 0.001
        (1 kHz).
    start_guard_s : float
        The wait after the first status before the first command [s], > 0. Default 0.3.
    stale_status_s : float
        The longest time without a status [s], > 0, before the client stops commanding
        (once statuses have come); also without a status newer than the last (at least
        10 of them) from the first command on. Default 0.05.
    stale_wrench_s : float
        With `force_source` "wrist_sensor": the longest time without a wrench [s], > 0,
        before the client stops commanding (the contact force can no longer be
        checked); raise it for a sensor that publishes slower than 20 Hz. Default 0.05.
    first_status_timeout_s : float
        How long the client waits for the first status [s], > 0, before it stops (is the
        driver running?). Default 30.
    start_tolerance_rad : float
        The largest distance of any joint from the start posture [rad], > 0, in the
        statuses before the first command (further: the client stops). Default 0.05.
    force_source : str
        "wrist_sensor" (default) or "external_torque", as above (FORCE_SOURCES).
    max_missed_fraction : float
        The share of the duration's ticks that may go unanswered, in [0, 1), before a run
        that finished counts as "degraded" (a non-zero exit). Default 0.01.
    max_consecutive_missed : int
        The longest run of unanswered ticks, >= 1, before a run that finished counts as
        "degraded". Default 10: 10 ms at 1 kHz, a fifth of the driver's 50 ms hold.
    period_tolerance : float
        How far the status period measured from the statuses' stamps may be from
        `period_s`, relative, in (0, 1). Further, the client stops before it commands at
        the wrong rate. Default 0.1.
    busy_wait : bool
        Between statuses, poll without sleeping (true: the tick starts from warm caches,
        but the poll starves LCM's own receiving, which loses datagrams unless the client
        has cores to spare) or sleep until a status comes (default false; docs/iiwa.md).
    warm_up_lead_s : float or None
        How long before the next expected status (the last answered one's receipt plus
        `period_s`) the client runs one throw-away tick at the last answered status's
        inputs, so that the real tick starts from warm caches [s], in [0, period_s); 0:
        never. None (default): `AUTO_WARM_UP_FRACTION` of the period where the period is
        at least `AUTO_WARM_UP_MIN_PERIOD_S`, else never (`warm_up_lead`): worth it where
        the period leaves the client idle (Drake's driver at 5 ms), while at 1 ms on two
        cores it cost more missed ticks than it saved (docs/iiwa.md). A status that comes
        while the client is busy with it counts as received when the client stopped
        listening, so its wait is in `tick_us`.
    warm_up_poll_s : float or None
        After the warm-up, poll for the status without sleeping until it comes or this long
        after it is expected [s], in [0, period_s); 0: sleep until it comes. None
        (default): `AUTO_WARM_UP_POLL_S` where the warm-up runs (`warm_up_poll`), so that
        the tick starts on a core that has not gone idle.
    realtime_priority : int
        The client's SCHED_FIFO priority while it serves a driver over the network, 1-99
        (Linux), as a robot's real-time client is run (an FRI client on a PREEMPT_RT
        machine, for one); 0 (default): the normal scheduler. Raising it needs the right
        to (root, CAP_SYS_NICE, or an rtprio limit of at least this), which is checked
        before the client is made. A status then wakes the client at once, and nothing of
        the normal scheduler's interrupts its tick (docs/iiwa.md). Not for memq://, whose
        driver runs in the same process; not with `busy_wait` where Linux throttles
        real-time threads (refused).
    """

    status_channel: str = "IIWA_STATUS"
    command_channel: str = "IIWA_COMMAND"
    wrist_channel: str = "IIWA_WRIST_FT"
    period_s: float = 0.001
    start_guard_s: float = 0.3
    stale_status_s: float = 0.05
    stale_wrench_s: float = 0.05
    first_status_timeout_s: float = 30.0
    start_tolerance_rad: float = 0.05
    force_source: str = "wrist_sensor"
    max_missed_fraction: float = 0.01
    max_consecutive_missed: int = 10
    period_tolerance: float = 0.1
    busy_wait: bool = False
    warm_up_lead_s: float | None = None
    warm_up_poll_s: float | None = None
    realtime_priority: int = 0

    def warm_up_lead(self) -> float:
        """The warm-up's lead the client uses [s]: `warm_up_lead_s`, or where that is None,
        AUTO_WARM_UP_FRACTION of `period_s` for a period of at least
        AUTO_WARM_UP_MIN_PERIOD_S and 0 (no warm-up) for a shorter one.

        Returns
        -------
        float
        """
        if self.warm_up_lead_s is not None:
            return self.warm_up_lead_s
        if self.period_s >= AUTO_WARM_UP_MIN_PERIOD_S:
            return AUTO_WARM_UP_FRACTION * self.period_s
        return 0.0

    def warm_up_poll(self) -> float:
        """How long after the expected status the client, after a warm-up, polls for it
        without sleeping [s]: `warm_up_poll_s`, or where that is None, AUTO_WARM_UP_POLL_S
        where a warm-up runs (`warm_up_lead` > 0) and 0 where none does.

        Returns
        -------
        float
        """
        if self.warm_up_poll_s is not None:
            return self.warm_up_poll_s
        return AUTO_WARM_UP_POLL_S if self.warm_up_lead() > 0 else 0.0

    def check(self, fail: Fail) -> None:
        """Known force source, non-empty channels, positive times and tolerance, the
        limits of a degraded run.

        Parameters
        ----------
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        if self.force_source not in FORCE_SOURCES:
            fail(
                "iiwa_driver.force_source",
                f"must be one of {', '.join(FORCE_SOURCES)}, got '{self.force_source}'",
            )
        channels = ("status_channel", "command_channel", "wrist_channel")
        for k, key in enumerate(channels):
            if not getattr(self, key):
                fail(f"iiwa_driver.{key}", "must name an LCM channel")
            for other in channels[:k]:  # a client would read its own messages as the driver's
                if getattr(self, key) == getattr(self, other):
                    fail(
                        f"iiwa_driver.{key}",
                        f"must differ from {other} (both '{getattr(self, key)}')",
                    )
        for key in (
            "period_s",
            "start_guard_s",
            "stale_status_s",
            "stale_wrench_s",
            "first_status_timeout_s",
            "start_tolerance_rad",
        ):
            value = getattr(self, key)
            if not (math.isfinite(value) and value > 0):
                fail(f"iiwa_driver.{key}", f"must be a positive number, got {value}")
        if not 0 <= self.max_missed_fraction < 1:
            fail(
                "iiwa_driver.max_missed_fraction",
                f"must be in [0, 1), got {self.max_missed_fraction}",
            )
        if not self.max_consecutive_missed >= 1:
            fail(
                "iiwa_driver.max_consecutive_missed",
                f"must be at least 1, got {self.max_consecutive_missed}",
            )
        if not 0 < self.period_tolerance < 1:
            fail("iiwa_driver.period_tolerance", f"must be in (0, 1), got {self.period_tolerance}")
        if self.warm_up_lead_s is not None and not 0 <= self.warm_up_lead_s < self.period_s:
            fail(
                "iiwa_driver.warm_up_lead_s",
                f"must be in [0, period_s = {self.period_s:g}), got {self.warm_up_lead_s}",
            )
        if self.warm_up_poll_s is not None and not 0 <= self.warm_up_poll_s < self.period_s:
            fail(
                "iiwa_driver.warm_up_poll_s",
                f"must be in [0, period_s = {self.period_s:g}), got {self.warm_up_poll_s}",
            )
        priority = self.realtime_priority
        if isinstance(priority, bool) or not isinstance(priority, int) or not 0 <= priority <= 99:
            fail(
                "iiwa_driver.realtime_priority",
                f"must be 0 (the normal scheduler) or a SCHED_FIFO priority 1-99, got {priority}",
            )
        if priority and not hasattr(os, "sched_setscheduler"):
            fail(
                "iiwa_driver.realtime_priority",
                "needs SCHED_FIFO (os.sched_setscheduler: Linux), which this platform lacks",
            )


# The largest relative error of the controller's model of a mass (link_mass_error,
# tool_mass_error), either way: a model of this arm is a few percent off, and a value of 1
# or more is most likely a percentage typed where the fraction goes.
MAX_MASS_ERROR = 0.5
# The largest error of the model's tool centre of mass along each axis [m]: a tool's is
# known to millimetres (`real_arm`: 5 mm), and 0.1 m or more is most likely millimetres
# typed where metres go.
MAX_COM_ERROR_M = 0.1


@dc.dataclass
class RobotImperfection:
    """A real iiwa's imperfections: a robot that is not its model (`hlcmp run` only; a
    served run meets the real arm's own). The defaults are a perfect robot: every field at
    its default adds nothing to a run.

    - **The controller's model.** The simulated arm is the scenario's models as they are;
      the controller computes M, C, G and J on a context of the same plant whose
      parameters are set off: each arm link's mass times (1 + `link_mass_error`) (its
      rotational inertia scales with it), the tool body's mass times (1 +
      `tool_mass_error`) and its centre of mass moved by `tool_com_error_m`.
    - **Joint friction** on the simulated arm, which the controller does not know:
      tau_f = -(F_v v + F_c tanh(v / v_s)) per joint (`core.robot.joint_friction_torque`).
    - **The wrist force** the controller reads (a law that reads it) and the safety
      monitor checks is the true one plus a bias and Gaussian noise of per-axis sigma,
      drawn once per control period from `noise_seed`. The logged force, and so the
      metrics and the claims, keep the true force: they judge what the world did.
    - **Velocities**: with `velocity_filter_hz` > 0 the controller reads, instead of the
      plant's exact v, the position differences over the control period through a
      first-order low-pass (drake-iiwa-driver's velocity estimate).
    - **The control period** `control_period_s`: the controller ticks and holds its
      torque over a whole number of plant steps.

    The bundled variant `real_arm` (diagrams/variants/real_arm.yaml, `hlcmp run SCENARIO
    --variant real_arm`) sets every field from a source: the friction from the
    identification of an iiwa 14 R820 by Stürz, Affolter and Smith (IFAC-PapersOnLine 50(1),
    2017, Table 3), the velocity filter from drake-iiwa-driver (40 Hz on the differences
    at the 1 ms FRI period), the noise from ATI's Axia80 manual (0.05 % of full scale,
    calibration SI-500-20), the links' mass error's size from our model's gravity torques
    against the identified arm's (3.3 %: scripts/iiwa_model_vs_identified.py); the tool's
    errors are free parameters at the few percent a tool's data are known to
    (docs/worlds.md says which is which).

    Attributes
    ----------
    link_mass_error : float
        The controller's model of every arm link's mass, relative to the arm's, minus 1: a
        fraction (-0.03: 3 % lighter), from -0.5 to 0.5 (`MAX_MASS_ERROR`). A model is a few
        percent off (`real_arm`: 3 %, 5 %); one off by more than half the mass is not of
        this arm, and 3 is most likely 3 % typed where the fraction goes. Default 0.
    tool_mass_error : float
        The same for the tool's body (the body of `task.tool_frame`), in the same range.
        Default 0.
    tool_com_error_m : list of float
        Where the controller's model puts the tool's centre of mass, minus where it is,
        in the tool body's frame (3 finite values, each from -0.1 to 0.1 m:
        `MAX_COM_ERROR_M`) [m]. Default zeros.
    viscous_friction_Nms_per_rad : list of float
        F_v per arm joint [N m s/rad], finite and >= 0; empty (the default) or one per
        joint of the plant.
    coulomb_friction_Nm : list of float
        F_c per arm joint [N m], finite and >= 0; empty (the default) or one per joint.
    friction_speed_rad_per_s : float
        v_s, the joint speed at which the Coulomb friction reaches tanh(1) = 76 % of
        F_c [rad/s], finite and > 0 (it smooths the sign near v = 0). Default 0.002.
    force_noise_N : list of float
        The wrist force's noise sigma per world axis x, y, z [N] (3 finite values >= 0).
        Default zeros.
    force_bias_N : list of float
        The wrist force's bias per world axis [N] (3 finite values). Default zeros.
    noise_seed : int
        The seed of the noise, >= 0: the same seed gives the same noise. Default 0.
    velocity_filter_hz : float
        The cutoff of the velocity estimate's first-order low-pass [Hz], finite and >= 0;
        0 (the default): the controller reads the plant's exact velocities.
    control_period_s : float
        The controller's tick [s], finite and >= 0, a whole number of plant steps; 0 (the
        default): one plant step.
    """

    link_mass_error: float = 0.0
    tool_mass_error: float = 0.0
    tool_com_error_m: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])
    viscous_friction_Nms_per_rad: list[float] = dc.field(default_factory=list)
    coulomb_friction_Nm: list[float] = dc.field(default_factory=list)
    friction_speed_rad_per_s: float = 0.002
    force_noise_N: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])
    force_bias_N: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])
    noise_seed: int = 0
    velocity_filter_hz: float = 0.0
    control_period_s: float = 0.0

    @property
    def model_differs(self) -> bool:
        """Whether the controller's model differs from the simulated arm."""
        return bool(self.link_mass_error or self.tool_mass_error or any(self.tool_com_error_m))

    @property
    def has_friction(self) -> bool:
        """Whether the simulated arm has joint friction."""
        return any(self.viscous_friction_Nms_per_rad) or any(self.coulomb_friction_Nm)

    @property
    def senses_force(self) -> bool:
        """Whether the wrist force the controller reads is noisy or biased."""
        return any(self.force_noise_N) or any(self.force_bias_N)

    @property
    def perfect(self) -> bool:
        """Whether nothing is set: the robot is its model."""
        return not (
            self.model_differs
            or self.has_friction
            or self.senses_force
            or self.velocity_filter_hz
            or self.control_period_s
        )

    def check(self, fail: Fail) -> None:
        """Every value finite and in its range, the vectors of their lengths.

        Parameters
        ----------
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        key = "robot_imperfection."
        for name in ("link_mass_error", "tool_mass_error"):
            value = getattr(self, name)
            if not (math.isfinite(value) and abs(value) <= MAX_MASS_ERROR):
                fail(
                    key + name,
                    f"must be a fraction of the mass from -{MAX_MASS_ERROR:g} to "
                    f"{MAX_MASS_ERROR:g} (0.03 for 3 %), got {value:g}",
                )
        check_vector(self.tool_com_error_m, key + "tool_com_error_m", fail, (3,), " (x, y, z) [m]")
        if any(abs(value) > MAX_COM_ERROR_M for value in self.tool_com_error_m):
            fail(
                key + "tool_com_error_m",
                f"each value must be from -{MAX_COM_ERROR_M:g} to {MAX_COM_ERROR_M:g} m "
                f"(0.005 for 5 mm), got {self.tool_com_error_m}",
            )
        for name in ("viscous_friction_Nms_per_rad", "coulomb_friction_Nm"):
            for value in getattr(self, name):
                check_number(value, key + name, fail, ">= 0")
        check_number(self.friction_speed_rad_per_s, key + "friction_speed_rad_per_s", fail)
        check_vector(self.force_noise_N, key + "force_noise_N", fail, (3,), " (x, y, z) [N]")
        for value in self.force_noise_N:
            check_number(value, key + "force_noise_N", fail, ">= 0")
        check_vector(self.force_bias_N, key + "force_bias_N", fail, (3,), " (x, y, z) [N]")
        if not self.noise_seed >= 0:
            fail(key + "noise_seed", f"must be >= 0, got {self.noise_seed}")
        check_number(self.velocity_filter_hz, key + "velocity_filter_hz", fail, ">= 0")
        check_number(self.control_period_s, key + "control_period_s", fail, ">= 0")

    def check_scenario(self, scenario: "Scenario", fail: Fail) -> None:
        """An imperfect robot is an arm on the fast path, its control period a whole number
        of plant steps.

        Parameters
        ----------
        scenario : Scenario
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        if self.perfect:
            return
        if not isinstance(scenario.task, ArmTask) or scenario.task.control_path != "fast":
            arm = isinstance(scenario.task, ArmTask)
            fail(
                "robot_imperfection",
                "a robot that is not its model applies to the arm scenarios only (insertion, "
                "cutting, peg_in_hole: an !ArmTask on the fast control path), "
                + (
                    "not with task.control_path: modular"
                    if arm
                    else f"not to a {type(scenario.task).__name__}"
                ),
            )
        step = scenario.plant_config.time_step
        steps = self.control_period_s / step if step > 0 else 0.0
        if self.control_period_s and not (steps >= 1 and math.isclose(steps, round(steps))):
            fail(
                "robot_imperfection.control_period_s",
                f"must be a whole number of plant steps (plant_config.time_step = {step:g} s), "
                f"got {self.control_period_s:g}",
            )

    def check_models(self, plant: MultibodyPlant, fail: Fail) -> None:
        """Each friction list empty or one value per joint of the scenario's plant.

        Parameters
        ----------
        plant : MultibodyPlant
            Finalized, with the scenario's models.
        fail : callable(dotted_key: str, problem: str)
            Raises the InputError that names where the key was set.
        """
        for name in ("viscous_friction_Nms_per_rad", "coulomb_friction_Nm"):
            values = getattr(self, name)
            if values and len(values) != plant.num_velocities():
                fail(
                    f"robot_imperfection.{name}",
                    f"needs none or {plant.num_velocities()} values, one per joint of the "
                    f"scenario's models, got {len(values)}",
                )


@dc.dataclass
class Scenario:
    """A whole scenario: the world (models, plant and simulator configs, task), the
    reference motion, the DMP settings and the controllers to compare.

    `name` names the outputs; `experiment` says how the runs are evaluated: one of the
    experiments registered in `hlcmp_drake.experiments` (their metrics, claims, figures).
    `max_abs_position_m` stops a run whose joint positions run away (unstable).
    `plant_config.use_sampled_output_ports` defaults to false: the plant then steps after
    the unrestricted updates at the same time (the arm's one-call controller, the foam's
    friction), from their values at that time. `iiwa_driver` is how `hlcmp serve` talks
    to an iiwa driver (arm scenarios only).

    Attributes
    ----------
    name : str
        Names the outputs (default folder out/<name>, the diagrams <name>_<controller>);
        required (the default "" fails validation).
    experiment : str
        The name of an experiment registered in `hlcmp_drake.experiments` whose world
        fits `task`: "one_dof" (a SliderTask), "insertion" or "cutting" (an ArmTask) as
        bundled. The default "" names none and is refused when the scenario is run (at
        load: `load_scenario`'s `experiments`).
    duration_s : float
        The simulated (or served) time of every run [s], > 0; for set-points also the
        phase's time constant tau. Default 1.
    log_period_s : float
        The period at which every series is logged [s], > 0 (`hlcmp serve`: every
        round(log_period_s / iiwa_driver.period_s) statuses). Default 0.01.
    directives : list of ModelDirective
        Drake's model directives of the world (add_model, add_weld,
        add_collision_filter_group, ...); a model file is a URL (package://, file://),
        and our package://hlcmp_drake/models/ files and file:// paths must exist; every
        name they use is looked up in the models at load. Default none.
    plant_config : MultibodyPlantConfig
        Drake's plant config (time_step [s], contact model, ...). Default Drake's with
        use_sampled_output_ports false, which an arm world requires; the arm's fast path
        also needs time_step > 0.
    simulator_config : SimulatorConfig
        Drake's simulator config (integration scheme, max step size [s], accuracy,
        target real-time rate, ...). Default Drake's.
    task : SliderTask or ArmTask
        The world kind, tagged !SliderTask or !ArmTask in the YAML. Default a SliderTask.
    reference : StepReferenceConfig or DemonstrationConfig
        The desired motion, tagged !StepReferenceConfig (slider only) or
        !DemonstrationConfig (an arm needs it). Default one set-point x_d = 0.
    dmp : DmpSettings
        The DMP's shape and the phase basis it shares with the compliant profiles
        (Eqs. 8, 13, 15, 16); for set-points the phase's alpha_s and the profiles' N.
        Default DmpSettings().
    controllers : dict of str to controller config
        The controllers to compare, label (free text; names the runs) -> a tagged
        ControllerConfig (!HlcmpConfig, !HlcmpForgettingConfig, !ConstantImpedanceConfig,
        !VariableImpedanceConfig), each per-axis list checked to hold M values. At least
        one is required (the default is empty).
    max_abs_position_m : float
        The bound on every |q| [m or rad], finite and > 0: a run whose joint positions go
        beyond it stops with status "unstable". Default 10.
    recording : RecordingConfig
        The 3-D recording's layout and camera. Default RecordingConfig().
    probe : ProbeConfig
        `hlcmp probe`'s carriage path (arm scenarios). Default: no probe.
    iiwa_driver : IiwaDriverConfig
        `hlcmp serve`'s LCM channels, period and watchdogs (arm scenarios; checked in every
        scenario). Default IiwaDriverConfig().
    robot_imperfection : RobotImperfection
        A real arm's imperfections in a simulated run (arm scenarios on the fast path;
        checked in every scenario). Default a perfect robot.
    """

    name: str = ""
    experiment: str = ""
    duration_s: float = 1.0
    log_period_s: float = 0.01
    directives: list[ModelDirective] = dc.field(default_factory=list)
    plant_config: MultibodyPlantConfig = dc.field(
        default_factory=lambda: MultibodyPlantConfig(use_sampled_output_ports=False)
    )
    simulator_config: SimulatorConfig = dc.field(default_factory=SimulatorConfig)
    task: Union[SliderTask, ArmTask] = dc.field(default_factory=SliderTask)
    reference: Union[StepReferenceConfig, DemonstrationConfig] = dc.field(
        default_factory=StepReferenceConfig
    )
    dmp: DmpSettings = dc.field(default_factory=DmpSettings)
    controllers: dict[str, ControllerConfig] = dc.field(default_factory=dict)
    max_abs_position_m: float = 10.0
    recording: RecordingConfig = dc.field(default_factory=RecordingConfig)
    probe: ProbeConfig = dc.field(default_factory=ProbeConfig)
    iiwa_driver: IiwaDriverConfig = dc.field(default_factory=IiwaDriverConfig)
    robot_imperfection: RobotImperfection = dc.field(default_factory=RobotImperfection)

    @property
    def n_axes(self) -> int:
        """M, the number of task-space axes the controllers act on."""
        return self.task.axis_count(self.reference)
