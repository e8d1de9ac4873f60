"""hlcmp_drake.systems.control_loop: ControlLoop, the arm's controller in one Python evaluation
per plant step: one tick against the modular systems, its documented ports, and its torque,
θ's rate and logs against ControlTick.evaluate on the same inputs (held between ticks)."""

import numpy as np
import pytest
from conftest import arm_tick_inputs
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core.dmp import phase_at
from hlcmp_drake.core.kernels import KERNEL_VARIABLE, numba_available
from hlcmp_drake.core.laws import TaskSpaceInstant
from hlcmp_drake.systems.arm import BelowTaskImpedance, NullSpaceImpedance
from hlcmp_drake.systems.control_loop import ControlLoop, ControlTick
from hlcmp_drake.systems.ports import REFERENCE_PORTS
from hlcmp_drake.systems.task_space import TaskSpaceDynamics, TaskSpaceModel
from hlcmp_drake.worlds.arm import arm_tick
from hlcmp_drake.worlds.controllers import hlcmp_law, modular_system
from hlcmp_drake.worlds.models import add_plant, scoped_frame
from hlcmp_drake.worlds.slider import slider_tick


def test_one_tick_gives_the_modular_systems_torque(insertion):
    """At a contact-like state, the loop's torque equals J^T f_c + the null-space torque of
    the modular chain, to rounding."""
    scenario, setup = insertion
    builder = DiagramBuilder()
    plant, _ = add_plant(builder, scenario)
    tip = scoped_frame(plant, scenario.task.tool_frame)
    law = hlcmp_law(scenario.controllers["hlcmp"], scenario)
    gains = (100.0, 10.0, 20.0, 5.0)
    effort = [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
    loop = ControlLoop(
        ControlTick(
            TaskSpaceModel(plant, tip),
            BelowTaskImpedance(plant, tip, setup.tool_orientation, setup.q0, *gains),
            law,
            effort,
        ),
        0.001,
    )
    rng = np.random.default_rng(3)
    state = np.concatenate([setup.q0 + rng.normal(0, 0.02, 7), rng.normal(0, 0.2, 7)])
    theta = rng.uniform(0, 300, law.theta_size)
    reference = dict(
        desired_position=setup.dmp.start + [0.0, 0.0, -0.01],
        desired_velocity=[0.0, 0.0, -0.03],
        desired_acceleration=[0.0, 0.0, 0.02],
        phase=[0.4],
    )
    context = loop.CreateDefaultContext()
    loop.plant_state.FixValue(context, state)
    loop.GetInputPort("theta").FixValue(context, theta)
    for name, value in reference.items():
        loop.GetInputPort(name).FixValue(context, value)
    Simulator(loop, context).AdvanceTo(0.0005)  # the tick at t = 0
    fast_torque = loop.GetOutputPort("joint_torque").Eval(context)
    fast_rates = loop.GetOutputPort("theta_rate").Eval(context)

    task_space = TaskSpaceDynamics(plant, tip)
    ts_context = task_space.CreateDefaultContext()
    task_space.plant_state.FixValue(ts_context, state)
    terms = task_space.terms(ts_context)
    out = law.command(
        TaskSpaceInstant(
            terms.position,
            terms.velocity,
            *(
                np.asarray(reference[k], float)
                for k in ("desired_position", "desired_velocity", "desired_acceleration")
            ),
            0.4,
            terms.inertia,
            terms.coriolis,
            terms.gravity,
        ),
        theta,
    )
    below = NullSpaceImpedance(plant, tip, setup.tool_orientation, setup.q0, *gains)
    below_context = below.CreateDefaultContext()
    below.plant_state.FixValue(below_context, state)
    below.projector.FixValue(below_context, terms.null_space.ravel())
    below.gravity.FixValue(below_context, terms.joint_gravity)
    modular_torque = np.clip(
        terms.jacobian.T @ out.force + below.get_output_port().Eval(below_context),
        -np.asarray(effort),
        effort,
    )
    assert np.abs(out.force).max() > 1.0  # a state that asks for a real command
    np.testing.assert_allclose(fast_torque, modular_torque, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(fast_rates, out.rates, rtol=1e-12)
    # and the modular controller system computes the same force from the same terms
    controller = modular_system(
        scenario.controllers["hlcmp"], scenario, np.zeros(3), law.unflatten(theta)
    )
    assert controller.num_continuous_states() == law.theta_size


# --- the loop against ControlTick.evaluate on the same inputs --------------------------------


@pytest.fixture(scope="module")
def arm_ticks(insertion):
    """For the Hl-CMP and a constant impedance of the insertion: two ControlTicks each, built
    alike on one plant, one for the loop and one to evaluate the same inputs by hand."""
    scenario, setup = insertion
    plant, _ = add_plant(DiagramBuilder(), scenario)
    return plant, {
        name: (
            arm_tick(scenario, name, plant=plant, setup=setup),
            arm_tick(scenario, name, plant=plant, setup=setup),
        )
        for name in ("hlcmp", "const_500")
    }


def _fix(loop, context, state, reference, theta):
    loop.plant_state.FixValue(context, state)
    for name, value in zip(REFERENCE_PORTS, reference):
        loop.GetInputPort(name).FixValue(context, value)
    if theta is not None:
        loop.GetInputPort("theta").FixValue(context, theta)


@pytest.mark.parametrize("name", ["hlcmp", "const_500"])
def test_the_loop_has_the_documented_ports(arm_ticks, insertion, name):
    plant, ticks = arm_ticks
    tick = ticks[name][0]
    loop = ControlLoop(tick, plant.time_step())
    law, m = tick.law, len(insertion[0].task.axes)  # M: the task's axes
    nq, nv = plant.num_positions(), plant.num_velocities()
    inputs = [loop.get_input_port(i) for i in range(loop.num_input_ports())]
    outputs = [loop.get_output_port(i) for i in range(loop.num_output_ports())]
    expected_inputs = [
        ("plant_state", nq + nv),
        ("desired_position", m),
        ("desired_velocity", m),
        ("desired_acceleration", m),
        ("phase", 1),
    ]
    expected_outputs = [("joint_torque", nv)]
    if law.learns:  # the Hl-CMP: theta in, its rate out (3 M N weights)
        assert law.theta_size == 3 * m * len(law.centers) > 0
        expected_inputs.append(("theta", law.theta_size))
        expected_outputs.append(("theta_rate", law.theta_size))
    else:
        assert loop.theta is None
    expected_outputs.append(("logs", 2 * m + 1 + m * len(law.log_fields)))
    assert [(p.get_name(), p.size()) for p in inputs] == expected_inputs
    assert [(p.get_name(), p.size()) for p in outputs] == expected_outputs
    assert loop.log_columns == tick.log_columns and tick.log_size == expected_outputs[-1][1]


@pytest.mark.parametrize("name", ["hlcmp", "const_500"])
def test_a_tick_is_arm_tick_evaluate_held_until_the_next(arm_ticks, insertion, name):
    """The torque (and θ's rate) of the tick at t = 0 are ControlTick.evaluate's on that
    tick's inputs, and they are held: new inputs change them only at the next tick
    (t = 1 ms). The logs output is evaluated at the present inputs."""
    plant, ticks = arm_ticks
    tick, by_hand = ticks[name]
    loop = ControlLoop(tick, plant.time_step())
    context = loop.CreateDefaultContext()
    first = arm_tick_inputs(insertion[1], tick.law, seed=3)
    second = arm_tick_inputs(insertion[1], tick.law, seed=4)
    expected = [by_hand.evaluate(*inputs) for inputs in (first, second)]
    assert np.abs(expected[0].law.force).max() > 1.0  # a state that asks for a real command
    assert np.abs(expected[0].torque - expected[1].torque).max() > 1e-3  # tells them apart

    def outputs():
        torque = loop.GetOutputPort("joint_torque").Eval(context)
        rates = loop.GetOutputPort("theta_rate").Eval(context) if tick.law.learns else None
        return torque, rates

    def assert_outputs_are(result):
        torque, rates = outputs()
        np.testing.assert_allclose(torque, result.torque, rtol=1e-12, atol=1e-12)
        if tick.law.learns:
            np.testing.assert_allclose(rates, result.law.rates, rtol=1e-12, atol=1e-12)
        else:
            assert result.law.rates is None

    _fix(loop, context, *first)
    simulator = Simulator(loop, context)
    simulator.AdvanceTo(0.0005)  # the tick at t = 0
    assert_outputs_are(expected[0])
    np.testing.assert_allclose(
        loop.GetOutputPort("logs").Eval(context), by_hand.log_row(expected[0]), rtol=1e-12
    )
    _fix(loop, context, *second)  # new inputs between two ticks
    assert_outputs_are(expected[0])  # held
    np.testing.assert_allclose(
        loop.GetOutputPort("logs").Eval(context), by_hand.log_row(expected[1]), rtol=1e-12
    )
    simulator.AdvanceTo(0.0015)  # the tick at t = 1 ms
    assert_outputs_are(expected[1])


def test_a_tick_whose_instant_was_logged_takes_the_loggers_result(arm_ticks, insertion):
    """Where the logs were read at the tick's instant and inputs (a logger's sample), the
    tick holds the torque and θ' of that result instead of computing them again: the same
    numbers to the bit; elsewhere it computes them. Only computing ticks are timed."""
    plant, ticks = arm_ticks
    tick, by_hand = ticks["hlcmp"]
    calls = []
    held_command = tick.held_command
    tick.held_command = lambda *args: calls.append(args[3]) or held_command(*args)
    try:
        loop = ControlLoop(tick, plant.time_step())
        times = loop.record_tick_times()
        context = loop.CreateDefaultContext()
        inputs = arm_tick_inputs(insertion[1], tick.law, seed=6)
        expected = by_hand.evaluate(*inputs)
        _fix(loop, context, *inputs)
        simulator = Simulator(loop, context)
        simulator.Initialize()
        loop.GetOutputPort("logs").Eval(context)  # a logger's sample at t = 0
        simulator.AdvanceTo(0.0005)  # the tick at t = 0: takes the logged result
        assert calls == [] and times == []
        np.testing.assert_array_equal(
            loop.GetOutputPort("joint_torque").Eval(context), expected.torque
        )
        np.testing.assert_array_equal(
            loop.GetOutputPort("theta_rate").Eval(context), expected.law.rates
        )
        simulator.AdvanceTo(0.0015)  # the tick at t = 1 ms, no logs read: computes
        assert calls == [0.001] and len(times) == 1
    finally:
        del tick.held_command


def test_the_torque_is_saturated_at_the_effort_limits(arm_ticks, insertion):
    """θ far too large: the tick's torque sits at the actuators' limits, as evaluate says."""
    plant, ticks = arm_ticks
    tick, by_hand = ticks["hlcmp"]
    state, reference, theta = arm_tick_inputs(insertion[1], tick.law, seed=5)
    theta = theta * 1e4
    result = by_hand.evaluate(state, reference, theta)
    limits = np.array(
        [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
    )
    assert result.saturated > 0 and np.all(np.abs(result.torque) <= limits)
    loop = ControlLoop(tick, plant.time_step())
    context = loop.CreateDefaultContext()
    _fix(loop, context, state, reference, theta)
    Simulator(loop, context).AdvanceTo(0.0005)
    torque = loop.GetOutputPort("joint_torque").Eval(context)
    np.testing.assert_allclose(torque, result.torque, rtol=1e-12)
    assert np.sum(np.isclose(np.abs(torque), limits)) == result.saturated
    logs = loop.GetOutputPort("logs").Eval(context)
    assert logs[loop.log_columns["saturated"]][0] == result.saturated


# --- the compiled tick against the numpy tick (core.kernels) ------------------------------


def _ticks_on_both_paths(monkeypatch, make):
    made = {}
    for path in ("compiled", "numpy"):
        monkeypatch.setenv(KERNEL_VARIABLE, path)
        made[path] = make()
        assert made[path].kernel == path
    return made["compiled"], made["numpy"]


def _assert_ticks_agree(compiled, numpy_path, inputs):
    """The torque, the saturation count, f_c, the law's series, θ' and the task-space terms
    of the two paths, each equal to 1e-12 of its own scale, at every input."""
    for state, reference, theta, extra in inputs:
        a = compiled.evaluate(state, reference, theta, **extra)
        b = numpy_path.evaluate(state, reference, theta, **extra)
        assert a.saturated == b.saturated
        pairs = [("torque", a.torque, b.torque), ("f_c", a.law.force, b.law.force)]
        pairs += [(key, a.law.logs[key], b.law.logs[key]) for key in b.law.logs]
        if b.law.rates is not None:
            pairs.append(("θ'", a.law.rates, b.law.rates))
        for field in ("position", "velocity", "inertia", "gravity", "null_space"):
            pairs.append((field, getattr(a.terms, field), getattr(b.terms, field)))
        for what, got, expected in pairs:
            scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale, err_msg=what)


needs_numba = pytest.mark.skipif(not numba_available(), reason="numba is not installed")


@needs_numba
@pytest.mark.parametrize("name", ["hlcmp", "const_500"])
def test_compiled_arm_tick_agrees_with_numpy_at_random_states(monkeypatch, insertion, name):
    scenario, setup = insertion
    plant, _ = add_plant(DiagramBuilder(), scenario)
    compiled, numpy_path = _ticks_on_both_paths(
        monkeypatch, lambda: arm_tick(scenario, name, plant=plant, setup=setup)
    )
    inputs = [(*arm_tick_inputs(setup, numpy_path.law, seed), {}) for seed in range(20)]
    _assert_ticks_agree(compiled, numpy_path, inputs)


@needs_numba
@pytest.mark.parametrize("name", ["hlcmp", "vic_fd_0.5"])
def test_compiled_slider_tick_agrees_with_numpy_at_random_states(monkeypatch, name):
    scenario, _ = load_scenario("one_dof")
    plant, _ = add_plant(DiagramBuilder(), scenario)
    compiled, numpy_path = _ticks_on_both_paths(
        monkeypatch, lambda: slider_tick(scenario, name, plant=plant)
    )
    rng = np.random.default_rng(5)
    law = numpy_path.law
    inputs = [
        (
            rng.normal(0, 0.1, 2),
            tuple(rng.normal(0, scale, 1) for scale in (0.1, 0.1, 1.0)) + (rng.uniform(size=1),),
            rng.uniform(0, 300, law.theta_size) if law.learns else rng.normal(0, 0.1, 3),
            dict(time=float(rng.uniform(0, 20)), external_force=rng.normal(0, 5, 1)),
        )
        for _ in range(20)
    ]
    _assert_ticks_agree(compiled, numpy_path, inputs)


def _real_inputs(run_folder, name, phase_of, law, every=25):
    """The run's logged plant states and set-points (every `every`-th 10 ms sample), the
    set-point's rates by differences, the phase at that time, and θ drawn at random."""
    series = np.load(run_folder / "timeseries.npz")
    t, xd = series["t"], series[f"{name}/xd"]
    xd_dot = np.gradient(xd, t, axis=0)
    xd_ddot = np.gradient(xd_dot, t, axis=0)
    rng = np.random.default_rng(11)
    return [
        (
            series[f"{name}/plant_state"][k],
            (xd[k], xd_dot[k], xd_ddot[k], np.array([phase_of(t[k])])),
            rng.uniform(0, 300, law.theta_size) if law.learns else None,
            dict(time=float(t[k]), external_force=series[f"{name}/f_ext"][k]),
        )
        for k in range(0, len(t), every)
    ]


@needs_numba
@pytest.mark.slow
@pytest.mark.parametrize("name", ["hlcmp", "const_500"])
def test_compiled_arm_tick_agrees_with_numpy_along_the_run(
    monkeypatch, insertion, insertion_run, name
):
    """At the bundled insertion's own plant states: free motion, contact, the tear."""
    scenario, setup = insertion
    plant, _ = add_plant(DiagramBuilder(), scenario)
    compiled, numpy_path = _ticks_on_both_paths(
        monkeypatch, lambda: arm_tick(scenario, name, plant=plant, setup=setup)
    )
    dmp = setup.dmp
    inputs = _real_inputs(
        insertion_run, name, lambda t: phase_at(t, dmp.tau, dmp.settings.alpha_s), numpy_path.law
    )
    _assert_ticks_agree(compiled, numpy_path, inputs)


@needs_numba
@pytest.mark.slow
@pytest.mark.parametrize("name", ["hlcmp", "vic_fd_0.5"])
def test_compiled_slider_tick_agrees_with_numpy_along_the_run(monkeypatch, one_dof_run, name):
    """At the bundled 1-DOF run's own states (free, pressing, retreating); the variable
    impedance's state θ from its commanded motion: x_c = x, x_c' = x', Φ = 0."""
    scenario, _ = load_scenario("one_dof")
    plant, _ = add_plant(DiagramBuilder(), scenario)
    compiled, numpy_path = _ticks_on_both_paths(
        monkeypatch, lambda: slider_tick(scenario, name, plant=plant)
    )
    inputs = _real_inputs(one_dof_run, name, lambda t: np.exp(-t), numpy_path.law, every=50)
    if not numpy_path.law.learns:
        inputs = [(s, r, np.concatenate([s, [0.0]]), e) for s, r, _, e in inputs]
    _assert_ticks_agree(compiled, numpy_path, inputs)


def test_the_tick_reads_the_orientation_and_j_w_from_the_terms(arm_ticks, insertion):
    """The tick's torque below the task, from the orientation and J_w in the model's terms,
    equals the one `BelowTaskImpedance` reads by itself on its own context, to 1e-12 of
    its scale; a below-task torque of another frame is refused."""
    plant, ticks = arm_ticks
    tick, _ = ticks["hlcmp"]
    scenario, setup = insertion
    for seed in range(5):
        state, reference, theta = arm_tick_inputs(setup, tick.law, seed)
        result = tick.evaluate(state, reference, theta)
        by_itself = tick.below_task.torque(
            state, result.terms.null_space, result.terms.joint_gravity
        )
        reused = tick.below_task.torque_at(
            state,
            result.terms.null_space,
            result.terms.joint_gravity,
            result.terms.rotation,
            result.terms.angular_jacobian,
        )
        assert np.abs(by_itself).max() > 1.0
        np.testing.assert_allclose(reused, by_itself, rtol=0, atol=1e-12 * np.abs(by_itself).max())
    other = plant.GetBodyByName("iiwa_link_7").body_frame()
    below = BelowTaskImpedance(plant, other, setup.tool_orientation, setup.q0, 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="must be one frame"):
        ControlTick(tick.model, below, tick.law, tick.effort_limits)
