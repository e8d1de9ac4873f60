"""Every field of the bundled scenarios, broken: `hlcmp run SCENARIO --set KEY=BROKEN --out
DIR` is refused at load (exit 2) in one line that names the override and the field, within
15 s, before any diagram is built or simulated, and writes nothing.

The fields are found by walking the loaded scenarios: our dataclasses, Drake's config
structs, every controller, and the model directives item by item (a directive's field is
broken by overriding the whole `directives` list with that one field changed). Each field
gets the broken values of the first BREAKS pattern that matches it; the few with no
invalid value are in EXEMPT with the reason. A field that matches neither fails
`test_every_field_has_a_break_or_an_exemption`, so a new field needs a rule here."""

from __future__ import annotations

import copy
import dataclasses as dc
import fnmatch
import math
import time

import numpy as np
import pytest
import yaml
from pydrake.common.schema import Rotation, Transform
from pydrake.common.yaml import yaml_dump_typed
from pydrake.multibody.parsing import ModelDirectives

from hlcmp_drake.cli import main
from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.validation import DIRECTIVE_KINDS
from hlcmp_drake.io.outputs import WRITTEN

SCENARIOS = ("one_dof", "insertion", "cutting", "peg_in_hole")
NAN = math.nan
LOAD_LIMIT_S = 15.0


def _nan_transform():
    pose = Transform()
    pose.translation = np.array([NAN, 0.0, 0.0])
    return pose


def _misspelt(name):
    return f"{name}x"


def _with_nan(values):
    return [NAN, *values[1:]] if values else [NAN, 0.0, 0.0]


# The value next to the valid ones that each sign rule refuses.
REFUSED = {"> 0": [0.0], ">= 0": [-1.0], "any": []}


def _number(rule):
    """A number's breaks: NaN, and the value the rule refuses (0 for "> 0", -1 for ">= 0")."""
    return lambda value, scenario: [NAN, *REFUSED[rule]]


def _per_axis(rule):
    """A controller's per-axis list: one value more, a NaN, and a value the rule refuses."""
    return lambda value, scenario: (
        [[*value, 0.0], _with_nan(value)] + [[bad, *value[1:]] for bad in REFUSED[rule]]
    )


def _camera(other):
    """A camera point: two values, a NaN, and the other point itself (no view direction)."""
    return lambda value, scenario: [
        value[:2],
        _with_nan(value),
        getattr(scenario.recording, other),
    ]


def _alone(scenario, value):
    """[value] where the scenario has no probe (start_m or push_m alone is no probe), else []."""
    return [] if scenario.probe.given else [value]


def _other_world(value, scenario):
    return ["nope", "", "insertion" if scenario.name == "one_dof" else "one_dof"]


def _not_an_arm(value, scenario):
    """A model the probe cannot carry: a misspelt one, and one with no tool welded to it."""
    return [
        _misspelt(value),
        {"insertion": "foam_plank", "cutting": "cutting_block", "peg_in_hole": "peg_fixture"}[
            scenario.name
        ],
    ]


