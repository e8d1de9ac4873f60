"""End to end: `hlcmp run one_dof` (the full 20 s scenario, about 25 s of wall time)."""

import json
import re
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import REPO_ROOT

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import one_dof
from hlcmp_drake.present.report import results_markdown

CONTROLLERS = ["hlcmp", "hlcmp_per_step", "vic_fd_0.5", "vic_fd_1.5", "vic_fd_5.0"]


@pytest.fixture
def run_dir(one_dof_run):
    return one_dof_run


@pytest.mark.slow  # reads the whole `hlcmp run one_dof` (one_dof_run)
def test_outputs_follow_the_contract(run_dir):
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["scenario"] == "one_dof" and metrics["status"] == "ok"
    assert list(metrics["controllers"]) == CONTROLLERS
    for values in metrics["controllers"].values():
        assert set(values) == {
            "position_at_10s_m",
            "final_position_m",
            "reach_time_s",
            "return_time_s",
            "task",
        }
        assert values["task"] == {  # every run lasts through its return
            "done": True,
            "evidence": "ran 20.00 s, through the return from 10 to 20 s",
        }
    c5 = metrics["claims"]["hlcmp"]["C5"]
    assert isinstance(c5["holds"], bool) and "x(10 s)" in c5["evidence"]
    data = np.load(run_dir / "timeseries.npz")
    T = len(data["t"])
    assert data["t"][-1] == pytest.approx(20.0)
    for name in CONTROLLERS:
        for key in ("x", "xd", "f_ext", "fc"):
            assert data[f"{name}/{key}"].shape == (T, 1)
    for key in ("Ks", "Kd", "v"):
        assert data[f"hlcmp/{key}"].shape == (T, 1)
    assert (run_dir / "figures" / "one_dof.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow  # reads the whole `hlcmp run one_dof` (one_dof_run)
def test_metrics_agree_with_the_time_series(run_dir):
    metrics = json.loads((run_dir / "metrics.json").read_text())
    data = np.load(run_dir / "timeseries.npz")
    scenario, _ = load_scenario("one_dof")
    for name in CONTROLLERS:
        run = SimpleNamespace(t=data["t"], series={"x": data[f"{name}/x"]})
        assert (
            one_dof.EXPERIMENT.metrics_of(run, scenario.controllers[name], scenario)
            == metrics["controllers"][name]
        )
    for learner in ("hlcmp", "hlcmp_per_step"):
        assert (
            one_dof.claims(metrics["controllers"], scenario, None, learner)
            == metrics["claims"][learner]
        )


@pytest.mark.slow  # reads the whole `hlcmp run one_dof` (one_dof_run)
def test_physics_of_the_runs(run_dir):
    data = np.load(run_dir / "timeseries.npz")
    t = data["t"]
    before_return = (t > 8.0) & (t < 10.0)
    # The environment pushes back only inside the object, with 10 N/m.
    x, f = data["hlcmp/x"][:, 0], data["hlcmp/f_ext"][:, 0]
    np.testing.assert_allclose(f, np.where(x < 0, -10.0 * x, 0.0), atol=1e-9)
    # The force-tracking baseline settles at its desired force, so at depth f_d / 10 N/m.
    for fd in (0.5, 1.5, 5.0):
        np.testing.assert_allclose(data[f"vic_fd_{fd}/f_ext"][before_return, 0][-1], fd, rtol=0.05)
    # The Hl-CMP learns stiffness while the error is large (theta(t0) = 0).
    assert data["hlcmp/Ks"][0, 0] == 0.0 and data["hlcmp/Ks"][:, 0].max() > 10.0
    # Q_v = 0: the feed-forward force stays at zero.
    np.testing.assert_array_equal(data["hlcmp/v"], 0.0)
    # Everyone is back home at the end.
    for name in CONTROLLERS:
        assert abs(data[f"{name}/x"][-1, 0]) < 0.005


@pytest.mark.slow  # reads the whole `hlcmp run one_dof` (one_dof_run)
def test_readme_results_come_from_this_run(run_dir):
    """The README's 1-DOF table is what scripts/update_readme.py makes of a fresh run."""
    metrics = json.loads((run_dir / "metrics.json").read_text())
    readme = (REPO_ROOT / "README.md").read_text()
    block = readme.split("<!-- BEGIN one_dof results -->\n")[1].split(
        "<!-- END one_dof results -->"
    )[0]
    assert block == results_markdown(metrics, one_dof.EXPERIMENT)


def test_a_run_shorter_than_the_return_command_has_no_x_at_10s_and_no_verdict():
    """--set duration_s=2 ends before t = 10 s: x(10 s) is not the last value held, and C5
    (which compares x(10 s) and the return) is not judged, saying why."""
    scenario, _ = load_scenario("one_dof", ["duration_s=2"])
    t = np.linspace(0.0, 2.0, 201)
    run = SimpleNamespace(t=t, series={"x": -0.1 * t[:, None] / 2.0})
    metrics = {
        name: one_dof.EXPERIMENT.metrics_of(run, config, scenario)
        for name, config in scenario.controllers.items()
    }
    assert all(m["position_at_10s_m"] is None for m in metrics.values())
    c5 = one_dof.claims(metrics, scenario)["C5"]
    assert c5["holds"] is None and "parts" not in c5
    assert c5["evidence"].startswith("hlcmp: ran 2.00 s, ended before the return command at 10 s;")
    for name in ("hlcmp", "vic_fd_0.5", "vic_fd_1.5", "vic_fd_5.0"):  # the runs C5 compares
        assert f"{name}: ran 2.00 s, ended before the return command at 10 s" in c5["evidence"]
    assert "n/a" in one_dof.table(metrics).rows[0]


@pytest.mark.parametrize("seconds", [10.0, 15.0])
def test_a_run_cut_short_of_its_return_has_no_verdict(seconds):
    """A run that stops at or after the return command, but before the return has had as
    long as the cut (10 s), would be judged "return never" for want of time: C5 is not
    judged, and each run says where it stopped."""
    scenario, _ = load_scenario("one_dof", [f"duration_s={seconds}"])
    t = np.linspace(0.0, seconds, round(seconds * 100) + 1)
    run = SimpleNamespace(t=t, series={"x": np.where(t < 10.0, -0.15, 0.0)[:, None]})
    metrics = {
        name: one_dof.EXPERIMENT.metrics_of(run, config, scenario)
        for name, config in scenario.controllers.items()
    }
    for m in metrics.values():
        assert m["position_at_10s_m"] is not None
        assert m["task"] == {
            "done": False,
            "evidence": f"ran {seconds:.2f} s, ended before the return's end at 20 s (the "
            "return gets as long as the segment before it, 10 s)",
        }
    c5 = one_dof.claims(metrics, scenario)["C5"]
    assert c5["holds"] is None and "parts" not in c5
    assert c5["evidence"].startswith(f"hlcmp: ran {seconds:.2f} s, ended before the return's end")


def _ramp_metrics(scenario):
    """Down to -0.15 m in 1 s and held there for 16 s: long enough for a return at 8 s."""
    t = np.linspace(0.0, 16.0, 1601)
    run = SimpleNamespace(t=t, series={"x": -0.15 * np.minimum(t, 1.0)[:, None]})
    return {
        name: one_dof.EXPERIMENT.metrics_of(run, config, scenario)
        for name, config in scenario.controllers.items()
    }


def test_a_reference_of_one_step_has_no_return_and_no_verdict():
    scenario, _ = load_scenario(
        "one_dof", ["reference.times_s=[0.0]", "reference.positions_m=[[-0.15]]"]
    )
    metrics = _ramp_metrics(scenario)
    for m in metrics.values():
        assert m["reach_time_s"] == pytest.approx(1.0, abs=0.05)
        assert m["position_at_10s_m"] is None and m["return_time_s"] is None
        assert m["task"] == {
            "done": False,
            "evidence": "the reference has one step: no return command",
        }
    c5 = one_dof.claims(metrics, scenario)["C5"]
    assert c5["holds"] is None and "the reference has one step" in c5["evidence"]


def test_c5s_evidence_names_the_references_own_return_time():
    scenario, _ = load_scenario("one_dof", ["reference.times_s=[0.0, 8.0]"])
    evidence = one_dof.claims(_ramp_metrics(scenario), scenario)["C5"]["evidence"]
    assert evidence.startswith("Hl-CMP: x(8 s) = -0.1500 m (target -0.15 m), reach 0.97 s")
    assert "return never after t = 8 s." in evidence and "10 s" not in evidence


@pytest.mark.parametrize("kept", ["vic_fd_1.5", "hlcmp"])
def test_c5_without_a_learner_or_a_force_tracking_run_is_not_judged(tmp_path, kept):
    """C5 compares the Hl-CMP with [21]: a scenario with only one of them has no C5."""
    text = (REPO_ROOT / "diagrams" / "one_dof.yaml").read_text()
    head, _, controllers = text.partition("controllers:\n")
    blocks = re.split(r"\n(?=  \S)", controllers.rstrip("\n"))
    one = next(block for block in blocks if block.startswith(f"  {kept}:"))
    path = tmp_path / "one_dof.yaml"
    path.write_text(f"{head}controllers:\n{one}\n")
    scenario, _ = load_scenario(path)
    assert list(scenario.controllers) == [kept]
    assert one_dof.claims(_ramp_metrics(scenario), scenario) == {}


def _fake_runs(scenario, scale=None):
    """Every controller's run as 3 s of made-up series; a learner's K_s and K_d peak at
    `scale[name]` (default 30)."""
    t = np.linspace(0.0, 3.0, 301)
    bump = (t * np.exp(-t))[:, None]
    scale = scale or {}
    runs = {}
    for name in scenario.controllers:
        peak = scale.get(name, 30.0)
        runs[name] = SimpleNamespace(
            t=t,
            series={
                "x": -0.1 * bump,
                "xd": np.full((len(t), 1), -0.15),
                "f_ext": bump,
                "Ks": peak * bump / bump.max(),
                "Kd": -0.3 * peak * bump / bump.max(),
            },
        )
    return runs


def _lines_by_label(axis):
    return {line.get_label(): line.get_color() for line in axis.get_lines()}


def test_the_figure_shows_every_learners_profiles_with_units_and_one_colour_per_controller():
    from hlcmp_drake.worlds.controllers import learners

    scenario, _ = load_scenario("one_dof")
    runs = _fake_runs(scenario, {"hlcmp": 30.0, "hlcmp_per_step": 2000.0})
    axes = one_dof.figures(runs, scenario)["one_dof.png"].axes
    position, force, stiffness, damping = axes
    assert (
        sorted(_lines_by_label(stiffness))
        == sorted(learners(scenario))
        == [
            "hlcmp",
            "hlcmp_per_step",
        ]
    )
    assert sorted(_lines_by_label(damping)) == sorted(learners(scenario))
    assert "[N/m]" in stiffness.get_ylabel() and "[N·s/m]" in damping.get_ylabel()
    assert "[m]" in position.get_ylabel() and "[N]" in force.get_ylabel()
    colours = _lines_by_label(position)
    colours.pop("reference $x_d$")
    assert sorted(colours) == sorted(scenario.controllers)
    assert len(set(colours.values())) == len(colours)  # one colour, one controller
    for axis in (force, stiffness, damping):
        for label, colour in _lines_by_label(axis).items():
            assert colour == colours[label], (axis.get_ylabel(), label)
    # 2000 N/m beside 30 N/m: a log scale, so that the smaller profile is not a flat line
    assert stiffness.get_yscale() == "symlog" and damping.get_yscale() == "symlog"


def test_profiles_of_similar_size_stay_on_a_linear_axis_and_a_run_without_learner_says_so():
    scenario, _ = load_scenario("one_dof")
    axes = one_dof.figures(_fake_runs(scenario), scenario)["one_dof.png"].axes
    assert axes[2].get_yscale() == "linear" and axes[3].get_yscale() == "linear"
    vic = {name: run for name, run in _fake_runs(scenario).items() if name.startswith("vic")}
    axes = one_dof.figures(vic, scenario)["one_dof.png"].axes
    assert not axes[2].get_lines() and "no learning controller" in axes[2].texts[0].get_text()
