"""The benchmark in its quick smoke mode: every measurement is produced (no thresholds --
speed is reported by `hlcmp bench`, never asserted in a test)."""

import json

import pytest

from hlcmp_drake.cli import main


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
    ):
        assert results[key] > 0
    assert results["controller_tick_us"]["p99"] >= results["controller_tick_us"]["p50"] > 0
    walls = results["insertion_wall_s"]
    assert set(walls) == {"fast", "cpp", "fast_bare", "cpp_bare", "modular"} and all(
        len(w) == 1 for w in walls.values()
    )
    assert "dmp_vs_movement_primitives" in results
    assert set(results["scenario_wall_s"]) == {"one_dof", "insertion", "cutting"}
    assert "controller_overhead_ratio" in capsys.readouterr().out