# (dotted-path pattern, breaks(value, scenario)); the first pattern that matches is a field's
# (fnmatch: "*" matches dots too). A directive's path has its index: "directives.3.add_weld.parent".
BREAKS = [
    ("name", lambda v, s: [""]),
    ("experiment", _other_world),
    ("duration_s", _number("> 0")),
    ("log_period_s", _number("> 0")),
    ("max_abs_position_m", _number("> 0")),
    # the model directives (Drake's ModelDirective rules, and what the parse finds)
    ("directives.*.add_model.name", lambda v, s: [""]),
    (
        "directives.*.add_model.file",
        lambda v, s: ["package://hlcmp_drake/models/nope.sdf", "", v.rsplit("/", 1)[-1]],
    ),
    ("directives.*.add_model.default_joint_positions", lambda v, s: [{"j": np.array([NAN])}]),
    ("directives.*.add_model.default_free_body_pose", lambda v, s: [{"b": _nan_transform()}]),
    ("directives.*.add_weld.parent", lambda v, s: [_misspelt(v), ""]),
    ("directives.*.add_weld.child", lambda v, s: [_misspelt(v), ""]),
    ("directives.*.add_weld.X_PC", lambda v, s: [_nan_transform()]),
    ("directives.*.add_weld.X_PC.base_frame", lambda v, s: ["world"]),
    ("directives.*.add_weld.X_PC.translation", lambda v, s: [np.array([0.0, NAN, 0.0])]),
    (
        "directives.*.add_weld.X_PC.rotation",
        lambda v, s: [Rotation(value=Rotation.Rpy(deg=[NAN, 0.0, 0.0]))],
    ),
    ("directives.*.add_collision_filter_group.name", lambda v, s: [""]),
    ("directives.*.add_collision_filter_group.members", lambda v, s: [[_misspelt(v[0])], []]),
    ("directives.*.add_collision_filter_group.member_groups", lambda v, s: [["nope"]]),
    ("directives.*.add_collision_filter_group.model_namespace", lambda v, s: ["nope"]),
    (
        "directives.*.add_collision_filter_group.ignored_collision_filter_groups",
        lambda v, s: [["nope"]],
    ),
    # Drake's plant and simulator configs
    ("plant_config.time_step", _number(">= 0")),
    ("plant_config.use_sampled_output_ports", lambda v, s: [True]),  # an arm world's rule
    ("plant_config.penetration_allowance", _number("> 0")),
    ("plant_config.stiction_tolerance", _number("> 0")),
    ("plant_config.sap_near_rigid_threshold", _number(">= 0")),
    ("plant_config.contact_model", lambda v, s: ["nope"]),
    ("plant_config.discrete_contact_approximation", lambda v, s: ["nope"]),
    ("plant_config.contact_surface_representation", lambda v, s: ["nope"]),
    ("simulator_config.integration_scheme", lambda v, s: ["nope", ""]),
    ("simulator_config.max_step_size", _number("> 0")),
    ("simulator_config.accuracy", _number("> 0")),
    ("simulator_config.start_time", lambda v, s: [1.0, NAN]),
    ("simulator_config.target_realtime_rate", _number(">= 0")),
    # the slider's task
    ("task.body", lambda v, s: [_misspelt(v), ""]),
    ("task.axis", lambda v, s: [3, -1, 1, 2]),  # the slider's joint moves along x alone
    ("task.environment_stiffness_N_per_m", _number(">= 0")),
    ("task.surface_position_m", _number("any")),
    # the arm's task
    ("task.tool_frame", lambda v, s: [_misspelt(v), "nope::tip", "", "tipp"]),
    ("task.axes", lambda v, s: [[0, 1], [0, 1, 1], [0, 1, 3]]),
    ("task.tool_direction", lambda v, s: [[0.0, 0.0], _with_nan(v), [0.0, 0.0, 0.0]]),
    ("task.tool_rpy_rad", lambda v, s: [[0.0, 0.0], [NAN, 0.0, 0.0], [*v, 0.0, 0.0]]),
    ("task.ik_seed_rad", lambda v, s: [v[:-1], [*v, 0.0], _with_nan(v)]),
    ("task.orientation_*", _number(">= 0")),
    ("task.posture_*", _number(">= 0")),
    ("task.max_contact_force_N", _number("> 0")),
    ("task.max_saturation_s", _number("> 0")),
    ("task.puncture.object_frame", lambda v, s: [_misspelt(v) if v else "nope::top"]),
    ("task.puncture.thickness_m", _number("> 0")),
    ("task.puncture.depth_m", lambda v, s: [NAN, 0.0, 1.0]),
    ("task.puncture.hole_friction_N_per_m", _number(">= 0")),
    ("task.puncture.sliding_speed_m_per_s", _number("> 0")),
    ("task.control_path", lambda v, s: ["nope"]),
    # the reference
    ("reference.times_s", lambda v, s: [[1.0, *v[1:]], v[:-1], [v[0], NAN], [v[0], -1.0], []]),
    (
        "reference.positions_m",
        lambda v, s: [[[NAN]] * len(v), [[0.0, 0.0]] * len(v), [[0.0]] * (len(v) + 1)],
    ),
    ("reference.file", lambda v, s: ["nope.csv", ""]),
    ("reference.duration_s", _number(">= 0")),
    ("dmp.n_basis", lambda v, s: [1, -3]),
    ("dmp.alpha", _number("> 0")),
    ("dmp.beta", _number("> 0")),
    ("dmp.alpha_s", _number("> 0")),
    ("dmp.smoothing_s", _number(">= 0")),
    # the controllers
    ("controllers.*.pi", _number("> 0")),
    ("controllers.*.pi_r", _number("> 0")),
    ("controllers.*.theta_?0", _number("any")),
    ("controllers.*.theta_??0", _number("any")),  # the rotational weights' start
    ("controllers.*.q_units", lambda v, s: ["nope"]),
    ("controllers.*.control_step_s", _number("> 0")),
    ("controllers.*.forgetting_per_s", _number(">= 0")),
    ("controllers.*.force_segments", lambda v, s: [[5], [-1]]),
    ("controllers.*.sigma", _number(">= 0")),
    ("controllers.*.sample_period_s", _number("> 0")),
    ("controllers.*.desired_force_N", _per_axis("any")),
    ("controllers.vic_*.mass_kg", _per_axis("> 0")),
    ("controllers.vic_*.damping_Ns_per_m", _per_axis("> 0")),
    ("controllers.*", _per_axis(">= 0")),  # the other per-axis lists: Q, L, K, D, kp, kv
    # the recording, the probe, the iiwa driver
    ("recording.spacing_m", _number(">= 0")),
    ("recording.camera_position_m", _camera("camera_target_m")),
    ("recording.camera_target_m", _camera("camera_position_m")),
    ("recording.frames_per_second", lambda v, s: [NAN, 0.0, 241.0]),
    ("probe.arm_model", _not_an_arm),
    ("probe.start_m", lambda v, s: [[0.0, 0.0], _with_nan(v), *_alone(s, [0.6, 0.0, 0.3])]),
    ("probe.approach_m", lambda v, s: [[0.0], [NAN, 0.0, 0.0]]),
    (
        "probe.push_m",
        lambda v, s: [[0.0], _with_nan(v), [0.0, 0.0, 0.0], *_alone(s, [0.0, 0.0, -0.1])],
    ),
    ("probe.lateral_axis", lambda v, s: [[1.0], [NAN, 0.0, 0.0], [0.0, 0.0, 0.0]]),
    ("probe.speed_m_per_s", _number("> 0")),
    ("probe.tilt_rad", _number("any")),
    (
        "probe.wrist_stiffness_Nm_per_rad",
        lambda v, s: [[0.0, 0.0], [NAN, 0.0, 0.0], [-1.0, 0.0, 0.0]],
    ),
    ("probe.wrist_damping_Nms_per_rad", _number(">= 0")),
    ("iiwa_driver.*_channel", lambda v, s: [""]),
    ("iiwa_driver.force_source", lambda v, s: ["nope"]),
    ("iiwa_driver.max_missed_fraction", lambda v, s: [-0.1, 1.0, float("nan")]),
    ("iiwa_driver.max_consecutive_missed", lambda v, s: [0, -3]),
    ("iiwa_driver.period_tolerance", lambda v, s: [0.0, 1.0, float("nan")]),
    ("iiwa_driver.warm_up_lead_s", lambda v, s: [-1e-4, s.iiwa_driver.period_s, NAN]),
    ("iiwa_driver.warm_up_poll_s", lambda v, s: [-1e-4, s.iiwa_driver.period_s, NAN]),
    ("iiwa_driver.realtime_priority", lambda v, s: [-1, 100]),
    ("iiwa_driver.*", _number("> 0")),  # the periods, the timeouts and the tolerance
    # a robot that is not its model
    # a fraction of the mass: -1 leaves none, 3 is 3 % typed as a percentage
    ("robot_imperfection.*_mass_error", lambda v, s: [NAN, -1.0, 3.0]),
    (
        "robot_imperfection.tool_com_error_m",
        lambda v, s: [[0.0, 0.0], _with_nan(v), [5.0, 0.0, -5.0]],  # the last in mm
    ),
    (
        "robot_imperfection.*_friction_*",  # one per joint of the plant (7 or 1), >= 0
        lambda v, s: [[0.1] * 3, [NAN] * 7, [-1.0] * 7],
    ),
    ("robot_imperfection.friction_speed_rad_per_s", _number("> 0")),
    ("robot_imperfection.force_noise_N", lambda v, s: [[0.0], [NAN, 0.0, 0.0], [-1.0, 0.0, 0.0]]),
    ("robot_imperfection.force_bias_N", lambda v, s: [[0.0], [NAN, 0.0, 0.0]]),
    ("robot_imperfection.noise_seed", lambda v, s: [-1]),
    ("robot_imperfection.velocity_filter_hz", _number(">= 0")),
    ("robot_imperfection.control_period_s", lambda v, s: [NAN, -1.0, 0.0015]),
]

