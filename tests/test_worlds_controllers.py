"""hlcmp_drake.worlds.controllers: a controller is built by its config kind, whatever its label."""

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.systems.baselines import ConstantImpedanceController
from hlcmp_drake.worlds.build import diagram_factory


def test_a_new_label_builds_its_controller_by_kind():
    scenario, _ = load_scenario(
        "one_dof",
        [
            "controllers.soft=!ConstantImpedanceConfig {stiffness_N_per_m: [100], "
            "damping_Ns_per_m: [20], gain_l: [10]}"
        ],
    )
    built = diagram_factory(scenario)("soft")
    assert isinstance(built.controller.system, ConstantImpedanceController)
    assert built.controller.system.get_name() == "soft" and built.controller.read_theta is None
    assert "Ks" not in built.loggers  # only a learning controller logs its profiles
