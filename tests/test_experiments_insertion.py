"""The insertion experiment: the scenario file, a contact smoke test, the full
`hlcmp run insertion` (about 35 s) and the hand-built diagram script."""

import json
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import INSERTION_DEMO, REPO_ROOT

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import (
    ArmTask,
    ConstantImpedanceConfig,
    DemonstrationConfig,
    HlcmpConfig,
)
from hlcmp_drake.experiments import insertion
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.worlds.build import diagram_factory

CONTROLLERS = ["hlcmp", "hlcmp_per_step", "const_500", "const_1000", "const_2000"]
FIGURES = [
    "fig4_profiles_z.png",
    "fig5_position_force.png",
    "fig6_position_error.png",
    "fig7_mean_force.png",
    "fig8_smoothness.png",
]


def test_scenario_file_loads_with_the_paper_values():
    scenario, _ = load_scenario("insertion")
    assert isinstance(scenario.task, ArmTask) and isinstance(
        scenario.reference, DemonstrationConfig
    )
    assert INSERTION_DEMO.samefile(scenario.reference.file)
    assert list(scenario.controllers) == CONTROLLERS
    hl = scenario.controllers["hlcmp"]
    assert isinstance(hl, HlcmpConfig)
    assert (hl.q_k, hl.q_d, hl.q_v) == ([3000.0] * 3, [90.0] * 3, [9.0] * 3)
    assert hl.theta_k0 == hl.theta_d0 == hl.theta_v0 == 0.0
    per_step = scenario.controllers["hlcmp_per_step"]  # the same Q, read per 1 ms control step
    assert (per_step.q_k, per_step.q_units, per_step.rate_scale()) == (hl.q_k, "per_step", 1000.0)
    for k in (500, 1000, 2000):
        config = scenario.controllers[f"const_{k}"]
        assert isinstance(config, ConstantImpedanceConfig) and config.stiffness_N_per_m == [k] * 3


@pytest.mark.slow
def test_tool_touches_the_foam_and_the_force_opposes_the_push():
    scenario, _ = load_scenario("insertion")
    scenario.duration_s = 4.2  # into the plank: contact starts at about 3.4 s
    run = simulate(diagram_factory(scenario)("const_1000"), scenario, "const_1000")
    assert run.status == "ok"
    f_z = run.series["f_ext"][:, 2]
    in_contact = np.abs(f_z) > 0.5
    assert in_contact.any() and not in_contact[: int(3.0 / scenario.log_period_s)].any()
    # The rod moves down (-z) into the plank, so the plank pushes it up (+z).
    assert np.all(f_z[in_contact] > 0) and f_z.max() > 3.0
    assert run.series["x"][in_contact, 2].min() < 0.33  # below the plank's top face


def test_run_writes_the_contract(insertion_run):
    metrics = json.loads((insertion_run / "metrics.json").read_text())
    assert metrics["status"] == "ok" and list(metrics["controllers"]) == CONTROLLERS
    for m in metrics["controllers"].values():
        for key in (
            "mean_abs_position_error_m",
            "mean_abs_force_N",
            "force_smoothness_N",
            "max_abs_force_N",
        ):
            assert set(m[key]) == {"x", "y", "z"}
    assert "ff_to_commanded_force_ratio_z" in metrics["controllers"]["hlcmp"]
    assert list(metrics["claims"]) == [
        "hlcmp",
        "hlcmp_per_step",
    ]  # one set of claims per reading of Q
    assert all(set(claims) == {"C1", "C2", "C3", "C4"} for claims in metrics["claims"].values())
    assert metrics["learners"] == {
        "hlcmp": {"q_units": "per_second"},
        "hlcmp_per_step": {"q_units": "per_step"},
    }
    data = np.load(insertion_run / "timeseries.npz")
    T = len(data["t"])
    for name in CONTROLLERS:
        for key in ("x", "xd", "f_ext", "fc"):
            assert data[f"{name}/{key}"].shape == (T, 3)
    for key in ("Ks", "Kd", "v"):
        assert data[f"hlcmp/{key}"].shape == (T, 3)
    for figure in FIGURES:
        assert (insertion_run / "figures" / figure).read_bytes()[:4] == b"\x89PNG"
    assert (insertion_run / "recording.html").stat().st_size > 100_000
    graph = next(insertion_run.glob("diagram.*"))
    assert all(
        name in graph.read_text() for name in ("hlcmp", "reference", "safety_monitor", "puncture")
    )


def test_run_metrics_agree_with_its_time_series(insertion_run):
    metrics = json.loads((insertion_run / "metrics.json").read_text())
    data = np.load(insertion_run / "timeseries.npz")
    scenario, _ = load_scenario("insertion")
    for name in CONTROLLERS:
        series = {
            key.split("/", 1)[1]: data[key] for key in data.files if key.startswith(f"{name}/")
        }
        run = SimpleNamespace(t=data["t"], series=series)
        assert (
            insertion.controller_metrics(run, scenario.controllers[name], scenario)
            == metrics["controllers"][name]
        )


def test_build_insertion_diagram_by_hand(tmp_path):
    result = subprocess.run(
        [
            sys.executable,
            str(REPO_ROOT / "scripts" / "build_insertion_diagram.py"),
            "--out",
            str(tmp_path),
            "--duration",
            "0.3",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert "simulated 0.30 s" in result.stdout
    assert (tmp_path / "recording.html").stat().st_size > 100_000
    graph = next(tmp_path.glob("diagram.*"))
    for system in ("DmpSource", "HlcmpController", "TaskSpaceDynamics", "TaskForceToJointTorque"):
        assert system in graph.read_text()


def test_the_tool_goes_through_the_plank_and_back_with_constant_stiffness(insertion_run):
    data = np.load(insertion_run / "timeseries.npz")
    z = data["const_2000/x"][:, 2]
    assert z.min() < 0.30 < 0.33 < z[-1]  # below the bottom face, and back above the top


def test_readme_results_come_from_this_run(insertion_run):
    from hlcmp_drake.present.report import results_markdown

    metrics = json.loads((insertion_run / "metrics.json").read_text())
    readme = (REPO_ROOT / "README.md").read_text()
    block = readme.split("<!-- BEGIN insertion results -->\n")[1].split(
        "<!-- END insertion results -->"
    )[0]
    assert block == results_markdown(metrics, insertion.EXPERIMENT)