# (scenario or "*", dotted-path pattern, why the field has no value to break).
EXEMPT = [
    ("*", "plant_config.adjacent_bodies_collision_filters", "Drake's switch: both values run"),
    ("*", "simulator_config.use_error_control", "Drake's switch: both values run"),
    ("*", "simulator_config.publish_every_time_step", "Drake's switch: both values run"),
    ("*", "iiwa_driver.busy_wait", "a switch: both values serve"),
    (
        "one_dof",
        "plant_config.use_sampled_output_ports",
        "the slider world runs with either value (an arm world needs false: broken there)",
    ),
    (
        "one_dof",
        "probe.arm_model",
        "read by a probe only, which the slider world cannot have (its start_m and push_m "
        "are broken: a probe there is refused)",
    ),
]


def _walk(node, path=()):
    """(path, value) of every field under `node`: a dataclass's fields, a Drake struct's
    (of a directive, only the kind it is), each controller, each item of a list of
    structs; a Rotation is one field (its variant)."""
    if dc.is_dataclass(node):
        for field in dc.fields(node):
            yield from _walk(getattr(node, field.name), (*path, field.name))
    elif path == ("controllers",):
        for label, config in node.items():
            yield from _walk(config, (*path, label))
    elif isinstance(node, Rotation):
        yield path, node
    elif hasattr(type(node), "__fields__"):
        for field in type(node).__fields__:
            value = getattr(node, field.name)
            if not (field.name in DIRECTIVE_KINDS and value is None):
                yield from _walk(value, (*path, field.name))
    elif isinstance(node, list) and node and hasattr(type(node[0]), "__fields__"):
        for k, item in enumerate(node):
            yield from _walk(item, (*path, k))
    else:
        yield path, node


