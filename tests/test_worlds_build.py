"""hlcmp_drake.worlds.build: every world's two control paths (fast: one ControlLoop call per
plant step, the reference and the law's state in C++; modular: the systems port by port)
give the same runs and the same verdicts; the slider's fast path makes few Python calls."""

import importlib.util
import json

import numpy as np
import pytest
from conftest import REPO_ROOT

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.paths import DIAGRAMS_DIR, MODELS_DIR
from hlcmp_drake.run.benchmark import count_python_calls
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.systems.control_loop import ControlLoop
from hlcmp_drake.worlds.build import diagram_factory


def _compare_paths_script():
    path = REPO_ROOT / "scripts" / "compare_paths.py"
    spec = importlib.util.spec_from_file_location("compare_paths", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _q_per_step(config):
    return getattr(config, "q_units", "per_second") == "per_step"


def assert_paths_agree(scenario, first, second):
    """The metrics of two runs of `scenario`'s controllers agree: values within 1 % of
    their size (both zero to rounding: 1e-9), a time read off the logs (a `*_time_s`)
    within one log period, its resolution. An Hl-CMP with Q per control step is left out:
    its two θ schemes differ by a step (docs/performance.md)."""
    compare = _compare_paths_script()
    for controller, metrics in first.items():
        if _q_per_step(scenario.controllers[controller]):
            continue
        a, b = compare.numbers(metrics), compare.numbers(second[controller])
        assert a.keys() == b.keys(), controller
        for key in a:
            size = max(abs(a[key]), abs(b[key]))
            if key.endswith("_time_s"):
                allowed = scenario.log_period_s * (1 + 1e-9) + 0.01 * size
            else:
                allowed = 0.01 * size if size > 1e-9 else 1e-9
            assert abs(a[key] - b[key]) <= allowed, (controller, key, a[key], b[key])


@pytest.mark.slow  # five controllers for 3 s on each path, the modular one slowly (about 4.7 s)
def test_the_slider_runs_the_same_on_both_paths():
    """3 s of every 1-DOF controller (pressing into the object), fast and modular."""
    sets = ["duration_s=3.0"]
    runs = {}
    for path in ("fast", "modular"):
        scenario, _ = load_scenario("one_dof", [*sets, f"task.control_path={path}"])
        factory, experiment = diagram_factory(scenario), experiment_of(scenario)
        runs[path] = {}
        for name, config in scenario.controllers.items():
            run = simulate(factory(name), scenario, name)
            runs[path][name] = json.loads(json.dumps(experiment.metrics_of(run, config, scenario)))
            if path == "fast":
                assert isinstance(factory(name).controller.system, ControlLoop)
    assert_paths_agree(scenario, runs["fast"], runs["modular"])


def test_the_slider_fast_path_makes_about_two_python_calls_per_step():
    """Counted, not timed: the loop's tick and the spring each step, the 100 Hz loggers and
    safety monitor; the modular path makes several times more."""
    counts = {}
    for path in ("fast", "modular"):
        scenario, _ = load_scenario("one_dof", ["duration_s=0.3", f"task.control_path={path}"])
        counts[path] = count_python_calls(diagram_factory(scenario)("hlcmp"), scenario)
    assert 1.0 <= counts["fast"] <= 2.5
    assert counts["modular"] > 3 * counts["fast"]


@pytest.mark.slow  # each bundled scenario once more, on the modular path (about 3.5 min)
@pytest.mark.parametrize("name", ["one_dof", "insertion", "cutting"])
def test_the_modular_path_gives_the_bundled_runs_verdicts(name, request, tmp_path):
    """Every claim's verdict is the same on both paths, and the metrics agree
    (`assert_paths_agree`)."""
    from hlcmp_drake.cli import main

    fast = request.getfixturevalue(f"{name}_run")
    assert (
        main(["run", name, "--quiet", "--set", "task.control_path=modular", "--out", str(tmp_path)])
        == 0
    )
    compare = _compare_paths_script()
    first, second = (
        json.loads((folder / "metrics.json").read_text()) for folder in (tmp_path, fast)
    )
    assert compare.verdicts(first["claims"]) == compare.verdicts(second["claims"])
    assert len(compare.verdicts(first["claims"])) >= {"one_dof": 2}.get(name, 4)  # C5 twice
    assert_paths_agree(load_scenario(name)[0], first["controllers"], second["controllers"])


def test_the_prismatic_model_gives_the_general_models_terms():
    from pydrake.systems.framework import DiagramBuilder

    from hlcmp_drake.systems.task_space import PrismaticTaskModel, TaskSpaceModel
    from hlcmp_drake.worlds.models import add_plant

    scenario, _ = load_scenario("one_dof")
    plant, _ = add_plant(DiagramBuilder(), scenario)
    frame = plant.GetBodyByName("body").body_frame()
    general, prismatic = (
        TaskSpaceModel(plant, frame, axes=[0]),
        PrismaticTaskModel(plant, frame, axes=[0]),
    )
    for state in np.random.default_rng(3).normal(size=(5, 2)):
        a, b = general.terms(state), prismatic.terms(state)
        for field in ("position", "velocity", "jacobian", "inertia", "coriolis", "gravity"):
            np.testing.assert_allclose(
                getattr(b, field), getattr(a, field), rtol=1e-12, atol=1e-12, err_msg=field
            )
        assert not b.null_space.any() and b.joint_gravity.shape == (1,)


@pytest.mark.parametrize("path", ["fast", "modular"])
def test_a_slider_held_at_its_effort_limit_stops_after_max_saturation_s(path, tmp_path):
    """The slider's actuator limited to 0.5 N, far below the 7.5 N the Hl-CMP commands at
    the start: its force is saturated from t = 0 on, and the run stops with the reason at
    the first 100 Hz check past task.max_saturation_s, on either control path."""
    model = (MODELS_DIR / "one_dof_slider.sdf").read_text()
    assert "<effort>1000</effort>" in model
    weak = tmp_path / "weak_slider.sdf"
    weak.write_text(model.replace("<effort>1000</effort>", "<effort>0.5</effort>"))
    yaml = (DIAGRAMS_DIR / "one_dof.yaml").read_text()
    package_url = "package://hlcmp_drake/models/one_dof_slider.sdf"
    assert package_url in yaml
    scenario_file = tmp_path / "weak_one_dof.yaml"
    scenario_file.write_text(yaml.replace(package_url, weak.as_uri()))
    sets = ["duration_s=1.0", "task.max_saturation_s=0.1", f"task.control_path={path}"]
    scenario, _ = load_scenario(scenario_file, sets)
    run = simulate(diagram_factory(scenario)("hlcmp"), scenario, "hlcmp")
    assert run.status == "unstable"
    assert run.reason == "joint forces saturated for more than max_saturation_s = 0.1 s"
    assert run.stop_time == pytest.approx(0.11, abs=1e-9)
    saturated = run.series["saturated_joints"][:, 0]
    assert (saturated[run.t < run.stop_time] == 1).all()


def test_a_label_the_scenario_does_not_have_is_named_with_the_labels_it_has():
    scenario, _ = load_scenario("one_dof", ["duration_s=0.2"])
    with pytest.raises(InputError) as error:
        diagram_factory(scenario)("hlcmpp")
    assert str(error.value) == (
        "no controller 'hlcmpp' (the scenario has: " + ", ".join(scenario.controllers) + ")"
    )


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda s: setattr(s.controllers["hlcmp"], "gain_l", [-10.0, -10.0, -10.0]),
            "controllers.hlcmp.gain_l: controller 'hlcmp': every value must be non-negative",
        ),
        (  # built, Drake's Integrator asserted its size and ended the process
            lambda s: setattr(s.controllers["hlcmp"], "q_k", [300.0, 300.0]),
            "controllers.hlcmp.q_k: controller 'hlcmp' needs 3 value(s), one per axis, got 2",
        ),
        (lambda s: setattr(s, "duration_s", -1.0), "duration_s: must be finite and > 0"),
    ],
)
def test_a_scenario_changed_in_python_is_checked_as_a_loaded_one(change, message):
    scenario, _ = load_scenario("insertion", ["duration_s=2"])
    change(scenario)
    with pytest.raises(InputError) as error:
        diagram_factory(scenario)
    assert str(error.value).startswith(f"scenario 'insertion': {message}")
