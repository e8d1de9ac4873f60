"""hlcmp_drake.systems.arm_tick: the arm's tick in two compiled calls gives what ControlTick
gives through the laws' shared interface, for the Hl-CMP, the Hl-CMP with forgetting and
the constant impedance, on both kernel paths; it is chosen only where it applies."""

import dataclasses as dc

import numpy as np
import pytest
from conftest import arm_tick_inputs, assert_held_command_is_evaluates
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.scenario import HlcmpForgettingConfig
from hlcmp_drake.core.kernels import kernel_chosen, numba_available
from hlcmp_drake.core.laws import VariableImpedanceLaw
from hlcmp_drake.systems.arm_tick import FusedArmTick, arm_control_tick
from hlcmp_drake.systems.control_loop import ControlTick
from hlcmp_drake.systems.task_space import TaskSpaceModel
from hlcmp_drake.worlds.arm import arm_tick
from hlcmp_drake.worlds.controllers import hlcmp_forgetting_law
from hlcmp_drake.worlds.models import add_plant, scoped_frame

PATHS = [
    "numpy",
    pytest.param(
        "compiled", marks=pytest.mark.skipif(not numba_available(), reason="numba is not installed")
    ),
]


@pytest.fixture(scope="module")
def plant(insertion):
    scenario, _ = insertion
    return add_plant(DiagramBuilder(), scenario)[0]


def _fused_and_shared(insertion, plant, name, path):
    """The insertion's tick for controller `name` as `arm_tick` makes it (fused), and a
    ControlTick of the same model, torque below the task and law."""
    scenario, setup = insertion
    with kernel_chosen(path):
        fused = arm_tick(scenario, name, plant=plant, setup=setup)
        shared = ControlTick(fused.model, fused.below_task, fused.law, fused.effort_limits)
    return fused, shared


def _forgetting(fused, insertion, plant, path):
    """The same tick with the Hl-CMP's law given a forgetting factor."""
    scenario, _ = insertion
    config = HlcmpForgettingConfig(**dc.asdict(scenario.controllers["hlcmp"]), forgetting_per_s=0.7)
    with kernel_chosen(path):
        law = hlcmp_forgetting_law(config, scenario)
        return (
            FusedArmTick(fused.model, fused.below_task, law, fused.effort_limits),
            ControlTick(fused.model, fused.below_task, law, fused.effort_limits),
        )


def _pairs(a, b):
    pairs = [("torque", a.torque, b.torque), ("f_c", a.law.force, b.law.force)]
    pairs += [(key, a.law.logs[key], b.law.logs[key]) for key in b.law.logs]
    if b.law.rates is not None:
        pairs.append(("θ'", a.law.rates, b.law.rates))
    for field in ("position", "velocity", "jacobian", "inertia", "gravity", "null_space"):
        pairs.append((field, getattr(a.terms, field), getattr(b.terms, field)))
    pairs += [("joint_gravity", a.terms.joint_gravity, b.terms.joint_gravity)]
    pairs += [("rotation", a.terms.rotation, b.terms.rotation)]
    pairs += [("J_w", a.terms.angular_jacobian, b.terms.angular_jacobian)]
    pairs += [("C_x x_e'", a.terms.coriolis @ a.law.force, b.terms.coriolis @ b.law.force)]
    return pairs


def _assert_agree(a, b):
    """Each equal to 1e-12 of its own scale (both run the same equations; compiled into
    one function, numba may order a sum differently: a few 1e-15 seen)."""
    assert a.saturated == b.saturated
    assert (a.law.rates is None) == (b.law.rates is None)
    assert a.law.logs.keys() == b.law.logs.keys()
    for what, got, expected in _pairs(a, b):
        scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale, err_msg=what)


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("name", ["hlcmp", "const_500", "forgetting"])
def test_the_fused_tick_gives_the_shared_interfaces_numbers(insertion, plant, name, path):
    fused, shared = _fused_and_shared(
        insertion, plant, "const_500" if name == "const_500" else "hlcmp", path
    )
    if name == "forgetting":
        fused, shared = _forgetting(fused, insertion, plant, path)
    assert isinstance(fused, FusedArmTick) and fused.kernel == shared.kernel == path
    for seed in range(10):
        state, reference, theta = arm_tick_inputs(insertion[1], shared.law, seed)
        a = fused.evaluate(state, reference, theta)
        b = shared.evaluate(state, reference, theta)
        _assert_agree(a, b)
        assert_held_command_is_evaluates(fused, a, state, reference, theta)
        assert_held_command_is_evaluates(shared, b, state, reference, theta)
        row = shared.log_row(b)
        scale = max(1.0, float(np.max(np.abs(row))))
        np.testing.assert_allclose(fused.log_row(a), row, rtol=0, atol=1e-12 * scale)


def test_the_comparison_sees_a_changed_weight(insertion, plant):
    """The agreement check fails where one side's θ differs by a part in 1e9."""
    fused, shared = _fused_and_shared(insertion, plant, "hlcmp", "numpy")
    state, reference, theta = arm_tick_inputs(insertion[1], shared.law, 0)
    a = fused.evaluate(state, reference, theta * (1 + 1e-9))
    with pytest.raises(AssertionError):
        _assert_agree(a, shared.evaluate(state, reference, theta))


def test_the_fused_tick_is_chosen_only_where_it_applies(insertion, plant):
    scenario, setup = insertion
    fused, _ = _fused_and_shared(insertion, plant, "hlcmp", "numpy")
    tip = scoped_frame(plant, scenario.task.tool_frame)
    apart = TaskSpaceModel(plant, tip, axes=(0, 2))  # not consecutive: no single row range
    assert apart.first_translational_row is None
    made = arm_control_tick(apart, fused.below_task, fused.law, fused.effort_limits)
    assert type(made) is ControlTick
    without_below = arm_control_tick(fused.model, None, fused.law, fused.effort_limits)
    assert type(without_below) is ControlTick
    variable = VariableImpedanceLaw.__new__(VariableImpedanceLaw)  # its type is what counts
    assert (
        type(arm_control_tick(fused.model, fused.below_task, variable, fused.effort_limits))
        is ControlTick
    )
    with pytest.raises(ValueError, match="FusedArmTick takes"):
        FusedArmTick(apart, fused.below_task, fused.law, fused.effort_limits)
