"""hlcmp_drake.systems.pose_control: the 6-D tick's arithmetic compiled by numba agrees with
its numpy path at the states of a short peg-in-hole run, and the tick refuses a torque below
the task of another frame than its model's."""

from functools import partial

import numpy as np
import pytest
from conftest import assert_held_command_is_evaluates

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core.kernels import kernel_chosen, numba_available
from hlcmp_drake.run.benchmark import _control_plant, _reference_along
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.systems.arm import BelowTaskImpedance
from hlcmp_drake.systems.pose_control import PoseControlTick
from hlcmp_drake.systems.spatial_task_space import SpatialTaskSpaceModel
from hlcmp_drake.worlds import arm
from hlcmp_drake.worlds.controllers import initial_theta
from hlcmp_drake.worlds.models import scoped_frame
from hlcmp_drake.worlds.pose import add_pose_reference, pose_tick

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba is not installed")


@pytest.fixture(scope="module")
def peg():
    """The peg-in-hole scenario, its ArmSetup, a control-side plant, and the plant states
    and 6-D references every 10 ms of a 0.5 s run of its 6-D Hl-CMP."""
    scenario, _ = load_scenario(
        "peg_in_hole", ["duration_s=0.5", "log_period_s=0.01", "task.control_path=fast"]
    )
    setup = arm.prepare(scenario)
    with kernel_chosen("numpy"):  # the states only: nothing to compile
        run = simulate(arm.build(scenario, "hlcmp_6d", setup), scenario, "hlcmp_6d")
    references = _reference_along(
        partial(add_pose_reference, scenario=scenario, setup=setup), scenario, run.t
    )
    return (
        scenario,
        setup,
        _control_plant(scenario),
        list(zip(run.series["plant_state"], references)),
    )


def _ticks_on_both_paths(peg, name):
    scenario, setup, plant, _ = peg
    made = {}
    for path in ("compiled", "numpy"):
        with kernel_chosen(path):
            made[path] = pose_tick(scenario, name, plant=plant, setup=setup)
        assert made[path].kernel == path
    return made["compiled"], made["numpy"]


def _pairs(a, b):
    """What the two ticks give: torque, wrench, the law's series, θ' and the 6-D terms."""
    pairs = [("torque", a.torque, b.torque), ("wrench", a.law.force, b.law.force)]
    pairs += [(key, a.law.logs[key], b.law.logs[key]) for key in b.law.logs]
    if b.law.rates is not None:
        pairs.append(("θ'", a.law.rates, b.law.rates))
    for field in ("position", "orientation", "spatial_velocity", "inertia", "gravity"):
        pairs.append((field, getattr(a.terms, field), getattr(b.terms, field)))
    pairs.append(("null_space", a.terms.null_space, b.terms.null_space))
    return pairs


def _assert_agree(pairs):
    """Each equal to 1e-12 of its own scale: absolute, 1e-12 times the numpy value's largest
    magnitude (at least 1)."""
    for what, got, expected in pairs:
        scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * scale, err_msg=what)


def _theta(peg, tick, seed):
    """The configured θ(0) with every weight moved, so that each profile and v_r is in
    play (None for a law without θ)."""
    scenario = peg[0]
    if tick.law.theta_size == 0:
        return None
    start = initial_theta(scenario.controllers["hlcmp_6d"], scenario)
    rng = np.random.default_rng(seed)
    return start * rng.uniform(0.5, 1.5, start.shape) + rng.normal(0, 5.0, start.shape)


@needs_numba
@pytest.mark.parametrize("name", ["hlcmp_6d", "const_6d_stiff"])
def test_compiled_pose_tick_agrees_with_numpy_along_a_peg_run(peg, name):
    compiled, numpy_path = _ticks_on_both_paths(peg, name)
    for k, (state, reference) in enumerate(peg[3]):
        theta = _theta(peg, numpy_path, k)
        a = compiled.evaluate(state, reference, theta)
        b = numpy_path.evaluate(state, reference, theta)
        assert a.saturated == b.saturated
        assert (a.law.rates is None) == (b.law.rates is None) == (name != "hlcmp_6d")
        assert a.law.logs.keys() == b.law.logs.keys()
        _assert_agree(_pairs(a, b))
        assert_held_command_is_evaluates(compiled, a, state, reference, theta)


@needs_numba
def test_the_comparison_sees_a_wrong_kernel(peg):
    """The agreement check fails where one path's θ differs by a part in 1e9."""
    compiled, numpy_path = _ticks_on_both_paths(peg, "hlcmp_6d")
    state, reference = peg[3][-1]
    theta = _theta(peg, numpy_path, 0)
    a = compiled.evaluate(state, reference, theta * (1 + 1e-9))
    b = numpy_path.evaluate(state, reference, theta)
    with pytest.raises(AssertionError):
        _assert_agree(_pairs(a, b))


def test_a_torque_below_the_task_of_another_frame_is_refused(peg):
    scenario, setup, plant, _ = peg
    model = SpatialTaskSpaceModel(plant, scoped_frame(plant, scenario.task.tool_frame))
    elsewhere = plant.GetFrameByName("iiwa_link_5")
    below = BelowTaskImpedance(plant, elsewhere, setup.tool_orientation, setup.q0, 0, 0, 1, 1)
    tick = pose_tick(scenario, "hlcmp_6d", plant=plant, setup=setup)
    with pytest.raises(ValueError, match="must be one frame"):
        PoseControlTick(model, below, tick.law, tick.effort_limits)
