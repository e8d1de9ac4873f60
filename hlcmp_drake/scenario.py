"""Typed scenario configuration, loaded from YAML with `pydrake.common.yaml`.

A scenario reuses Drake's own config structs where one exists (MultibodyPlantConfig,
SimulatorConfig, ModelDirective) and adds only what is this project's own: the task,
the reference motion, the phase basis and the controllers to compare. Controllers are a
name -> tagged config map, e.g. ``hlcmp: !HlcmpConfig {q_k: [2000], ...}``.
"""


import dataclasses as dc
import math
import re
from pathlib import Path
from typing import Union

from pydrake.common.schema import Transform
from pydrake.common.yaml import yaml_load_typed
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import AddModel, AddWeld, ModelDirective
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.analysis import SimulatorConfig

from hlcmp_drake.errors import InputError
from hlcmp_drake.paths import DIAGRAMS_DIR, PACKAGE_NAME, REPO_ROOT, bundled_scenarios


@dc.dataclass
class BasisConfig:
    """The phase basis shared by the DMP (Eq. 13) and the compliant profiles (Eq. 16)."""

    n_basis: int = 10
    alpha_s: float = 4.0


@dc.dataclass
class StepReferenceConfig:
    """Piecewise-constant set-points: positions_m[k] holds from times_s[k] on."""

    times_s: list[float] = dc.field(default_factory=lambda: [0.0])
    positions_m: list[list[float]] = dc.field(default_factory=lambda: [[0.0]])


@dc.dataclass
class HlcmpConfig:
    """The Hl-CMP learner: learning rates Q per axis (Eq. 31), pi (Eq. 29), L (Eq. 34),
    and the initial value of every weight of theta_k, theta_d, theta_v."""

    q_k: list[float] = dc.field(default_factory=list)
    q_d: list[float] = dc.field(default_factory=list)
    q_v: list[float] = dc.field(default_factory=list)
    pi: float = 5.0
    gain_l: list[float] = dc.field(default_factory=list)
    theta_k0: float = 0.0
    theta_d0: float = 0.0
    theta_v0: float = 0.0


@dc.dataclass
class ConstantImpedanceConfig:
    """Fixed diagonal stiffness/damping in the same structure (Eqs. 33-34 with v = 0)."""

    stiffness_N_per_m: list[float] = dc.field(default_factory=list)
    damping_Ns_per_m: list[float] = dc.field(default_factory=list)
    pi: float = 5.0
    gain_l: list[float] = dc.field(default_factory=list)


@dc.dataclass
class VariableImpedanceConfig:
    """Duan et al. 2018 force-tracking variable impedance (the paper's ref. [21]).

    desired_force_N is the desired reaction force per axis while the task asks for force
    (the reference segments listed in `force_segments`); elsewhere f_d = 0."""

    desired_force_N: list[float] = dc.field(default_factory=list)
    force_segments: list[int] = dc.field(default_factory=lambda: [0])
    mass_kg: list[float] = dc.field(default_factory=list)
    damping_Ns_per_m: list[float] = dc.field(default_factory=list)
    free_stiffness_N_per_m: list[float] = dc.field(default_factory=list)
    sigma: float = 0.002
    sample_period_s: float = 0.001
    kp: list[float] = dc.field(default_factory=list)
    kv: list[float] = dc.field(default_factory=list)


ControllerConfig = Union[HlcmpConfig, ConstantImpedanceConfig, VariableImpedanceConfig]


@dc.dataclass
class SliderTask:
    """A single-joint world (the 1-DOF experiment): the task space is the joint's body
    position along `axis`; the elastic object is a unilateral spring at the surface."""

    body: str = "body"
    axis: int = 0
    environment_stiffness_N_per_m: float = 10.0
    surface_position_m: float = 0.0


