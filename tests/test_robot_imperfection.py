"""A robot that is not its model (`robot_imperfection`, the `real_arm` variant): each
imperfection alone -- the joint friction's torque curve, the force sensor's noise and its
seed, the velocity estimate, the controller's model set off in M and G -- the bad values
refused at load, and short runs on the imperfect arm."""

import math

import numpy as np
import pytest
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, VectorLogSink

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core.robot import force_noise_samples, joint_friction_torque, low_pass_retention
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.run.runner import experiment_worlds
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.systems.control_loop import ControlLoop
from hlcmp_drake.systems.robot import (
    JointFriction,
    arm_bodies,
    sensed_force,
    set_model_off,
    velocity_estimate,
)
from hlcmp_drake.systems.task_space import TaskSpaceModel
from hlcmp_drake.worlds import arm
from hlcmp_drake.worlds.models import load_models, scoped_frame

# Stürz et al. 2017, Table 3, as in diagrams/variants/real_arm.yaml.
VISCOUS = np.array([0.24150, 0.37328, 0.11025, 0.10000, 0.10000, 0.12484, 0.10000])
COULOMB = np.array([0.31909, 0.18130, 0.07302, 0.17671, 0.03463, 0.13391, 0.08710])


# --- the joints' friction ------------------------------------------------------------------


def test_friction_opposes_the_motion_viscous_plus_coulomb_smoothed():
    speed = 0.002
    assert not np.any(joint_friction_torque(np.zeros(7), VISCOUS, COULOMB, speed))
    fast = np.full(7, 0.5)  # 250 v_s: tanh is 1 to double precision
    np.testing.assert_allclose(
        joint_friction_torque(fast, VISCOUS, COULOMB, speed), -(VISCOUS * 0.5 + COULOMB)
    )
    np.testing.assert_allclose(
        joint_friction_torque(-fast, VISCOUS, COULOMB, speed), VISCOUS * 0.5 + COULOMB
    )
    at_speed = joint_friction_torque(np.full(7, speed), VISCOUS, COULOMB, speed)
    np.testing.assert_allclose(at_speed, -(VISCOUS * speed + COULOMB * math.tanh(1.0)))
    # continuous through rest: the slope there is F_v + F_c / v_s
    tiny = 1e-7
    slope = (
        joint_friction_torque(np.full(7, -tiny), VISCOUS, COULOMB, speed)
        - joint_friction_torque(np.full(7, tiny), VISCOUS, COULOMB, speed)
    ) / (2 * tiny)
    np.testing.assert_allclose(slope, VISCOUS + COULOMB / speed, rtol=1e-6)


def test_the_friction_system_outputs_the_curve_at_the_plant_velocities():
    friction = JointFriction(7, VISCOUS, COULOMB, 0.002)
    context = friction.CreateDefaultContext()
    v = np.array([0.3, -0.001, 0.0, 0.002, -0.5, 0.01, 1.0])
    friction.plant_state.FixValue(context, np.concatenate([np.full(7, 9.0), v]))
    np.testing.assert_array_equal(
        friction.GetOutputPort("generalized_force").Eval(context),
        joint_friction_torque(v, VISCOUS, COULOMB, 0.002),
    )
    coulomb_only = JointFriction(7, [], COULOMB, 0.002)
    context = coulomb_only.CreateDefaultContext()
    coulomb_only.plant_state.FixValue(context, np.concatenate([np.zeros(7), v]))
    np.testing.assert_array_equal(
        coulomb_only.GetOutputPort("generalized_force").Eval(context),
        joint_friction_torque(v, np.zeros(7), COULOMB, 0.002),
    )


# --- the wrist force sensor -----------------------------------------------------------------


def test_noise_has_its_sigma_per_axis_and_the_seed_fixes_it():
    sigma = np.array([0.25, 0.25, 0.45])
    times, noise = force_noise_samples(sigma, 7, 0.001, 40.0)
    assert noise.shape == (40002, 3) and times[1] == 0.001 and times[-1] == pytest.approx(40.001)
    # 40002 draws: the sample sigma is within 2 % (about 6 standard errors) and the mean
    # within 5 standard errors of zero
    np.testing.assert_allclose(noise.std(axis=0), sigma, rtol=0.02)
    assert np.all(np.abs(noise.mean(axis=0)) < 5 * sigma / math.sqrt(len(noise)))
    assert abs(np.corrcoef(noise[:, 0], noise[:, 2])[0, 1]) < 0.03  # independent axes
    assert abs(np.corrcoef(noise[1:, 2], noise[:-1, 2])[0, 1]) < 0.03  # a new draw each time
    np.testing.assert_array_equal(force_noise_samples(sigma, 7, 0.001, 40.0)[1], noise)
    assert not np.array_equal(force_noise_samples(sigma, 8, 0.001, 40.0)[1], noise)
    assert not np.any(force_noise_samples(np.zeros(3), 7, 0.001, 1.0)[1])


