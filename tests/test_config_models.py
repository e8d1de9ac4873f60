"""hlcmp_drake.config.models.process_directives: the bundled models parsed from their text,
welded and collision-filtered here, make the same plant and the same scene as Drake's
ProcessModelDirectives of the same directives, for every bundled scenario, with a
SceneGraph and without; a directive list outside what is done here is left to Drake whole."""

import dataclasses

import pytest
from pydrake.geometry import Role
from pydrake.multibody.parsing import (
    AddCollisionFilterGroup,
    AddDirectives,
    AddModel,
    AddWeld,
    ModelDirective,
)
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant
from pydrake.multibody.tree import (
    BodyIndex,
    FrameIndex,
    ModelInstanceIndex,
)
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.models import bundled_model_texts, process_directives
from hlcmp_drake.io.paths import bundled_scenarios


def pose(transform):
    return transform.GetAsMatrix34().tolist()


def property_value(value):
    try:
        held = value.get_value()
    except RuntimeError:  # HydroelasticType has no Python binding: compared by presence
        return "not readable in Python"
    if hasattr(held, "static_friction"):
        return ("friction", held.static_friction(), held.dynamic_friction())
    return repr(held)


def description(plant, scene_graph):
    """Everything of the plant and its scene that a parse decides, in registration order."""
    instances = [
        plant.GetModelInstanceName(ModelInstanceIndex(k))
        for k in range(plant.num_model_instances())
    ]
    bodies = [
        (
            body.name(),
            plant.GetModelInstanceName(body.model_instance()),
            body.default_spatial_inertia().CopyToFullMatrix6().tolist(),
        )
        for body in (plant.get_body(BodyIndex(k)) for k in range(plant.num_bodies()))
    ]
    joints = [
        (
            joint.name(),
            joint.type_name(),
            joint.frame_on_parent().name(),
            joint.frame_on_child().name(),
            joint.parent_body().name(),
            joint.child_body().name(),
            pose(joint.frame_on_parent().GetFixedPoseInBodyFrame()),
            pose(joint.frame_on_child().GetFixedPoseInBodyFrame()),
            joint.position_lower_limits().tolist(),
            joint.position_upper_limits().tolist(),
            joint.velocity_lower_limits().tolist(),
            joint.velocity_upper_limits().tolist(),
            joint.acceleration_lower_limits().tolist(),
            joint.acceleration_upper_limits().tolist(),
            joint.default_positions().tolist(),
            joint.default_damping_vector().tolist(),
        )
        for joint in (plant.get_joint(k) for k in plant.GetJointIndices())
    ]
    frames = [
        (frame.name(), frame.body().name(), pose(frame.GetFixedPoseInBodyFrame()))
        for frame in (plant.get_frame(FrameIndex(k)) for k in range(plant.num_frames()))
    ]
    actuators = [
        (
            actuator.name(),
            actuator.joint().name(),
            actuator.effort_limit(),
            actuator.default_rotor_inertia(),
            actuator.default_gear_ratio(),
        )
        for actuator in (plant.get_joint_actuator(k) for k in plant.GetJointActuatorIndices())
    ]
    parts = {
        "instances": instances,
        "bodies": bodies,
        "joints": joints,
        "frames": frames,
        "actuators": actuators,
    }
    if scene_graph is None:
        return parts
    inspector = scene_graph.model_inspector()
    ids = inspector.GetAllGeometryIds()
    geometries = []
    for gid in ids:
        roles = []
        for role in (Role.kProximity, Role.kIllustration, Role.kPerception):
            properties = inspector.GetProperties(gid, role)
            roles.append(
                None
                if properties is None
                else {
                    group: {
                        name: property_value(value)
                        for name, value in properties.GetPropertiesInGroup(group).items()
                    }
                    for group in properties.GetGroupNames()
                }
            )
        geometries.append(
            (
                inspector.GetName(gid),
                inspector.GetName(inspector.GetFrameId(gid)),
                repr(inspector.GetShape(gid)),
                pose(inspector.GetPoseInFrame(gid)),
                roles,
            )
        )
    colliding = [g for g in ids if inspector.GetProximityProperties(g) is not None]
    filtered = [[inspector.CollisionFiltered(a, b) for b in colliding] for a in colliding]
    return {**parts, "geometries": geometries, "filtered": filtered}


def built(scenario, by_drake, scene_graph=True):
    """The scenario's plant finalized (and its scene), its directives by Drake or here."""
    if scene_graph:
        plant, scene = AddMultibodyPlant(scenario.plant_config, DiagramBuilder())
    else:
        plant, scene = MultibodyPlant(scenario.plant_config.time_step), None
    process_directives(plant, scenario.directives, scene, by_drake)
    plant.Finalize()
    return description(plant, scene)


