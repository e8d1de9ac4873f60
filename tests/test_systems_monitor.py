"""hlcmp_drake.systems.monitor: the SafetyMonitor looks every period (from t = 0 on), lets a
fine run continue and stops a simulation at the first problem its check reports, with the
check's reason; and the plant-state check every world shares."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator, SimulatorStatus
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Integrator

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.systems.monitor import (
    CHECK_PERIOD_S,
    SafetyMonitor,
    plant_state_check,
    saturation_check,
)
from hlcmp_drake.worlds import arm


def test_a_problem_at_the_start_stops_the_run_at_once(insertion):
    """The SafetyMonitor also looks at t = 0 (inside the Simulator's Initialize)."""
    scenario, _ = load_scenario("insertion", ["max_abs_position_m=0.01", "duration_s=0.5"])
    run = simulate(arm.build(scenario, "hlcmp", insertion[1]), scenario, "hlcmp")
    assert run.status == "unstable" and run.stop_time == 0.0 and "beyond 0.01" in run.reason


# --- the monitor alone: a clock x(t) = t and a constant pair -----------------------------


def _clock_and_monitor(check, **period):
    """x(t) = t (a constant 1 integrated) and the constant (3, 4) into a SafetyMonitor with
    inputs x (1) and pair (2). Returns a Simulator of the diagram."""
    builder = DiagramBuilder()
    one = builder.AddSystem(ConstantVectorSource([1.0]))
    clock = builder.AddSystem(Integrator(1))
    pair = builder.AddSystem(ConstantVectorSource([3.0, 4.0]))
    monitor = builder.AddSystem(SafetyMonitor({"x": 1, "pair": 2}, check, **period))
    builder.Connect(one.get_output_port(), clock.get_input_port())
    builder.Connect(clock.get_output_port(), monitor.GetInputPort("x"))
    builder.Connect(pair.get_output_port(), monitor.GetInputPort("pair"))
    return Simulator(builder.Build())


class _Check:
    """Records every call; a problem once x is above `limit`."""

    def __init__(self, limit=np.inf):
        self.limit, self.calls = limit, []

    def __call__(self, t, values):
        self.calls.append((t, {name: np.array(value) for name, value in values.items()}))
        x = values["x"][0]
        return f"x = {x:.3f} above {self.limit}" if x > self.limit else None


def test_the_monitor_declares_its_inputs_and_no_output():
    monitor = SafetyMonitor({"plant_state": 14, "contact_force": 3, "saturated": 1}, _Check())
    ports = [monitor.get_input_port(i) for i in range(monitor.num_input_ports())]
    assert [(p.get_name(), p.size()) for p in ports] == [
        ("plant_state", 14),
        ("contact_force", 3),
        ("saturated", 1),
    ]
    assert monitor.num_output_ports() == 0


def test_a_fine_run_continues_and_is_checked_every_period():
    check = _Check()
    simulator = _clock_and_monitor(check)
    status = simulator.AdvanceTo(0.995)
    assert status.reason() == SimulatorStatus.ReturnReason.kReachedBoundaryTime
    assert simulator.get_context().get_time() == 0.995
    times = np.array([t for t, _ in check.calls])
    expected = np.arange(0.0, 0.995, CHECK_PERIOD_S)  # from t = 0 (Initialize) on
    np.testing.assert_allclose(times, expected, atol=1e-12)
    for t, values in check.calls:  # the inputs as they are at the check's time
        assert set(values) == {"x", "pair"} and values["x"].shape == (1,)
        np.testing.assert_allclose(values["x"], [t], atol=1e-9)
        np.testing.assert_array_equal(values["pair"], [3.0, 4.0])


@pytest.mark.parametrize("period", [CHECK_PERIOD_S, 0.1])
def test_the_first_problem_stops_the_simulation_with_its_reason(period):
    limit = 0.505
    check = _Check(limit)
    simulator = _clock_and_monitor(check, period=period)
    status = simulator.AdvanceTo(2.0)
    assert status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition
    first_above = period * np.ceil(limit / period)  # the first check with x > limit
    assert status.return_time() == pytest.approx(first_above, abs=1e-12)
    assert simulator.get_context().get_time() == pytest.approx(first_above, abs=1e-12)
    assert f"x = {first_above:.3f} above {limit}" in status.message()  # the check's own words
    times = [t for t, _ in check.calls]  # and none after it
    assert times[0] == 0.0 and times[-1] == pytest.approx(first_above, abs=1e-12)
    np.testing.assert_allclose(np.diff(times), period, atol=1e-12)


def test_problem_at_gives_the_checks_verdict_at_a_context():
    check = _Check(0.5)
    monitor = SafetyMonitor({"x": 1, "pair": 2}, check)
    context = monitor.CreateDefaultContext()
    monitor.GetInputPort("pair").FixValue(context, [3.0, 4.0])
    monitor.GetInputPort("x").FixValue(context, [0.2])
    context.SetTime(0.25)
    assert monitor.problem_at(context) is None
    monitor.GetInputPort("x").FixValue(context, [0.7])
    assert monitor.problem_at(context) == "x = 0.700 above 0.5"
    assert [t for t, _ in check.calls] == [0.25, 0.25]


def test_the_plant_state_check_finite_and_positions_bounded():
    check = plant_state_check(2, 1.0)  # state (q0, q1, v0, v1)
    assert check(np.array([0.5, -0.9, 0.0, 0.0])) is None
    assert check(np.array([0.5, -0.9, 50.0, -50.0])) is None  # velocities are not bounded
    assert check(np.array([0.5, -1.1, 0.0, 0.0])) == "a joint position beyond 1.0 m/rad"
    assert check(np.array([0.5, 0.0, np.nan, 0.0])) == "plant state is not finite"
    assert check(np.array([np.inf, 0.0, 0.0, 0.0])) == "plant state is not finite"


def test_the_saturation_check_counts_from_when_saturation_began():
    """A stop only once some joint has been saturated at every check for longer than the
    limit; a check without saturation starts the count again."""
    check = saturation_check(0.25, "joint forces")
    assert [check(t, 1) for t in (0.0, 0.1, 0.2)] == [None, None, None]
    assert check(0.3, 0) is None  # released: the next saturation counts from its start
    assert [check(t, 2) for t in (0.4, 0.5, 0.6)] == [None, None, None]
    assert check(0.7, 1) == "joint forces saturated for more than max_saturation_s = 0.25 s"
