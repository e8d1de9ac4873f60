"""Contract tests over the registries: every controller kind in every world it applies to,
every world kind, every physics extra and every experiment -- built, stepped, logged and
checked, so that a new entry in any registry is held to what the runs need of it."""

import dataclasses as dc
import json
import subprocess
import sys

import numpy as np
import pytest

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import (
    ArmTask,
    ConstantImpedanceConfig,
    ConstantPoseImpedanceConfig,
    HlcmpConfig,
    HlcmpForgettingConfig,
    PoseHlcmpConfig,
)
from hlcmp_drake.experiments import EXPERIMENTS
from hlcmp_drake.run.runner import evaluate
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.worlds.build import WORLDS, diagram_factory, world_of
from hlcmp_drake.worlds.controllers import CONTROLLER_KINDS, kind_of
from hlcmp_drake.worlds.extras import PHYSICS_EXTRAS

# A bundled scenario per world kind, and the scenario its experiment runs in.
SCENARIO_OF_WORLD = {"slider": "one_dof", "arm": "insertion"}
COMMON_SERIES = ("x", "xd", "f_ext", "fc", "plant_state")


def _example_configs(scenario):
    """One config per controller kind in CONTROLLER_KINDS, from the scenario's own where it
    has one (the forgetting learner from its Hl-CMP, γ > 0)."""
    configs = {type(c): c for c in scenario.controllers.values()}
    hlcmp = next(c for c in scenario.controllers.values() if type(c) is HlcmpConfig)
    fields = {f.name: getattr(hlcmp, f.name) for f in dc.fields(HlcmpConfig)}
    configs[HlcmpForgettingConfig] = HlcmpForgettingConfig(**fields, forgetting_per_s=0.2)
    m = scenario.n_axes
    configs.setdefault(
        ConstantImpedanceConfig,
        ConstantImpedanceConfig([100.0] * m, [20.0] * m, gain_l=[10.0] * m),
    )
    rotational = {"q_kr": [0.3] * 3, "q_dr": [0.01] * 3, "q_vr": [0.1] * 3, "gain_l_r": [0.1] * 3}
    configs.setdefault(PoseHlcmpConfig, PoseHlcmpConfig(**fields, **rotational))
    configs.setdefault(
        ConstantPoseImpedanceConfig,
        ConstantPoseImpedanceConfig(
            [100.0] * m,
            [20.0] * m,
            gain_l=[10.0] * m,
            rotational_stiffness_Nm_per_rad=[10.0] * 3,
            rotational_damping_Nms_per_rad=[1.0] * 3,
            gain_l_r=[0.1] * 3,
        ),
    )
    return configs


def _applies(kind, scenario):
    """An arm world evaluates a law in its one-call loop or the modular LawController; a
    kind without a law (the variable impedance) is a slider comparison; a 6-D kind needs
    an arm (its tool's orientation)."""
    if kind.pose:
        return isinstance(scenario.task, ArmTask)
    return kind.law is not None or not isinstance(scenario.task, ArmTask)


def test_every_world_kind_has_a_bundled_scenario():
    assert {world.name for world in WORLDS.values()} == set(SCENARIO_OF_WORLD)


def test_every_experiment_names_a_registered_world():
    for experiment in EXPERIMENTS.values():
        assert experiment.world in WORLDS


CASES = [
    (world, kind_type) for world in sorted(SCENARIO_OF_WORLD) for kind_type in CONTROLLER_KINDS
]


@pytest.mark.parametrize(
    "world_name, kind_type", CASES, ids=[f"{w}-{k.__name__}" for w, k in CASES]
)
def test_every_controller_kind_builds_steps_and_logs_in_every_world(world_name, kind_type):
    scenario, _ = load_scenario(SCENARIO_OF_WORLD[world_name], ["duration_s=0.05"])
    config = _example_configs(scenario).get(kind_type)
    kind = CONTROLLER_KINDS[kind_type]
    if config is None or not _applies(kind, scenario):
        pytest.skip(f"{kind_type.__name__} does not apply to the {world_name} world")
    assert kind.learns == (kind.role == "learner")
    scenario.controllers = {"probe_me": config}
    assert world_of(scenario).name == world_name
    built = diagram_factory(scenario)("probe_me")
    run = simulate(built, scenario, "probe_me")
    assert run.status == "ok", run.reason
    for series in (*COMMON_SERIES, *kind.logs.values()):
        assert series in run.series and np.all(np.isfinite(run.series[series])), series
    assert len(run.t) >= 5
    if kind.learns:
        n = scenario.dmp.n_basis
        shapes = [(scenario.n_axes, n)] * 3 + ([(3, n)] * 3 if kind.pose else [])
        assert [t.shape for t in run.theta] == shapes
        frozen = kind.frozen(config)
        assert kind_of(frozen) is kind and frozen.q_k == [0.0] * scenario.n_axes
    else:
        assert built.controller.read_theta is None and run.theta is None


@pytest.mark.parametrize("name", sorted(EXPERIMENTS))
def test_every_experiment_evaluates_short_runs_of_its_bundled_scenario(name):
    scenario, _ = load_scenario(
        next(s for s in ("one_dof", "insertion", "cutting", "peg_in_hole") if s == name),
        ["duration_s=0.05"],
    )
    experiment = EXPERIMENTS[name]
    build = diagram_factory(scenario)
    runs = {n: simulate(build(n), scenario, n) for n in scenario.controllers}
    metrics = evaluate(runs, scenario, experiment)
    assert metrics["status"] == "ok" and set(metrics["controllers"]) == set(scenario.controllers)
    json.dumps(metrics)  # metrics.json must be able to hold it
    assert experiment.table(metrics["controllers"]).rows


def test_every_physics_extra_is_added_by_the_arm_world():
    scenario, _ = load_scenario("insertion", ["duration_s=0.02"])
    configured = scenario.task.physics_extras()
    assert configured and all(type(c) in PHYSICS_EXTRAS for c in configured)
    built = diagram_factory(scenario)("const_500")
    assert built.after_step is not None  # the tear runs after every step
    without, _ = load_scenario("insertion", ["task.puncture.object_frame=''"])
    assert without.task.physics_extras() == []


def test_task_axes_subsets_of_an_arm_are_refused_in_one_line():
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "hlcmp_drake.cli",
            "run",
            "insertion",
            "--set",
            "task.axes=[0,2]",
            "--out",
            "/nonexistent-out-never-written",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "task.axes" in lines[0] and "[0, 1, 2]" in lines[0], lines
