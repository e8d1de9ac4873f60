"""hlcmp_drake.worlds.controllers: a controller is built by its config kind, whatever its label;
the forgetting learner is a kind of its own."""

import numpy as np
import pytest

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core.laws import ConstantImpedanceLaw
from hlcmp_drake.systems.control_loop import ControlLoop
from hlcmp_drake.systems.law_controller import LawController
from hlcmp_drake.worlds.build import diagram_factory


@pytest.mark.parametrize("path, system_type", [("modular", LawController), ("fast", ControlLoop)])
def test_a_new_label_builds_its_controller_by_kind(path, system_type):
    scenario, _ = load_scenario(
        "one_dof",
        [
            f"task.control_path={path}",
            "controllers.soft=!ConstantImpedanceConfig {stiffness_N_per_m: [100], "
            "damping_Ns_per_m: [20], gain_l: [10]}",
        ],
    )
    built = diagram_factory(scenario)("soft")
    system = built.controller.system
    assert isinstance(system, system_type)
    assert isinstance(system.law, ConstantImpedanceLaw)
    assert system.get_name() == "soft" and built.controller.read_theta is None
    assert "Ks" not in built.loggers  # only a learning controller logs its profiles


FORGETTING = (
    "controllers.forgetting=!HlcmpForgettingConfig {q_k: [2000.0], q_d: [500.0], q_v: [0.0], "
    "pi: 5.0, gain_l: [10.0], forgetting_per_s: %s}"
)


def test_a_forgetting_learner_with_gamma_zero_runs_exactly_as_the_hlcmp():
    from hlcmp_drake.run.runner import run_controllers

    scenario, _ = load_scenario("one_dof", ["duration_s=1.0", FORGETTING % 0.0])
    scenario.controllers = {n: scenario.controllers[n] for n in ("hlcmp", "forgetting")}
    runs = run_controllers(scenario)
    for series in ("x", "fc", "Ks", "Kd", "v", "eps"):
        np.testing.assert_array_equal(
            runs["forgetting"].series[series], runs["hlcmp"].series[series]
        )
    assert runs["hlcmp"].series["Ks"].max() > 1.0  # it did learn


def test_a_forgetting_learner_counts_as_a_learner_and_freezes():
    from hlcmp_drake.worlds.controllers import controller_kind, learners

    scenario, _ = load_scenario("one_dof", [FORGETTING % 0.5])
    assert learners(scenario) == ["hlcmp", "hlcmp_per_step", "forgetting"]
    frozen = controller_kind(scenario, "forgetting").frozen(scenario.controllers["forgetting"])
    assert frozen.q_k == [0.0] and frozen.forgetting_per_s == 0.0


def test_forgetting_decays_the_stiffness_where_the_error_vanishes():
    from pydrake.systems.analysis import Simulator

    from hlcmp_drake.core.dmp import basis_centers_and_widths
    from hlcmp_drake.core.laws import HlcmpForgettingLaw, HlcmpGains, HlcmpLaw

    centers, widths = basis_centers_and_widths(4, 4.0)
    gains = HlcmpGains(np.array([3000.0]), np.array([90.0]), np.array([9.0]), 2.0, np.array([3.0]))
    theta0 = np.full(3 * 4, 40.0)
    stiffness = {}
    for gamma in (0.0, 0.5):
        law = (
            HlcmpForgettingLaw(centers, widths, gains, gamma)
            if gamma
            else HlcmpLaw(centers, widths, gains)
        )
        controller = LawController(law, theta0)
        context = controller.CreateDefaultContext()
        # Perfect tracking: x = x_d and x' = x_d', so Eq. 31's increment is zero.
        for port, value in dict(
            position=[0.1],
            velocity=[0.0],
            desired_position=[0.1],
            desired_velocity=[0.0],
            desired_acceleration=[0.0],
            phase=[0.5],
            task_inertia=[2.0],
            task_coriolis=[0.0],
            task_gravity=[0.0],
        ).items():
            controller.GetInputPort(port).FixValue(context, value)
        simulator = Simulator(controller, context)
        simulator.AdvanceTo(2.0)
        stiffness[gamma] = controller.GetOutputPort("stiffness").Eval(context)[0]
    assert stiffness[0.0] == pytest.approx(40.0)  # the paper's law holds θ without error
    assert stiffness[0.5] == pytest.approx(40.0 * np.exp(-0.5 * 2.0), rel=1e-4)
