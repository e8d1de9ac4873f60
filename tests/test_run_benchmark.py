"""The benchmark in its quick smoke mode: every measurement is produced (no thresholds --
speed is reported by `hlcmp bench`, never asserted in a test)."""

import json

import pytest

from hlcmp_drake.cli import main
from hlcmp_drake.experiments import EXPERIMENTS


@pytest.mark.slow
def test_quick_benchmark_writes_every_measurement(tmp_path, capsys):
    assert main(["bench", "--out", str(tmp_path), "--quick"]) == 0
    results = json.loads((tmp_path / "bench.json").read_text())
    for key in (
        "insertion_rtf",
        "controller_overhead_ratio",
        "controller_overhead_ratio_bare",
        "modular_over_fast",
        "python_calls_per_step",
        "python_calls_per_step_modular",
        "dmp_fit_ms",
        "dmp_rollout_ms",
        "one_dof_rtf",
        "one_dof_modular_over_fast",
    ):
        assert results[key] > 0
    by_controller = results["one_dof_rtf_by_controller"]
    assert set(by_controller) == {
        "hlcmp",
        "hlcmp_per_step",
        "vic_fd_0.5",
        "vic_fd_1.5",
        "vic_fd_5.0",
    }
    assert results["one_dof_rtf"] == min(by_controller.values())
    assert results["controller_tick_us"]["p99"] >= results["controller_tick_us"]["p50"] > 0
    assert results["pose_over_translational_tick"] > 0
    assert results["pose_tick_us"]["p99"] >= results["pose_tick_us"]["p50"] > 0
    walls = results["insertion_wall_s"]
    assert set(walls) == {"fast", "cpp", "fast_bare", "cpp_bare", "modular"} and all(
        len(w) == 1 for w in walls.values()
    )
    assert "dmp_vs_movement_primitives" in results
    assert results["pose_dmp_fit_rollout_ms"] > 0
    if results["pose_dmp_vs_cartesian_dmp"] is not None:  # movement_primitives is installed
        assert set(results["cartesian_dmp_rms_deg"]) == {"150", "270"}
    assert set(results["orientation_dmp_rms_deg"]) == {"150", "270"}
    assert set(results["scenario_wall_s"]) == set(EXPERIMENTS)  # every bundled experiment
    assert set(results["world_alone_rtf"]) == {"insertion", "cutting"}
    assert all(rtf > 0 for rtf in results["world_alone_rtf"].values())
    assert "report" not in results  # a smoke run does not time the whole report
    for when in ("at_start", "at_end"):  # the machine's load and speed, beside the code's
        state = results["machine"][when]
        assert len(state["load_average"]) == 3 and state["dmp_rollout_ms"] > 0
    out = capsys.readouterr().out
    assert "controller_overhead_ratio" in out and "quick smoke run" in out
    assert "the machine during the run" in out
    assert "pose_dmp_vs_cartesian_dmp" in out and "pose_over_translational_tick" in out
    assert "met" not in out.split() and "missed" not in out


def _results(mode):
    """bench.json content with made-up values (a full run misses all eight targets)."""
    quick = mode == "quick"
    results = {
        "machine": {"python": "3", "processor": "", "mode": mode},
        "insertion_rtf": 1.0,
        "controller_overhead_ratio": 9.0,
        "controller_overhead_ratio_bare": 9.0,
        "modular_over_fast": 2.0,
        "python_calls_per_step": 9.0,
        "python_calls_per_step_modular": 30.0,
        "controller_tick_us": {"p50": 300.0, "p99": 900.0},
        "dmp_fit_ms": 1.0,
        "dmp_rollout_ms": 1.0,
        "dmp_vs_movement_primitives": 2.0,
        "insertion_simulated_s": 1.0 if quick else 9.5,
        "scenario_wall_s": {"one_dof": 1.0},
        "one_dof_rtf": 5.0,
        "one_dof_rtf_by_controller": {"hlcmp": 5.0, "vic": 6.0},
        "one_dof_modular_over_fast": 3.0,
        "one_dof_simulated_s": 0.5 if quick else 20.0,
        "world_alone_rtf": {"insertion": 3.0, "cutting": 5.0},
        "world_alone_simulated_s": {"insertion": 1.0 if quick else 9.5, "cutting": 1.0},
    }
    if quick:
        results["scenario_simulated_s"] = 0.5
    else:
        results["report"] = {"wall_s": 120.0, "jobs": 2}
    return results