@dc.dataclass
class ArmTask:
    """A torque-controlled arm (the iiwa) whose task space is the translation of a tool
    point. The start posture comes from inverse kinematics at the demonstration's start
    with the tool frame's +z axis along `tool_direction` (world; the rotation about it is
    left to the solver, near the seed `ik_seed_rad`) -- or, for a tool whose rotation
    about its axis matters (a blade), with the whole tool orientation `tool_rpy_rad`
    (world roll, pitch, yaw) when given; that orientation and posture are then held below
    the translational task (NullSpaceImpedance)."""

    tool_frame: str = "insertion_tool::tip"
    axes: list[int] = dc.field(default_factory=lambda: [0, 1, 2])
    tool_direction: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, -1.0])
    tool_rpy_rad: list[float] = dc.field(default_factory=list)
    ik_seed_rad: list[float] = dc.field(default_factory=lambda: [0.0, 0.6, 0.0, -1.5, 0.0, 1.0, 0.0])
    orientation_stiffness_Nm_per_rad: float = 100.0
    orientation_damping_Nms_per_rad: float = 10.0
    posture_stiffness_Nm_per_rad: float = 20.0
    posture_damping_Nms_per_rad: float = 5.0
    max_contact_force_N: float = 200.0
    max_saturation_s: float = 0.25


@dc.dataclass
class DemonstrationConfig:
    """The reference is a DMP fitted at start-up to a demonstration CSV (t,x,y,z; world
    frame, metres). `file` is relative to the scenario file's folder. The DMP's N and
    alpha_s are the scenario's `basis`; `duration_s` > 0 replays it at another tau."""

    file: str = ""
    alpha: float = 25.0
    smoothing_s: float = 0.01
    duration_s: float = 0.0


@dc.dataclass
class RecordingConfig:
    """The offline 3-D recording: the runs' copies of the world stand `spacing_m` apart
    along +y; the camera is placed relative to the middle copy."""

    spacing_m: float = 0.6
    camera_position_m: list[float] = dc.field(default_factory=lambda: [1.6, -1.8, 1.2])
    camera_target_m: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.2])
    frames_per_second: float = 30.0


@dc.dataclass
class Scenario:
    """name: names the outputs. experiment: how the runs are evaluated -- one_dof,
    insertion or cutting (their metrics, claims and figures; see hlcmp_drake.experiments)."""

    name: str = ""
    experiment: str = ""
    duration_s: float = 1.0
    log_period_s: float = 0.01
    directives: list[ModelDirective] = dc.field(default_factory=list)
    plant_config: MultibodyPlantConfig = dc.field(default_factory=MultibodyPlantConfig)
    simulator_config: SimulatorConfig = dc.field(default_factory=SimulatorConfig)
    task: Union[SliderTask, ArmTask] = dc.field(default_factory=SliderTask)
    reference: Union[StepReferenceConfig, DemonstrationConfig] = dc.field(default_factory=StepReferenceConfig)
    basis: BasisConfig = dc.field(default_factory=BasisConfig)
    controllers: dict[str, ControllerConfig] = dc.field(default_factory=dict)
    max_abs_position_m: float = 10.0
    recording: RecordingConfig = dc.field(default_factory=RecordingConfig)

    @property
    def n_axes(self):
        if isinstance(self.task, ArmTask):
            return len(self.task.axes)
        return len(self.reference.positions_m[0])


def resolve_scenario_path(name_or_path) -> Path:
    """A bundled scenario name (diagrams/NAME.yaml) or a path to a YAML file."""
    path = Path(name_or_path)
    if path.suffix in (".yaml", ".yml"):
        if not path.is_file():
            raise InputError(f"{path}: no such scenario file")
        return path
    bundled = DIAGRAMS_DIR / f"{name_or_path}.yaml"
    if bundled.is_file():
        return bundled
    raise InputError(f"{name_or_path}: not a bundled scenario ({', '.join(bundled_scenarios())}) "
                     "nor a .yaml file")


def _line_of(text, key):
    """1-based line where `key:` first appears in the YAML text, or None."""
    for number, line in enumerate(text.splitlines(), start=1):
        if re.match(rf"\s*(- )?{re.escape(key)}\s*:", line):
            return number
    return None


def _yaml_error(path, text, error):
    """One line `file:line: problem` for whatever the YAML parser or the schema raised."""
    mark = getattr(error, "problem_mark", None) or getattr(error, "context_mark", None)
    if mark is not None:  # a YAML syntax error: PyYAML knows the line
        problem = " ".join(filter(None, [getattr(error, "context", None), getattr(error, "problem", None)]))
        return InputError(f"{path}:{mark.line + 1}: {problem}")
    message = " ".join(str(error).split())
    line = None
    field = re.search(r"\['([^']+)'|for '([^']+)'|options for '([^']+)'", message)
    value = re.search(r": '([^']*)'$", message)
    if field:
        line = _line_of(text, next(g for g in field.groups() if g))
    elif value:  # a value of the wrong type: find the line that holds it
        line = next((n for n, row in enumerate(text.splitlines(), 1)
                     if re.search(rf":\s*{re.escape(value.group(1))}\s*(#.*)?$", row)), None)
    return InputError(f"{path}:{line}: {message}" if line else f"{path}: {message}")


