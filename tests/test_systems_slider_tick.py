"""hlcmp_drake.systems.slider_tick: the slider's tick in one compiled call gives what
ControlTick gives through the laws' shared interface, for every controller of the 1-DOF
world and the Hl-CMP with forgetting, on both kernel paths; it is chosen only where it
applies."""

import dataclasses as dc

import numpy as np
import pytest
from conftest import assert_held_command_is_evaluates
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import HlcmpForgettingConfig
from hlcmp_drake.core.kernels import kernel_chosen, numba_available
from hlcmp_drake.core.laws import ConstantImpedanceLaw
from hlcmp_drake.systems.control_loop import ControlTick
from hlcmp_drake.systems.slider_tick import FusedSliderTick, slider_control_tick
from hlcmp_drake.worlds.controllers import hlcmp_forgetting_law
from hlcmp_drake.worlds.models import add_plant
from hlcmp_drake.worlds.slider import slider_tick

PATHS = [
    "numpy",
    pytest.param(
        "compiled", marks=pytest.mark.skipif(not numba_available(), reason="numba is not installed")
    ),
]
CONTROLLERS = ["hlcmp", "hlcmp_per_step", "vic_fd_0.5", "vic_fd_5.0", "const", "forgetting"]


@pytest.fixture(scope="module")
def one_dof():
    scenario, _ = load_scenario("one_dof")
    return scenario, add_plant(DiagramBuilder(), scenario)[0]


def _ticks(one_dof, name, path):
    """The slider's tick for `name` as `slider_tick` makes it, and a ControlTick of the same
    model and law. "const" is a constant impedance from the Hl-CMP's gains (the bundled
    1-DOF world has none), "forgetting" the Hl-CMP with a forgetting factor."""
    scenario, plant = one_dof
    with kernel_chosen(path):
        fused = slider_tick(
            scenario, "hlcmp" if name in ("const", "forgetting") else name, plant=plant
        )
        law = fused.law
        if name == "forgetting":
            config = HlcmpForgettingConfig(
                **dc.asdict(scenario.controllers["hlcmp"]), forgetting_per_s=0.7
            )
            law = hlcmp_forgetting_law(config, scenario)
        elif name == "const":
            law = ConstantImpedanceLaw(
                np.array([400.0]), np.array([40.0]), law.gains.pi, law.gains.gain_l
            )
        fused = slider_control_tick(fused.model, law, fused.effort_limits)
        shared = ControlTick(fused.model, None, law, fused.effort_limits)
    return fused, shared


def _inputs(law, seed):
    rng = np.random.default_rng(seed)
    theta = (
        rng.uniform(0, 300, law.theta_size) if law.learns else rng.normal(0, 0.1, law.theta_size)
    )
    return (
        rng.normal(0, 0.1, 2),
        tuple(rng.normal(0, scale, 1) for scale in (0.1, 0.1, 1.0)) + (rng.uniform(size=1),),
        theta if law.theta_size else None,
        dict(time=float(rng.uniform(0, 20)), external_force=rng.normal(0, 5, 1)),
    )


def _assert_agree(fused, shared, a, b):
    """Torque, saturation, f_c, every series, θ' and the log row, each within 1e-12 of its
    scale (in practice to the bit: the same operations)."""
    assert a.saturated == b.saturated
    assert (a.law.rates is None) == (b.law.rates is None)
    assert a.law.logs.keys() == b.law.logs.keys()
    pairs = [("torque", a.torque, b.torque), ("f_c", a.law.force, b.law.force)]
    pairs += [(key, a.law.logs[key], b.law.logs[key]) for key in b.law.logs]
    if b.law.rates is not None:
        pairs.append(("θ'", a.law.rates, b.law.rates))
    pairs.append(("log row", fused.log_row(a), shared.log_row(b)))
    for what, got, expected in pairs:
        scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale, err_msg=what)


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("name", CONTROLLERS)
def test_the_fused_slider_tick_gives_the_shared_interfaces_numbers(one_dof, name, path):
    fused, shared = _ticks(one_dof, name, path)
    assert isinstance(fused, FusedSliderTick) and fused.kernel == shared.kernel == path
    for seed in range(20):
        state, reference, theta, extra = _inputs(shared.law, seed)
        a = fused.evaluate(state, reference, theta, **extra)
        b = shared.evaluate(state, reference, theta, **extra)
        _assert_agree(fused, shared, a, b)
        assert_held_command_is_evaluates(fused, a, state, reference, theta, **extra)
        assert_held_command_is_evaluates(shared, b, state, reference, theta, **extra)


def test_the_comparison_sees_a_changed_input(one_dof):
    """The agreement check fails where one side's measured force differs by a part in 1e9."""
    fused, shared = _ticks(one_dof, "vic_fd_5.0", "numpy")
    state, reference, theta, extra = _inputs(shared.law, 0)
    moved = dict(extra, external_force=extra["external_force"] * (1 + 1e-9))
    with pytest.raises(AssertionError):
        _assert_agree(
            fused,
            shared,
            fused.evaluate(state, reference, theta, **moved),
            shared.evaluate(state, reference, theta, **extra),
        )


def test_another_law_gets_the_shared_tick_and_the_fused_one_refuses_it(one_dof):
    fused, _ = _ticks(one_dof, "hlcmp", "numpy")

    class AnotherLaw:
        """A law of the ControlLaw shape that the fused tick does not know."""

        learns, reads_external_force, log_fields, n_axes, theta_size = False, False, {}, 1, 0

    made = slider_control_tick(fused.model, AnotherLaw(), fused.effort_limits)
    assert type(made) is ControlTick
    with pytest.raises(ValueError, match="FusedSliderTick takes"):
        FusedSliderTick(fused.model, AnotherLaw(), fused.effort_limits)
