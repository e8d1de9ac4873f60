"""hlcmp_drake.systems.monitor: the SafetyMonitor stops a simulation at the first problem its
check reports."""

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.worlds import arm


def test_a_problem_at_the_start_stops_the_run_at_once(insertion):
    """The SafetyMonitor also looks at t = 0 (inside the Simulator's Initialize)."""
    scenario, _ = load_scenario("insertion", ["max_abs_position_m=0.01", "duration_s=0.5"])
    run = simulate(arm.build(scenario, "hlcmp", insertion[1]), scenario, "hlcmp")
    assert run.status == "unstable" and run.stop_time == 0.0 and "beyond 0.01" in run.reason