def _dotted(path):
    return ".".join(map(str, path))


def _exemption(scenario, path):
    return next(
        (
            reason
            for name, pattern, reason in EXEMPT
            if name in ("*", scenario) and fnmatch.fnmatchcase(_dotted(path), pattern)
        ),
        None,
    )


def _breaks(loaded, path, value):
    rule = next((f for p, f in BREAKS if fnmatch.fnmatchcase(_dotted(path), p)), None)
    return None if rule is None else rule(value, loaded)


def _fields():
    for scenario in SCENARIOS:
        loaded, _ = load_scenario(scenario)
        for path, value in _walk(loaded):
            yield scenario, loaded, path, value


FIELDS = list(_fields())


def _replaced(node, path, value):
    """A copy of `node` with the field at `path` set to `value` (Drake's structs hand out
    copies of their fields, so each level is set back into a copy of its parent)."""
    if not path:
        return value
    head, rest = path[0], path[1:]
    if isinstance(head, int):
        items = list(node)
        items[head] = _replaced(items[head], rest, value)
        return items
    changed = copy.deepcopy(node)
    setattr(changed, head, _replaced(getattr(node, head), rest, value))
    return changed


def _flow(node):
    """Make a composed YAML node (and every node in it) flow style: one line."""
    if isinstance(node, yaml.SequenceNode):
        children = node.value
    elif isinstance(node, yaml.MappingNode):
        children = [child for _, child in node.value]
    else:
        return
    node.flow_style = True
    for child in children:
        _flow(child)


def _override(scenario, path, broken):
    """The --set that gives the field at `path` the value `broken`: `key=value`, or for a
    directive's field the whole list of directives, in YAML flow style, with it changed."""
    if not any(isinstance(part, int) for part in path):
        value = yaml.safe_dump(broken, default_flow_style=True, width=math.inf)
        return f"{_dotted(path)}={value.strip().removesuffix('...').strip()}"
    directives = _replaced(scenario, path, broken).directives
    document = yaml.compose(yaml_dump_typed(ModelDirectives(directives=directives)))
    node = next(v for k, v in document.value if k.value == "directives")
    _flow(node)
    return f"directives={yaml.serialize(node, width=math.inf).strip()}"


def test_every_field_has_a_break_or_an_exemption():
    unruled = [
        f"{s}:{_dotted(p)}"
        for s, sc, p, v in FIELDS
        if _exemption(s, p) is None and _breaks(sc, p, v) is None
    ]
    assert not unruled, "fields with no broken value and no exemption: " + ", ".join(unruled)
    for name, pattern, _ in EXEMPT:  # no exemption outlives its field
        assert any(
            name in ("*", s) and fnmatch.fnmatchcase(_dotted(p), pattern) for s, _, p, _ in FIELDS
        ), (name, pattern)
    assert len(FIELDS) > 300  # the three scenarios' fields, controllers and directives included


def _reached_the_run(*args, **kwargs):
    raise AssertionError("the broken value passed the checks at load: a run was started")


@pytest.mark.parametrize(
    "scenario, loaded, path, value",
    [
        pytest.param(s, sc, p, v, id=f"{s}:{_dotted(p)}")
        for s, sc, p, v in FIELDS
        if _exemption(s, p) is None
    ],
)
def test_a_broken_field_is_refused_at_load(
    scenario, loaded, path, value, tmp_path, capfd, monkeypatch
):
    monkeypatch.setattr("hlcmp_drake.run.runner.run_loaded_scenario", _reached_the_run)
    out = tmp_path / "out"
    names = {str(part) for part in path}
    for broken in _breaks(loaded, path, value):
        override = _override(loaded, path, broken)
        start = time.perf_counter()
        status = main(["run", scenario, "--set", override, "--out", str(out), "--quiet"])
        elapsed = time.perf_counter() - start
        captured = capfd.readouterr()
        lines = captured.err.strip().splitlines()
        assert status == 2 and len(lines) == 1, (override, captured.err)
        prefix = f"hlcmp: error: override '{override}': "
        assert lines[0].startswith(prefix), (override, lines[0])
        leaf, _, problem = lines[0][len(prefix) :].partition(": ")
        assert (leaf in names or leaf == "directives") and problem, (override, lines[0])
        assert elapsed < LOAD_LIMIT_S, (override, elapsed)
        assert not out.exists() and not WRITTEN, (override, WRITTEN)