def test_the_sensor_reads_the_force_plus_bias_plus_the_draw_of_each_period():
    builder = DiagramBuilder()
    force = np.array([1.0, -2.0, 10.0])
    bias = np.array([0.0, 0.0, -0.147])
    sigma = np.array([0.25, 0.25, 0.45])
    source = builder.AddSystem(ConstantVectorSource(force))
    sensed = sensed_force(
        builder,
        source.get_output_port(),
        sigma=sigma,
        bias=bias,
        seed=3,
        period=0.005,
        duration=0.1,
    )
    sink = builder.AddSystem(VectorLogSink(3, 0.005))
    builder.Connect(sensed, sink.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.1)
    log = sink.FindLog(simulator.get_context())
    _, noise = force_noise_samples(sigma, 3, 0.005, 0.1)
    # each logged sample holds its period's draw (the log samples a hair after the event)
    readings = log.data().T
    expected = force + bias + noise[: len(readings)]
    assert len(readings) >= 20
    np.testing.assert_allclose(readings, expected, atol=1e-12)


# --- the velocity estimate ------------------------------------------------------------------


def test_the_low_pass_is_drake_iiwa_drivers_at_40_hz_and_1_ms():
    rc = 1 / (2 * math.pi * 40.0)
    assert low_pass_retention(40.0, 0.001) == pytest.approx(rc / (0.001 + rc))
    assert low_pass_retention(40.0, 0.001) == pytest.approx(0.79915, abs=1e-5)
    assert low_pass_retention(40.0, 0.005) < low_pass_retention(40.0, 0.001)


def _run_estimate(system, positions, n):
    context = system.CreateDefaultContext()
    outputs = []
    for q in positions:
        system.get_input_port().FixValue(context, np.concatenate([q, np.full(n, 99.0)]))
        outputs.append(system.get_output_port().Eval(context).copy())
        context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context).value())
    return np.array(outputs)


def test_the_velocity_estimate_filters_the_position_differences():
    n, period = 2, 0.001
    q0 = np.array([0.3, -1.0])
    t = period * np.arange(400)
    positions = q0 + np.column_stack([0.2 * np.sin(3 * t), 0.05 * t])
    out = _run_estimate(velocity_estimate(n, period, 40.0, q0), positions, n)
    np.testing.assert_array_equal(out[:, :n], positions)  # the positions go through
    a = low_pass_retention(40.0, period)
    v, previous, expected = np.zeros(n), q0, []
    for q in positions:
        v = a * v + (1 - a) * (q - previous) / period
        previous = q
        expected.append(v)
    np.testing.assert_allclose(out[:, n:], expected, rtol=1e-12, atol=1e-12)
    # the ramp's slope once the filter has settled; the sine's velocity lags and is damped
    assert out[-1, n + 1] == pytest.approx(0.05, rel=1e-9)
    assert 0.5 < np.abs(out[200:, n]).max() / 0.6 < 1.0
    # the first estimate starts from q0: no jump from a zero initial position
    assert not np.any(out[0, n:])


def test_a_position_step_decays_at_the_filters_rate():
    n, period = 1, 0.001
    out = _run_estimate(
        velocity_estimate(n, period, 40.0, np.zeros(1)), [[0.0], [0.001], *[[0.001]] * 5], n
    )
    a = low_pass_retention(40.0, period)
    np.testing.assert_allclose(out[1:, 1], (1 - a) * a ** np.arange(6), rtol=1e-12)


# --- the controller's model -----------------------------------------------------------------


@pytest.fixture(scope="module")
def insertion_plant():
    scenario, _ = load_scenario("insertion")
    plant = MultibodyPlant(0.001)
    load_models(plant, scenario)
    q0 = np.array([0.1, 0.5, -0.1, -1.4, 0.2, 1.1, 0.3])
    return plant, scoped_frame(plant, scenario.task.tool_frame), q0


def _mass_and_gravity(plant, tool_frame, q, **errors):
    model = TaskSpaceModel(plant, tool_frame)
    if errors:
        set_model_off(
            plant,
            model.context,
            arm_bodies=arm_bodies(plant),
            tool_body=tool_frame.body(),
            link_mass_error=errors.get("link", 0.0),
            tool_mass_error=errors.get("tool", 0.0),
            tool_com_error=np.asarray(errors.get("com", np.zeros(3))),
        )
    terms = model.terms(np.concatenate([q, np.zeros(7)]))
    return plant.CalcMassMatrix(model.context), terms.joint_gravity, model.context


