"""hlcmp_drake.config.world: a scenario's world as a skill records it -- the same for the
same models, placement and task however they are reached, another one when any of them
changes, and blind to what a replay may change (controllers, durations, numerics)."""

import shutil

import pytest

from hlcmp_drake.config.loading import load_scenario, load_scenario_text
from hlcmp_drake.config.world import world_definition, world_of_scenario
from hlcmp_drake.io.paths import DIAGRAMS_DIR, MODELS_DIR


def world(name="insertion", overrides=()):
    scenario, _ = load_scenario(name, list(overrides))
    return world_of_scenario(scenario)


def test_the_bundled_worlds_are_three_and_stable():
    worlds = {name: world(name) for name in ("insertion", "cutting", "one_dof")}
    assert len({w.digest for w in worlds.values()}) == 3
    assert [w.kind for w in worlds.values()] == ["ArmTask", "ArmTask", "SliderTask"]
    assert [w.scenario for w in worlds.values()] == ["insertion", "cutting", "one_dof"]
    assert world("insertion") == worlds["insertion"]  # loading again: the same digest
    assert all(len(w.digest) == 64 for w in worlds.values())


@pytest.mark.parametrize(
    "override",
    [
        "duration_s=4",
        "controllers.hlcmp.q_k=[1,2,3]",
        "dmp.n_basis=20",
        "plant_config.time_step=0.0005",
        "simulator_config.max_step_size=0.0005",
        "log_period_s=0.02",
        "reference.duration_s=6",
    ],
)
def test_what_a_replay_may_change_is_not_the_world(override):
    assert world(overrides=[override]) == world()


@pytest.mark.parametrize(
    "override",
    [
        "task.puncture.hole_friction_N_per_m=0",
        "task.tool_direction=[0,0.1,-1]",
        "task.max_contact_force_N=100",
        "task.orientation_stiffness_Nm_per_rad=50",
    ],
)
def test_a_changed_task_is_another_world(override):
    changed = world(overrides=[override])
    assert changed.kind == "ArmTask" and changed.digest != world().digest


def _insertion_text():
    return (DIAGRAMS_DIR / "insertion.yaml").read_text()


def test_moving_the_plank_is_another_world():
    text = _insertion_text()
    assert "translation: [0.6, 0.0, 0.33]" in text
    moved = text.replace("translation: [0.6, 0.0, 0.33]", "translation: [0.6, 0.0, 0.34]")
    here = DIAGRAMS_DIR / "insertion.yaml"
    assert world_of_scenario(load_scenario_text(text, here)) == world()
    assert world_of_scenario(load_scenario_text(moved, here)).digest != world().digest


def test_a_rotated_weld_is_read_and_told_apart():
    text = _insertion_text()
    line = "      translation: [0.6, 0.0, 0.33]"

    def rotated(deg):
        return text.replace(line, f"{line}\n      rotation: !Rpy {{deg: [0, 0, {deg}]}}")

    here = DIAGRAMS_DIR / "insertion.yaml"
    a, b = (world_of_scenario(load_scenario_text(rotated(d), here)) for d in (10, 20))
    assert a.digest != b.digest and world().digest not in (a.digest, b.digest)
    welds = [
        d["add_weld"]
        for d in world_definition(load_scenario_text(rotated(10), here))["directives"]
        if "add_weld" in d
    ]
    assert {"!Rpy": {"deg": [0.0, 0.0, 10.0]}} in [w.get("X_PC", {}).get("rotation") for w in welds]


def test_a_model_counts_by_its_content_not_its_path(tmp_path):
    """The plank as a file:// path: a copy elsewhere is the same world, an edit is not."""
    text = _insertion_text()
    url = "package://hlcmp_drake/models/foam_plank.sdf"
    assert url in text

    def world_with(plank):
        return world_of_scenario(
            load_scenario_text(
                text.replace(url, f"file://{plank}"), DIAGRAMS_DIR / "insertion.yaml"
            )
        )

    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        shutil.copy(MODELS_DIR / "foam_plank.sdf", tmp_path / folder / "plank.sdf")
    assert world_with(tmp_path / "a" / "plank.sdf") == world()
    assert world_with(tmp_path / "b" / "plank.sdf") == world()
    edited = tmp_path / "b" / "plank.sdf"
    modulus = "<drake:hydroelastic_modulus>2.0e5<"
    assert modulus in edited.read_text()
    edited.write_text(edited.read_text().replace(modulus, modulus.replace("2.0e5", "4.0e5")))
    assert world_with(edited).digest != world().digest


def test_the_task_counts_by_what_differs_from_its_defaults():
    scenario, _ = load_scenario("one_dof", [])
    # The slider's task as bundled is all defaults: a field added later at its default
    # would leave every digest as it is.
    assert world_definition(scenario)["task"] == {}
    stiffer = load_scenario("one_dof", ["task.environment_stiffness_N_per_m=20"])[0]
    assert world_definition(stiffer)["task"] == {"environment_stiffness_N_per_m": 20.0}


def test_the_world_records_only_the_overrides_that_change_it():
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.config.world import world_of_scenario

    overrides = [
        "task.puncture.depth_m=0.0125",
        "duration_s=3",
        "controllers.hlcmp.pi=4",
        "directives.2.add_weld.X_PC.translation=[0, 0, 0.1]",
    ]
    scenario, _ = load_scenario("insertion", overrides[:3])
    world = world_of_scenario(scenario, overrides)
    assert world.overrides == (overrides[0], overrides[3])
    assert world.digest == world_of_scenario(scenario).digest