def test_a_quick_run_is_labelled_a_smoke_run_and_judges_no_target():
    from hlcmp_drake.present.tables import to_text
    from hlcmp_drake.run.benchmark import table

    text = to_text(table(_results("quick")))
    assert "quick smoke run" in text.splitlines()[0]
    assert "met" not in text.split() and "missed" not in text and "≥" not in text
    assert "(1 s, harnessed" in text and "9.5 s" not in text
    assert "`hlcmp run one_dof` cut to 0.5 s" in text
    assert "world_alone_rtf[cutting]" in text and "hlcmp report" not in text
    full = to_text(table(_results("full")))
    assert "smoke" not in full and full.count("**missed**") == 8 and "(9.5 s, harnessed" in full
    assert "world_alone_rtf[insertion]" in full and "`hlcmp report`" in full


def test_the_machines_load_and_speed_at_both_ends_head_the_table():
    from hlcmp_drake.present.tables import to_text
    from hlcmp_drake.run.benchmark import table

    results = _results("full")
    assert "the machine" not in to_text(table(results))  # a bench.json from before: no row
    results["machine"].update(
        tick_kernel="compiled",
        cpus=2,
        at_start={"load_average": [0.41, 0.5, 0.6], "dmp_rollout_ms": 11.64},
        at_end={"load_average": [1.02, 0.9, 0.7], "dmp_rollout_ms": 12.31},
    )
    lines = to_text(table(results)).splitlines()
    row = next(k for k, line in enumerate(lines) if "the machine during the run" in line)
    assert "tick_kernel" in lines[row + 1]  # the first row: what every figure below ran on
    assert "on 2 CPUs" in lines[row] and "0.41 / 1.02; 11.6 / 12.3 ms" in lines[row]


def test_the_pose_dmp_rows_show_both_sides_or_say_n_a():
    from hlcmp_drake.present.tables import to_text
    from hlcmp_drake.run.benchmark import table

    results = _results("full")
    results.update(
        orientation_dmp_rms_deg={"150": 0.0012, "270": 0.0014},
        cartesian_dmp_rms_deg={"150": 0.052, "270": 0.085},
        pose_dmp_fit_rollout_ms=40.0,
        cartesian_dmp_fit_rollout_ms=320.0,
        pose_dmp_vs_cartesian_dmp=0.25,
    )
    text = to_text(table(results))
    assert "0.0012 / 0.0014°" in text and "0.0520 / 0.0850°" in text
    (ratio,) = [line for line in text.splitlines() if "pose_dmp_vs_cartesian_dmp" in line]
    assert "(40 ms / 320 ms)" in ratio and ratio.split()[-1] == "0.25"
    results.update(
        cartesian_dmp_rms_deg=None,
        cartesian_dmp_fit_rollout_ms=None,
        pose_dmp_vs_cartesian_dmp=None,
    )
    text = to_text(table(results))
    assert "(40 ms / n/a)" in text and text.count("n/a") >= 3


@pytest.mark.slow  # a whole report, timed (about 2.0 s)
def test_the_report_is_timed_in_a_folder_of_its_own(tmp_path):
    from hlcmp_drake.io.paths import DIAGRAMS_DIR
    from hlcmp_drake.run.benchmark import report_wall_s

    own = tmp_path / "short.yaml"  # the bundled 1-DOF scenario, renamed and cut short
    text = (DIAGRAMS_DIR / "one_dof.yaml").read_text().replace("name: one_dof", "name: short", 1)
    own.write_text(text.replace("duration_s: 20.0", "duration_s: 0.3", 1))
    timed = report_wall_s([str(own)])
    assert timed["wall_s"] > 0 and timed["jobs"] >= 1
    assert list(tmp_path.iterdir()) == [own]  # the report's files went elsewhere and are gone