def load_scenario(name_or_path):
    """Load and validate a scenario; any problem is an InputError naming file and line."""
    path = resolve_scenario_path(name_or_path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: cannot be read as text ({error.__class__.__name__})") from None
    try:
        scenario = yaml_load_typed(schema=Scenario, data=text)
    except Exception as error:  # yaml errors come as several exception types
        raise _yaml_error(path, text, error) from None
    validate_scenario(scenario, path, text)
    if isinstance(scenario.reference, DemonstrationConfig):
        # Resolve the demonstration next to the scenario file, once, for every later user.
        scenario.reference.file = str((path.parent / scenario.reference.file).resolve())
    return scenario, path


def _model_file_exists(file):
    """Our package:// models and plain paths are checked; other packages (drake_models,
    downloaded by Drake on first use) are left to Drake."""
    prefix = f"package://{PACKAGE_NAME}/"
    if file.startswith(prefix):
        return (REPO_ROOT / file[len(prefix):]).is_file()
    if file.startswith("package://"):
        return True
    return Path(file.removeprefix("file://")).is_file()


def validate_scenario(scenario: Scenario, path, text=""):
    """Semantic checks that the YAML schema cannot express."""

    def fail(key, problem):
        line = _line_of(text, key) if text else None
        raise InputError(f"{path}:{line}: {key}: {problem}" if line else f"{path}: {key}: {problem}")

    if not scenario.name:
        fail("name", "must be given")
    for directive in scenario.directives:
        if directive.add_model is not None and not _model_file_exists(directive.add_model.file):
            file = directive.add_model.file
            line = next((n for n, row in enumerate(text.splitlines(), 1) if file in row), None)
            where = f"{path}:{line}" if line else f"{path}"
            raise InputError(f"{where}: file: model file '{file}' does not exist")
    from hlcmp_drake.experiments import EXPERIMENTS  # late: the experiments import this module

    if scenario.experiment not in EXPERIMENTS:
        fail("experiment", f"must be one of {', '.join(EXPERIMENTS)}, got '{scenario.experiment}'")
    if (scenario.experiment == "one_dof") != isinstance(scenario.task, SliderTask):
        fail("experiment", f"'{scenario.experiment}' does not fit a {type(scenario.task).__name__}")
    for key in ("duration_s", "log_period_s"):
        value = getattr(scenario, key)
        if not (math.isfinite(value) and value > 0):
            fail(key, f"must be a positive number, got {value}")
    if scenario.basis.n_basis < 2:
        fail("n_basis", f"must be at least 2, got {scenario.basis.n_basis}")
    if not scenario.basis.alpha_s > 0:
        fail("alpha_s", "must be positive")
    reference = scenario.reference
    if isinstance(reference, StepReferenceConfig) and isinstance(scenario.task, ArmTask):
        fail("reference", "an arm task needs a !DemonstrationConfig reference")
    if isinstance(reference, StepReferenceConfig):
        if len(reference.times_s) != len(reference.positions_m) or not reference.times_s:
            fail("times_s", "needs one entry per row of positions_m")
        if reference.times_s[0] != 0 or any(b <= a for a, b in zip(reference.times_s, reference.times_s[1:])):
            fail("times_s", "must start at 0 and increase")
        if len({len(row) for row in reference.positions_m}) != 1:
            fail("positions_m", "every row needs the same number of axes")
    if isinstance(reference, DemonstrationConfig):
        demo = Path(path).parent / reference.file
        if not reference.file or not demo.is_file():
            fail("file", f"demonstration file '{reference.file}' not found (looked for {demo})")
        if not (reference.alpha > 0 and reference.smoothing_s >= 0 and reference.duration_s >= 0):
            fail("alpha", "alpha > 0, smoothing_s >= 0 and duration_s >= 0 are required")
    task = scenario.task
    if isinstance(task, ArmTask):
        if not task.axes or any(a not in (0, 1, 2) for a in task.axes) or len(set(task.axes)) != len(task.axes):
            fail("axes", f"task axes must be distinct values of 0 (x), 1 (y), 2 (z), got {task.axes}")
        if len(task.tool_direction) != 3 or not any(task.tool_direction):
            fail("tool_direction", "needs a non-zero 3-vector")
        if len(task.tool_rpy_rad) not in (0, 3):
            fail("tool_rpy_rad", "needs three angles (roll, pitch, yaw), or none")
        for key in ("orientation_stiffness_Nm_per_rad", "orientation_damping_Nms_per_rad",
                    "posture_stiffness_Nm_per_rad", "posture_damping_Nms_per_rad"):
            if not (math.isfinite(getattr(task, key)) and getattr(task, key) >= 0):
                fail(key, f"must be non-negative, got {getattr(task, key)}")
        if not task.max_contact_force_N > 0:
            fail("max_contact_force_N", "must be positive")
        if not task.max_saturation_s > 0:
            fail("max_saturation_s", "must be positive")
    m = scenario.n_axes
    if not scenario.controllers:
        fail("controllers", "at least one controller is needed")
    for name, config in scenario.controllers.items():
        _validate_controller(name, config, m, fail)


def _validate_controller(name, config, m, fail):
    def per_axis(key, nonnegative=True, positive=False):
        values = getattr(config, key)
        if len(values) != m:
            fail(key, f"controller '{name}' needs {m} value(s), one per axis, got {len(values)}")
        for value in values:
            if not math.isfinite(value) or (nonnegative and value < 0) or (positive and value <= 0):
                kind = "positive" if positive else "non-negative"
                fail(key, f"controller '{name}': every value must be {kind} and finite, got {value}")

    if isinstance(config, (HlcmpConfig, ConstantImpedanceConfig)):
        if not config.pi > 0:
            fail("pi", f"controller '{name}': pi must be > 0 (Eq. 29), got {config.pi}")
        per_axis("gain_l")
    if isinstance(config, HlcmpConfig):
        for key in ("q_k", "q_d", "q_v"):
            per_axis(key)
    elif isinstance(config, ConstantImpedanceConfig):
        per_axis("stiffness_N_per_m")
        per_axis("damping_Ns_per_m")
    elif isinstance(config, VariableImpedanceConfig):
        per_axis("desired_force_N", nonnegative=False)
        per_axis("mass_kg", positive=True)
        per_axis("damping_Ns_per_m", positive=True)
        for key in ("free_stiffness_N_per_m", "kp", "kv"):
            per_axis(key)
        if not (config.sigma >= 0 and config.sample_period_s > 0):
            fail("sigma", f"controller '{name}': sigma >= 0 and sample_period_s > 0 are required")


OWN_IIWA = "package://hlcmp_drake/models/iiwa14.sdf"
DRAKE_MODELS_IIWA = "package://drake_models/iiwa_description/sdf/iiwa14_no_collision.sdf"
FLANGE_OFFSET_M = 0.045   # our model's "flange" frame, along link 7's +z


def use_drake_models_iiwa(scenario: Scenario) -> Scenario:
    """The same scenario with Drake's official iiwa14 (drake_models, which Drake downloads
    on first use: needs internet) in place of ours. Its links have the same names; it has
    no "flange" frame, so welds to iiwa::flange go to iiwa::iiwa_link_7 + 0.045 m."""
    directives = []
    for directive in scenario.directives:
        model, weld = directive.add_model, directive.add_weld
        if model is not None and model.file == OWN_IIWA:
            directive = ModelDirective(add_model=AddModel(
                file=DRAKE_MODELS_IIWA, name=model.name,
                default_joint_positions=model.default_joint_positions,
                default_free_body_pose=model.default_free_body_pose))
        elif weld is not None and weld.parent.endswith("::flange"):
            x_pc = weld.X_PC.GetDeterministicValue() if weld.X_PC is not None else RigidTransform()
            directive = ModelDirective(add_weld=AddWeld(
                parent=weld.parent[: -len("flange")] + "iiwa_link_7", child=weld.child,
                X_PC=Transform(RigidTransform([0.0, 0.0, FLANGE_OFFSET_M]) @ x_pc)))
        directives.append(directive)
    return dc.replace(scenario, directives=directives)