def test_the_arm_bodies_are_its_seven_links(insertion_plant):
    plant, _, _ = insertion_plant
    assert [b.name() for b in arm_bodies(plant)] == [f"iiwa_link_{k}" for k in range(1, 8)]


def test_link_masses_off_scale_the_links_share_of_m_and_g(insertion_plant):
    plant, tool_frame, q = insertion_plant
    m0, g0, _ = _mass_and_gravity(plant, tool_frame, q)
    m1, g1, context = _mass_and_gravity(plant, tool_frame, q, link=-0.03)
    m2, g2, _ = _mass_and_gravity(plant, tool_frame, q, link=-0.06)
    # M and G are linear in the masses (each link's inertia scales with its mass)
    np.testing.assert_allclose(m2 - m1, m1 - m0, atol=1e-12)
    np.testing.assert_allclose(g2 - g1, g1 - g0, atol=1e-12)
    # the links' share: G with massless links is the tool's alone
    massless, tool_only, _ = _mass_and_gravity(plant, tool_frame, q, link=-1 + 1e-12)
    np.testing.assert_allclose(g1 - g0, -0.03 * (g0 - tool_only), atol=1e-9)
    assert np.abs(g1 - g0).max() > 0.5  # N m: a visible mismatch on the shoulder
    # the reflected rotor inertia (not a link's) stays: M of massless links keeps its diagonal
    assert np.all(np.diag(massless) > 1.0)
    # the plant's own defaults (the simulated arm) are untouched
    assert arm_bodies(plant)[1].default_mass() == 6.35
    assert arm_bodies(plant)[1].get_mass(context) == pytest.approx(6.35 * 0.97)


def test_the_tools_mass_and_centre_of_mass_off_move_g_by_their_weight(insertion_plant):
    plant, tool_frame, q = insertion_plant
    tool = tool_frame.body()
    _, g0, context = _mass_and_gravity(plant, tool_frame, q)
    _, g1, _ = _mass_and_gravity(plant, tool_frame, q, tool=-0.05)
    com = tool.default_com()
    jacobian = plant.CalcJacobianTranslationalVelocity(
        context,
        JacobianWrtVariable.kV,
        tool.body_frame(),
        com,
        plant.world_frame(),
        plant.world_frame(),
    )
    weight = 9.81 * tool.default_mass()
    # G = J_com^T (m g z): 5 % less tool mass takes 5 % of the tool's weight off G
    np.testing.assert_allclose(g1 - g0, -0.05 * weight * jacobian[2], atol=1e-9)
    _, g2, _ = _mass_and_gravity(plant, tool_frame, q, com=[0.0, 0.0, -0.005])
    moved = plant.CalcJacobianTranslationalVelocity(
        context,
        JacobianWrtVariable.kV,
        tool.body_frame(),
        com + [0.0, 0.0, -0.005],
        plant.world_frame(),
        plant.world_frame(),
    )
    np.testing.assert_allclose(g2 - g0, weight * (moved[2] - jacobian[2]), atol=1e-9)
    assert np.abs(g2 - g0).max() > 1e-3


# --- the scenario option ------------------------------------------------------------------


def _variant(overrides=(), name="insertion"):
    return load_scenario(name, list(overrides), experiment_worlds(), "real_arm")[0]


def test_the_real_arm_variant_sets_every_imperfection_and_renames_the_runs():
    scenario = _variant()
    real = scenario.robot_imperfection
    assert scenario.name == "insertion_real_arm"
    assert real.model_differs and real.has_friction and real.senses_force
    np.testing.assert_array_equal(real.viscous_friction_Nms_per_rad, VISCOUS)
    np.testing.assert_array_equal(real.coulomb_friction_Nm, COULOMB)
    assert real.velocity_filter_hz == 40.0 and real.control_period_s == 0.001
    assert load_scenario("insertion")[0].robot_imperfection.perfect


def test_a_run_of_the_variant_reruns_from_its_record_with_the_variant_once(tmp_path):
    from hlcmp_drake.run.runner import scenario_record

    record = tmp_path / "scenario.yaml"
    record.write_text(scenario_record(_variant()))
    again = load_scenario(str(record), [], experiment_worlds(), "real_arm")[0]
    assert again.name == "insertion_real_arm"  # not insertion_real_arm_real_arm
    assert again.robot_imperfection == _variant().robot_imperfection


