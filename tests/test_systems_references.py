"""hlcmp_drake.systems.references: the DMP source (state, ports and derivatives; simulated
against the numpy rollout; the compiled C++ source against the Python one) and the step
reference (the Python one against the compiled one)."""

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.systems.ports import REFERENCE_PORTS
from hlcmp_drake.systems.references import (
    DmpSource,
    StepReference,
    compiled_step_reference,
    linear_dmp_source,
)


def test_dmp_source_state_ports_and_derivatives(smooth_demo):
    t, positions = smooth_demo
    dmp = Dmp.fit(t, positions, "xyz")
    source = DmpSource(dmp)
    context = source.CreateDefaultContext()
    assert context.num_continuous_states() == 7
    assert [source.get_output_port(i).get_name() for i in range(source.num_output_ports())] == [
        "desired_position",
        "desired_velocity",
        "desired_acceleration",
        "phase",
    ]
    state = np.array([0.1, 0.2, 0.3, 0.5, -0.4, 0.2, 0.6])
    context.SetContinuousState(state)
    pdot, zdot, sdot = dmp.rates(state[:3], state[3:6], state[6])
    derivatives = source.EvalTimeDerivatives(context).CopyToVector()
    np.testing.assert_allclose(derivatives, np.concatenate([pdot, zdot, [sdot]]))
    np.testing.assert_allclose(
        source.GetOutputPort("desired_velocity").Eval(context), state[3:6] / dmp.tau
    )
    np.testing.assert_allclose(
        source.GetOutputPort("desired_acceleration").Eval(context), zdot / dmp.tau
    )
    np.testing.assert_allclose(source.GetOutputPort("phase").Eval(context), [0.6])


def test_dmp_source_simulated_matches_numpy_rollout(smooth_demo):
    from pydrake.systems.analysis import Simulator

    t, positions = smooth_demo
    dmp = Dmp.fit(t, positions, "xyz")
    source = DmpSource(dmp, tau=1.5 * dmp.tau)
    simulator = Simulator(source)
    simulator.get_mutable_integrator().set_target_accuracy(1e-8)
    simulator.AdvanceTo(1.5 * dmp.tau)
    _, p, *_ = dmp.rollout(dt=0.001, tau=1.5 * dmp.tau)
    np.testing.assert_allclose(
        source.GetOutputPort("desired_position").Eval(simulator.get_context()), p[-1], atol=1e-5
    )


def test_step_reference_switches_and_decays_phase():
    ref = StepReference([0.0, 10.0], [[-0.15], [0.0]], tau=20.0, alpha_s=4.0)
    context = ref.CreateDefaultContext()
    context.SetTime(9.9)
    assert ref.GetOutputPort("desired_position").Eval(context)[0] == -0.15
    context.SetTime(10.0)
    assert ref.GetOutputPort("desired_position").Eval(context)[0] == 0.0
    assert ref.GetOutputPort("desired_velocity").Eval(context)[0] == 0.0
    context.SetContinuousState([0.5])
    np.testing.assert_allclose(ref.EvalTimeDerivatives(context).CopyToVector(), [-4.0 * 0.5 / 20.0])


def test_the_compiled_dmp_source_follows_the_python_one(insertion):
    from pydrake.systems.primitives import LogVectorOutput

    scenario, setup = insertion
    logs = {}
    for name, source in [
        ("python", DmpSource(setup.dmp, tau=6.0)),
        ("compiled", linear_dmp_source(setup.dmp, 7.0, tau=6.0)),
    ]:  # temporal scaling too
        builder = DiagramBuilder()
        system = builder.AddSystem(source)
        ports = ("desired_position", "desired_velocity", "desired_acceleration", "phase")
        loggers = [LogVectorOutput(system.GetOutputPort(port), builder, 0.01) for port in ports]
        simulator = Simulator(builder.Build())
        simulator.get_mutable_integrator()  # the default RK3, variable step: both see the same
        simulator.AdvanceTo(7.0)
        logs[name] = [logger.FindLog(simulator.get_context()).data() for logger in loggers]
    for python, compiled, tolerance in zip(
        logs["python"], logs["compiled"], (1e-6, 1e-5, 1e-4, 1e-9)
    ):
        assert np.abs(python - compiled).max() < tolerance * max(1.0, np.abs(python).max())


def test_the_compiled_step_reference_gives_the_step_references_values():
    times, positions = [0.0, 4.0, 10.0], [[-0.15], [-0.05], [0.0]]
    python, compiled = (
        StepReference(times, positions, 20.0, 4.0),
        compiled_step_reference(times, positions, 20.0, 4.0),
    )
    simulators = [Simulator(system) for system in (python, compiled)]
    for t in [0.0, 3.999, 4.0, 7.5, 10.0, 19.0, 25.0]:
        values = []
        for system, simulator in zip((python, compiled), simulators):
            simulator.AdvanceTo(t)
            context = simulator.get_context()
            values.append([system.GetOutputPort(n).Eval(context) for n in REFERENCE_PORTS])
        for name, a, b in zip(REFERENCE_PORTS, *values):
            np.testing.assert_allclose(b, a, rtol=1e-6, atol=0, err_msg=f"{name} at {t}")


def test_the_orientation_source_follows_the_numpy_rollout():
    from conftest import tilted_turn
    from pydrake.systems.primitives import LogVectorOutput

    from hlcmp_drake.core import quaternion as quat
    from hlcmp_drake.core.orientation_dmp import OrientationDmp
    from hlcmp_drake.systems.references import orientation_dmp_source

    t, _, q, _ = tilted_turn(5)
    dmp = OrientationDmp.fit(t, q)
    dmp = dmp.with_goal(quat.multiply(quat.from_rotation_vector([0.2, 0.0, -0.1]), dmp.goal))
    tau, duration = 1.5 * dmp.tau, 2.0 * dmp.tau  # temporal scaling and a new goal
    builder = DiagramBuilder()
    source = builder.AddSystem(orientation_dmp_source(dmp, duration, tau=tau))
    ports = ("desired_orientation", "desired_angular_velocity", "desired_angular_acceleration")
    loggers = [LogVectorOutput(source.GetOutputPort(port), builder, 0.01) for port in ports]
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(duration)
    q_d, omega_d, omega_dot_d = (
        logger.FindLog(simulator.get_context()).data().T for logger in loggers
    )
    _, q_r, omega_r, _ = dmp.rollout(duration=duration, dt=0.001, tau=tau)
    omega_dot_r = np.gradient(omega_r, 0.001, axis=0)
    every = slice(None, None, 10)
    assert np.degrees(quat.geodesic_angle(q_d, q_r[every])).max() < 1e-4
    assert np.abs(omega_d - omega_r[every]).max() < 1e-5 * np.abs(omega_r).max()
    # np.gradient is one-sided (first order) at the rollout's first sample: left out.
    assert np.abs(omega_dot_d[1:] - omega_dot_r[10::10]).max() < 1e-3 * np.abs(omega_dot_r).max()
