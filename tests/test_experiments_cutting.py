"""The cutting experiment: its demonstration (the g ~ p0 case), the full run, its claims."""

import json
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import REPO_ROOT

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import ArmTask, HlcmpConfig
from hlcmp_drake.experiments import cutting
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.present.report import results_markdown
from hlcmp_drake.worlds.arm import fit_demonstration

CONTROLLERS = ["hlcmp", "hlcmp_per_step", "const_500", "const_1000"]


def test_scenario_has_the_paper_values():
    scenario, _ = load_scenario("cutting")
    assert isinstance(scenario.task, ArmTask) and scenario.experiment == "cutting"
    assert list(scenario.controllers) == CONTROLLERS
    hl = scenario.controllers["hlcmp"]
    assert isinstance(hl, HlcmpConfig)
    assert (hl.q_k, hl.q_d, hl.q_v) == ([4000.0] * 3, [50.0] * 3, [9.0] * 3)


def test_the_dmp_brings_z_back_to_the_start_height():
    """The cutting demonstration ends at the height it started from (g ~ p0 in z)."""
    scenario, _ = load_scenario("cutting")
    dmp = fit_demonstration(scenario)
    assert list(dmp.goal_scaled) == [True, True, False]
    t, p, *_ = dmp.rollout(duration=dmp.tau + 1.0)
    assert p[:, 2].min() < dmp.start[2] - 0.08  # it goes down into the block ...
    assert abs(p[-1, 2] - dmp.start[2]) < 1e-3  # ... and comes back up
    np.testing.assert_allclose(p[-1], dmp.goal, atol=1e-3)


@pytest.mark.slow  # reads the whole `hlcmp run cutting` (cutting_run)
def test_run_writes_the_contract_and_its_metrics_agree(cutting_run):
    metrics = json.loads((cutting_run / "metrics.json").read_text())
    assert metrics["status"] == "ok" and list(metrics["controllers"]) == CONTROLLERS
    assert list(metrics["claims"]) == [
        "hlcmp",
        "hlcmp_per_step",
    ]  # one set of claims per reading of Q
    assert all(set(claims) == {"C2", "C3"} for claims in metrics["claims"].values())
    data = np.load(cutting_run / "timeseries.npz")
    scenario, _ = load_scenario("cutting")
    for name in CONTROLLERS:
        series = {
            key.split("/", 1)[1]: data[key] for key in data.files if key.startswith(f"{name}/")
        }
        assert series["f_ext"].shape == (len(data["t"]), 3)
        assert (
            cutting.EXPERIMENT.metrics_of(
                SimpleNamespace(t=data["t"], series=series), scenario.controllers[name], scenario
            )
            == metrics["controllers"][name]
        )
    for figure in ("fig11_profiles_xyz.png", "fig12_force_z_smoothness.png"):
        assert (cutting_run / "figures" / figure).read_bytes()[:4] == b"\x89PNG"
    assert (cutting_run / "recording.html").stat().st_size > 100_000


@pytest.mark.slow  # reads the whole `hlcmp run cutting` (cutting_run)
def test_the_blade_cuts_through_the_block(cutting_run):
    data = np.load(cutting_run / "timeseries.npz")
    t = data["t"]
    cutting_phase = (t > 2.5) & (t < 5.5)
    for name in ("const_500", "const_1000"):
        z, f = data[f"{name}/x"][:, 2], data[f"{name}/f_ext"]
        assert np.all(z[cutting_phase] < 0.27)  # the edge is inside the block
        assert np.all(f[cutting_phase, 1] < 0)  # the block resists the cut along +y
        assert np.all(f[cutting_phase, 2] > 0)  # and pushes the blade up


@pytest.mark.slow  # reads the whole `hlcmp run cutting` (cutting_run)
def test_readme_results_come_from_this_run(cutting_run):
    metrics = json.loads((cutting_run / "metrics.json").read_text())
    readme = (REPO_ROOT / "README.md").read_text()
    block = readme.split("<!-- BEGIN cutting results -->\n")[1].split(
        "<!-- END cutting results -->"
    )[0]
    assert block == results_markdown(metrics, cutting.EXPERIMENT)


def _cut(depth_short_m, covered):
    """A blade cutting along y at the reference's depth (short of it by `depth_short_m`)
    over the first `covered` fraction of an 18 cm stroke."""
    t = np.linspace(0.0, 10.0, 1001)
    y = np.interp(t, [0, 2, 8, 10], [-0.10, -0.10, 0.08, 0.08])
    zd = np.interp(t, [0, 2, 8, 10], [0.275, 0.255, 0.255, 0.275])
    xd = np.column_stack([np.full_like(t, 0.6), y, zd])
    end = -0.10 + covered * 0.18
    z = np.where(y <= end, zd + depth_short_m, 0.275)
    x = np.column_stack([np.full_like(t, 0.6), y, z])
    return RunResult("blade", t, {"x": x, "xd": xd})


def test_the_cut_is_done_at_depth_along_its_length():
    assert cutting.cut_done(_cut(0.002, 1.0), None)["done"]
    short = cutting.cut_done(_cut(0.006, 1.0), None)  # 6 mm above: not at depth
    assert not short["done"] and short["stroke_covered"] == 0.0
    assert short["evidence"].endswith("its deepest point stayed 6.0 mm above the reference's")
    half = cutting.cut_done(_cut(0.0, 0.5), None)  # at depth over half the stroke
    assert not half["done"] and half["stroke_covered"] == pytest.approx(0.5, abs=0.01)
    assert half["evidence"].endswith("of the 18 cm stroke, short of the 90 % the task needs")


@pytest.mark.parametrize("seconds", [1.0, 4.0, 8.0])  # descending; along the stroke; at its end
def test_a_run_that_ends_before_the_references_cut_did_not_do_the_task(seconds):
    """The stroke is read off the logged reference: cut short, the run would see a short
    stroke that it covers whole."""
    whole = _cut(0.0, 1.0)
    kept = whole.t <= seconds
    run = RunResult("blade", whole.t[kept], {k: v[kept] for k, v in whole.series.items()})
    verdict = cutting.cut_done(run, None)
    assert not verdict["done"] and verdict["stroke_covered"] is None
    assert verdict["evidence"].startswith(f"the run ended at t = {seconds:.2f} s, before the ")