@pytest.mark.parametrize(
    "override, message",
    [
        ("robot_imperfection.coulomb_friction_Nm=[0.1, 0.1]", "needs none or 7 values"),
        ("robot_imperfection.control_period_s=0.0025", "a whole number of plant steps"),
        ("robot_imperfection.link_mass_error=-1", "must be a fraction of the mass from -0.5"),
        # 3 % typed as a percentage: the model's links 4 times as heavy as the arm's
        (
            "robot_imperfection.link_mass_error=3",
            r"^override 'robot_imperfection.link_mass_error=3': link_mass_error: must be a "
            r"fraction of the mass from -0.5 to 0.5 \(0.03 for 3 %\), got 3$",
        ),
        ("robot_imperfection.tool_mass_error=0.51", "from -0.5 to 0.5"),
        ("robot_imperfection.force_noise_N=[0.1, -0.1, 0.1]", "finite and >= 0"),
        ("task.control_path=modular", "the fast control path"),
    ],
)
def test_bad_values_are_refused_in_one_line(override, message):
    with pytest.raises(InputError, match=message) as error:
        _variant([override])
    assert "\n" not in str(error.value)


def test_a_slider_is_no_real_arm_and_a_bad_variant_file_names_its_line(tmp_path):
    with pytest.raises(InputError, match="applies to the arm scenarios only") as error:
        _variant(name="one_dof")
    assert str(error.value).endswith("not to a SliderTask")
    bad = tmp_path / "shaky.yaml"
    bad.write_text("robot_imperfection:\n  velocity_filter_hz: -3.0\n")
    with pytest.raises(InputError, match=rf"{bad}:2: velocity_filter_hz: must be finite"):
        load_scenario("insertion", [], None, bad)


# --- runs on the imperfect arm ----------------------------------------------------------------


def _run(scenario, controller="const_500"):
    built = arm.build(scenario, controller, arm.prepare(scenario))
    return built, simulate(built, scenario, controller)


def test_a_short_run_on_the_real_arm_is_reproducible_and_not_the_perfect_one():
    real_scenario = _variant(["duration_s=0.3"])
    built, first = _run(real_scenario)
    for name in ("joint_friction", "velocity_estimate", "sensed_force"):
        assert built.diagram.HasSubsystemNamed(name), name
    _, again = _run(_variant(["duration_s=0.3"]))
    perfect_scenario, _ = load_scenario("insertion", ["duration_s=0.3"])
    _, perfect = _run(perfect_scenario)
    assert first.status == again.status == perfect.status == "ok"
    for series in ("x", "f_ext", "plant_state"):
        np.testing.assert_array_equal(first.series[series], again.series[series])
    # the model set off sags the tool (gravity under-compensated)
    assert 1e-4 < np.abs(first.series["x"] - perfect.series["x"]).max() < 0.01
    # no contact yet: the logged (true) force is zero, the monitor reads the noisy sensor
    assert not np.any(first.series["f_ext"])
    simulator = Simulator(built.diagram)
    simulator.AdvanceTo(0.02)
    monitor = built.diagram.GetSubsystemByName("safety_monitor")
    read = monitor.GetInputPort("contact_force").Eval(
        monitor.GetMyContextFromRoot(simulator.get_context())
    )
    assert 0 < np.abs(read - [0.0, 0.0, -0.147]).max() < 2.0


def test_the_controller_reads_the_estimate_and_ticks_at_its_period(monkeypatch):
    ticks = []  # every tick's time, also those that take a logged result
    tick = ControlLoop._tick  # the update's handler is bound when the loop is made
    monkeypatch.setattr(
        ControlLoop, "_tick", lambda self, c, s: ticks.append(c.get_time()) or tick(self, c, s)
    )
    scenario = _variant(["duration_s=0.05", "robot_imperfection.control_period_s=0.005"])
    built = arm.build(scenario, "const_500", arm.prepare(scenario))
    loop = next(s for s in built.diagram.GetSystems() if isinstance(s, ControlLoop))
    simulator = Simulator(built.diagram)
    context = simulator.get_mutable_context()
    built.plant.SetPositions(
        built.plant.GetMyMutableContextFromRoot(context), built.initial_positions
    )
    simulator.AdvanceTo(0.0501)
    assert np.allclose(ticks, np.arange(11) * 0.005)  # t = 0, 5, ..., 50 ms
    read = loop.plant_state.Eval(loop.GetMyContextFromRoot(context))
    state = built.plant.get_state_output_port().Eval(built.plant.GetMyContextFromRoot(context))
    np.testing.assert_array_equal(read[:7], state[:7])
    assert np.abs(state[7:]).max() > 1e-3 and np.abs(read[7:] - state[7:]).max() > 1e-4


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "insertion", "--variant", "nope"],
        ["run", "one_dof", "--variant", "real_arm"],
        ["report", "--scenarios", "insertion", "--variants", "nope"],
    ],
)
def test_a_bad_variant_stops_the_command_in_one_line_before_any_run(argv, tmp_path, capfd):
    from hlcmp_drake.cli import main

    out = tmp_path / "out"
    assert main([*argv, "--out", str(out), "--quiet"]) == 2
    lines = capfd.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("hlcmp: error: "), lines
    assert not out.exists()