def test_the_6d_tick_is_timed_beside_the_translational_one_on_each_path():
    from hlcmp_drake.core.kernels import kernel_path, numba_available
    from hlcmp_drake.run.benchmark import pose_tick_cost

    timed = pose_tick_cost(duration=0.02, repetitions=2)
    assert timed["pose_tick_states"] == 6  # logged every 4 ms
    paths = {"numpy", "compiled"} if numba_available() else {"numpy"}
    for side in ("pose", "translational"):
        by_path = timed[f"{side}_tick_us_by_path"]
        assert set(by_path) == paths
        assert all(tick["p99"] >= tick["p50"] > 0 for tick in by_path.values())
        assert timed[f"{side}_tick_us"] == by_path[kernel_path()]
    ratios = timed["pose_over_translational_tick_by_path"]
    assert set(ratios) == paths and all(ratio > 0 for ratio in ratios.values())
    assert timed["pose_over_translational_tick"] == ratios[kernel_path()]


def test_the_6d_tick_rows_name_both_paths_and_the_bench_path_first():
    from hlcmp_drake.present.tables import to_text
    from hlcmp_drake.run.benchmark import table

    results = _results("full")
    results["machine"]["tick_kernel"] = "compiled"
    results.update(
        pose_tick_states=101,
        pose_tick_us_by_path={
            "compiled": {"p50": 1900.0, "p99": 2600.0},
            "numpy": {"p50": 2200.0, "p99": 3000.0},
        },
        translational_tick_us_by_path={
            "compiled": {"p50": 250.0, "p99": 400.0},
            "numpy": {"p50": 500.0, "p99": 700.0},
        },
        pose_over_translational_tick=7.6,
        pose_over_translational_tick_by_path={"compiled": 7.6, "numpy": 4.4},
    )
    lines = to_text(table(results)).splitlines()
    (first,) = [k for k, line in enumerate(lines) if "pose_over_translational_tick" in line]
    assert "(compiled; 6-D 1900 / 2600 µs, translational 250 / 400 µs" in lines[first]
    assert lines[first].split()[-1] == "7.60"
    assert "numpy path (6-D 2200 / 3000 µs, translational 500 / 700 µs)" in lines[first + 1]
    assert lines[first + 1].split()[-1] == "4.40"


def test_sides_advanced_alternately_all_end_where_asked():
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.primitives import ConstantVectorSource

    from hlcmp_drake.run.benchmark import advance_alternately

    simulators = {side: Simulator(ConstantVectorSource([1.0])) for side in ("a", "b")}
    for simulator in simulators.values():
        simulator.Initialize()
    spent = advance_alternately(simulators, 0.35, chunk_s=0.1)
    assert set(spent) == {"a", "b"} and all(wall >= 0.0 for wall in spent.values())
    assert all(s.get_context().get_time() == 0.35 for s in simulators.values())


def test_sides_ended_alike_only_in_the_same_state():
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource, Integrator

    from hlcmp_drake.run.benchmark import ended_alike

    def integrating():
        builder = DiagramBuilder()
        integrator = builder.AddSystem(Integrator(2))
        rate = builder.AddSystem(ConstantVectorSource([1.0, -2.0]))
        builder.Connect(rate.get_output_port(), integrator.get_input_port())
        return Simulator(builder.Build())

    simulators = {side: integrating() for side in ("a", "b", "c")}
    for simulator in simulators.values():
        simulator.AdvanceTo(0.3)
    assert ended_alike(simulators)
    simulators["c"].AdvanceTo(0.31)
    assert not ended_alike(simulators) and ended_alike({k: simulators[k] for k in "ab"})


def test_a_side_by_side_line_gives_each_sides_step_and_the_ratio():
    from hlcmp_drake.run.benchmark import side_by_side_line

    line = side_by_side_line("hlcmp", {"other": 0.3, "this": 0.2}, 1000, ("other", "this"), True)
    assert line == (
        "hlcmp: other 300.0, this 200.0 µs a step; other / this 1.500; "
        "the same state to the bit: True"
    )
