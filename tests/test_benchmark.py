"""The benchmark in its quick smoke mode: every measurement is produced (no thresholds --
speed is reported by `hlcmp bench`, never asserted in a test)."""

import json

import pytest

from hlcmp_drake.cli import main


@pytest.mark.slow
def test_quick_benchmark_writes_every_measurement(tmp_path, capsys):
    assert main(["bench", "--out", str(tmp_path), "--quick"]) == 0
    results = json.loads((tmp_path / "bench.json").read_text())
    for key in ("insertion_rtf", "controller_overhead_ratio", "dmp_fit_ms", "dmp_rollout_ms"):
        assert results[key] > 0
    assert set(results["controller_eval_us"]) == {"10", "50", "200"}
    assert all(v["p99"] >= v["median"] > 0 for v in results["controller_eval_us"].values())
    assert "dmp_vs_movement_primitives" in results
    assert set(results["scenario_wall_s"]) == {"one_dof", "insertion", "cutting"}
    assert "controller_overhead_ratio" in capsys.readouterr().out
