"""hlcmp_drake.config.variants: the drake_models iiwa variant swaps the arm and the flange weld."""

from hlcmp_drake.config.loading import load_scenario


def test_drake_models_variant_swaps_the_arm_and_the_flange_weld():
    from hlcmp_drake.config.variants import DRAKE_MODELS_IIWA, use_drake_models_iiwa

    scenario, _ = load_scenario("insertion")
    variant = use_drake_models_iiwa(scenario)
    files = [d.add_model.file for d in variant.directives if d.add_model is not None]
    assert DRAKE_MODELS_IIWA in files and not any("hlcmp_drake/models/iiwa14" in f for f in files)
    weld = next(
        d.add_weld
        for d in variant.directives
        if d.add_weld is not None and d.add_weld.child == "insertion_tool::mount"
    )
    assert weld.parent == "iiwa::iiwa_link_7"
    assert list(weld.X_PC.GetDeterministicValue().translation()) == [0.0, 0.0, 0.045]
    assert len(variant.directives) == len(scenario.directives)


def test_a_scenario_without_our_iiwa_is_refused():
    import pytest

    from hlcmp_drake.config.variants import use_drake_models_iiwa
    from hlcmp_drake.io.errors import InputError

    with pytest.raises(InputError, match=r"only applies to arm scenarios .* 'one_dof' has no iiwa"):
        use_drake_models_iiwa(load_scenario("one_dof")[0])


def test_what_a_variant_changes_is_its_dotted_keys(tmp_path):
    """The report says what a variant changes: the real arm's robot only; a file of one's
    own that sets a controller's gains and the task, those keys (the name aside)."""
    from hlcmp_drake.config.variants import changed_keys

    scenario, _ = load_scenario("insertion")
    real_arm = changed_keys(scenario, load_scenario("insertion", variant="real_arm")[0])
    assert real_arm and all(key.startswith("robot_imperfection.") for key in real_arm)
    gains = tmp_path / "gains.yaml"
    gains.write_text(
        "controllers:\n  const_500: !ConstantImpedanceConfig\n"
        "    stiffness_N_per_m: [5.0, 5.0, 5.0]\n    damping_Ns_per_m: [90.0, 90.0, 90.0]\n"
        "    pi: 5.0\n    gain_l: [10.0, 10.0, 10.0]\n"
        "task: !ArmTask\n  max_contact_force_N: 5.0\n"
    )
    varied = load_scenario("insertion", variant=gains)[0]
    assert changed_keys(scenario, varied) == [
        "controllers.const_500.stiffness_N_per_m",
        "task.max_contact_force_N",
    ]
    assert changed_keys(scenario, scenario) == []