@pytest.mark.parametrize("scene_graph", [True, False], ids=["scene", "plant_alone"])
@pytest.mark.parametrize("name", bundled_scenarios())
def test_the_bundled_worlds_are_parsed_as_drake_parses_them(name, scene_graph):
    scenario = load_scenario(name)[0]
    assert bundled_model_texts(MultibodyPlant(0.0), scenario.directives) is not None
    here, by_drake = built(scenario, False, scene_graph), built(scenario, True, scene_graph)
    for part in by_drake:  # as text: the world body's inertia is NaN
        assert repr(here[part]) == repr(by_drake[part]), part
    if scene_graph and any(d.add_collision_filter_group for d in scenario.directives):
        flat = [f for row in here["filtered"] for f in row]  # the filters are seen: some
        assert any(flat) and not all(flat)  # pairs filtered, some not


def test_a_model_is_renamed_to_its_directive_and_its_mesh_found_beside_it():
    scenario = load_scenario("peg_in_hole")[0]
    renamed = [copy_with_name(d, "fixture_2") if is_fixture(d) else d for d in scenario.directives]
    renamed = [rename_weld_child(d, "peg_fixture::", "fixture_2::") for d in renamed]
    renamed = [rename_members(d, "peg_fixture::", "fixture_2::") for d in renamed]
    scenario = dataclasses.replace(scenario, directives=renamed)
    here, by_drake = built(scenario, False), built(scenario, True)
    assert "fixture_2" in here["instances"] and "peg_fixture" not in here["instances"]
    assert repr(here) == repr(by_drake)
    assert any("peg_fixture.obj" in g[2] for g in here["geometries"])


def is_fixture(directive):
    return directive.add_model is not None and directive.add_model.name == "peg_fixture"


def copy_with_name(directive, name):
    add = directive.add_model
    return ModelDirective(add_model=AddModel(file=add.file, name=name))


def rename_weld_child(directive, old, new):
    weld = directive.add_weld
    if weld is None or not weld.child.startswith(old):
        return directive
    return ModelDirective(
        add_weld=AddWeld(parent=weld.parent, child=new + weld.child[len(old) :], X_PC=weld.X_PC)
    )


def rename_members(directive, old, new):
    group = directive.add_collision_filter_group
    if group is None:
        return directive
    members = [new + m[len(old) :] if m.startswith(old) else m for m in group.members]
    return ModelDirective(
        add_collision_filter_group=AddCollisionFilterGroup(
            name=group.name,
            members=members,
            ignored_collision_filter_groups=group.ignored_collision_filter_groups,
        )
    )


def outside(directives):
    """Directives the bundled text route must leave to Drake."""
    return bundled_model_texts(MultibodyPlant(0.0), directives) is None


def test_what_is_not_a_bundled_model_weld_or_own_filter_is_left_to_drake():
    insertion = load_scenario("insertion")[0].directives
    model = next(d for d in insertion if d.add_model is not None).add_model
    group = next(d for d in insertion if d.add_collision_filter_group is not None)
    group = group.add_collision_filter_group

    def with_model(**fields):
        return [ModelDirective(add_model=AddModel(**{"file": model.file, "name": "a", **fields}))]

    def with_group(**fields):
        values = {
            "name": group.name,
            "members": group.members,
            "ignored_collision_filter_groups": group.ignored_collision_filter_groups,
        }
        values.update(fields)
        return insertion[:-1] + [
            ModelDirective(add_collision_filter_group=AddCollisionFilterGroup(**values))
        ]

    assert not outside(insertion)
    assert outside(with_model(file="package://hlcmp_drake/models/missing.sdf"))
    assert outside(with_model(file="package://drake_models/iiwa_description/sdf/x.sdf"))
    assert outside(with_model(name="a b"))
    assert outside(with_model(default_joint_positions={"j": [0.1]}))
    assert outside(with_model() + with_model())  # a name twice: Drake's message
    assert outside([ModelDirective(add_directives=AddDirectives(file="x.dmd.yaml"))])
    assert outside(with_group(member_groups=["other"]))
    assert outside(with_group(model_namespace="iiwa"))
    assert outside(with_group(members=["plank"]))  # unscoped: Drake's lookup rules
    assert outside(with_group(members=["foam_plank::plank::"]))  # Drake refuses these
    assert outside(with_group(name="a::b", ignored_collision_filter_groups=["a::b"]))
    assert outside(with_group(ignored_collision_filter_groups=["iiwa::some_group"]))
    plant = MultibodyPlant(0.0)
    process_directives(plant, with_model())
    assert bundled_model_texts(plant, with_model()) is None  # already in the plant


def test_a_slider_axis_its_joint_does_not_move_along_is_refused_at_load():
    """The slider's prismatic joint moves its body along x: task.axis 1 or 2 loaded, then
    failed after the diagram was built, in a traceback (a singular task-space mass)."""
    from hlcmp_drake.config.models import translation_axes
    from hlcmp_drake.config.validation import scenario_plant
    from hlcmp_drake.io.errors import InputError

    scenario, _ = load_scenario("one_dof")

    def fail(key, problem):
        raise AssertionError((key, problem))

    assert translation_axes(scenario_plant(scenario, fail), scenario.task.body) == [0]
    with pytest.raises(
        InputError, match=r"axis: the joints move 'body' along x \(0\), not along z \(2\)$"
    ):
        load_scenario("one_dof", ["task.axis=2"])
