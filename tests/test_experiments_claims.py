"""hlcmp_drake.experiments.claims: controllers are found by their config kind, never by their
YAML label: a new label added through YAML alone takes part in the claims, and renamed
labels give the same verdicts."""

import json

import numpy as np
import pytest

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import ConstantImpedanceConfig
from hlcmp_drake.experiments import insertion, one_dof
from hlcmp_drake.io.paths import DIAGRAMS_DIR
from hlcmp_drake.io.runs import RunResult

STIFF = (
    "controllers.stiff=!ConstantImpedanceConfig {stiffness_N_per_m: [4000, 4000, 4000], "
    "damping_Ns_per_m: [250, 250, 250], gain_l: [10, 10, 10]}"
)


def _errors(**by_label):
    """Per-controller metrics with only the position error (C1's measure), in mm per axis."""
    return {
        name: {"mean_abs_position_error_m": {a: e / 1000 for a in "xyz"}}
        for name, e in by_label.items()
    }


@pytest.mark.parametrize("stiff_error_mm, holds", [(0.5, True), (3.0, False)])
def test_a_constant_impedance_added_through_yaml_joins_c1(stiff_error_mm, holds):
    scenario, _ = load_scenario("insertion", [STIFF])
    assert isinstance(scenario.controllers["stiff"], ConstantImpedanceConfig)
    metrics = _errors(const_500=4.0, const_1000=2.0, const_2000=1.0, stiff=stiff_error_mm)
    c1 = insertion.claims(metrics, scenario)["C1"]
    # Ordered by the configured stiffness, the new one (4000 N/m) last.
    assert c1["evidence"].index("const_2000") < c1["evidence"].index("stiff ")
    assert c1["holds"] is holds


def _renamed_scenario(tmp_path, name, renames):
    text = (
        (DIAGRAMS_DIR / f"{name}.yaml")
        .read_text()
        .replace("file: demos/", f"file: {DIAGRAMS_DIR}/demos/")
    )
    for old, new in renames.items():
        assert f"  {old}: !" in text
        text = text.replace(f"  {old}: !", f"  {new}: !")
    path = tmp_path / f"renamed_{name}.yaml"
    path.write_text(text)
    return load_scenario(path)[0]


def _runs_from(run_dir, renames):
    data = np.load(run_dir / "timeseries.npz")
    runs = {}
    for old, new in renames.items():
        series = {
            key.split("/", 1)[1]: data[key] for key in data.files if key.startswith(f"{old}/")
        }
        runs[new] = RunResult(new, data["t"], series)
    return runs


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, experiment, renames",
    [
        (
            "insertion",
            insertion,
            {
                "hlcmp": "learner",
                "hlcmp_per_step": "stepwise",
                "const_500": "soft",
                "const_1000": "medium",
                "const_2000": "hard",
            },
        ),
        (
            "one_dof",
            one_dof,
            {
                "hlcmp": "learner",
                "hlcmp_per_step": "stepwise",
                "vic_fd_0.5": "weak",
                "vic_fd_1.5": "right",
                "vic_fd_5.0": "strong",
            },
        ),
    ],
)
def test_renamed_labels_give_the_same_verdicts(request, tmp_path, name, experiment, renames):
    run_dir = request.getfixturevalue(f"{name}_run")
    original = json.loads((run_dir / "metrics.json").read_text())
    scenario = _renamed_scenario(tmp_path, name, renames)
    runs = _runs_from(run_dir, renames)
    metrics = {
        new: experiment.EXPERIMENT.metrics_of(runs[new], scenario.controllers[new], scenario)
        for new in runs
    }
    for old, new in renames.items():
        assert metrics[new] == original["controllers"][old]
    for old, new in (("hlcmp", "learner"), ("hlcmp_per_step", "stepwise")):
        claims = experiment.claims(metrics, scenario, runs, new)
        assert {c: v["holds"] for c, v in claims.items()} == {
            c: v["holds"] for c, v in original["claims"][old].items()
        }


def test_a_claim_about_a_run_that_did_not_do_the_task_is_not_judged():
    from hlcmp_drake.experiments.claims import (
        NOT_JUDGED,
        Claim,
        Verdict,
        judge_claims,
        verdict_text,
    )

    scenario, _ = load_scenario("insertion")
    claim = Claim("CX", "a sentence", lambda given: Verdict(True, "measured"))
    done = {"done": True, "evidence": "tore the plank at 3.70 s"}
    undone = {"done": False, "evidence": "did not go through the plank"}
    metrics = {name: {"task": done} for name in scenario.controllers}
    assert judge_claims([claim], metrics, scenario)["CX"]["holds"] is True
    metrics["hlcmp"] = {"task": undone}
    entry = judge_claims([claim], metrics, scenario)["CX"]
    assert entry["holds"] is None
    assert entry["evidence"] == "hlcmp: did not go through the plank"
    assert verdict_text(None) == NOT_JUDGED and verdict_text(False) == "no"
    # a claim that does not speak of the learner is judged all the same
    about_constants = Claim(
        "CY", "another", lambda given: Verdict(False, "m"), about=lambda g: ["const_500"]
    )
    assert judge_claims([about_constants], metrics, scenario)["CY"]["holds"] is False
