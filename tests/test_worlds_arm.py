"""hlcmp_drake.worlds.arm: the start posture, and the two control paths (fast: ControlLoop,
the C++ DMP source and theta in an Integrator; modular: the systems port by port) giving the
same runs with far fewer Python calls."""

import numpy as np
import pytest
from pydrake.math import RotationMatrix

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.run.benchmark import count_python_calls
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.systems.control_loop import ControlLoop
from hlcmp_drake.worlds import arm
from hlcmp_drake.worlds.arm import solve_start_posture


def test_start_posture_puts_the_tool_at_the_demonstration_start_pointing_down(arm):
    np.testing.assert_allclose(arm.terms.position, arm.setup.dmp.start, atol=2e-4)
    np.testing.assert_allclose(arm.setup.tool_orientation.col(2), [0, 0, -1], atol=2e-3)


def _paths(scenario_name, controller, duration):
    """The same controller simulated on both paths: {path: RunResult}."""
    runs = {}
    for path in ("modular", "fast"):
        scenario, _ = load_scenario(
            scenario_name, [f"duration_s={duration}", f"task.control_path={path}"]
        )
        built = arm.build(scenario, controller, arm.prepare(scenario))
        runs[path] = simulate(built, scenario, controller)
    return runs


@pytest.mark.slow  # two 0.6 s insertion runs
def test_a_constant_impedance_runs_the_same_on_both_paths():
    runs = _paths("insertion", "const_500", 0.6)
    assert runs["fast"].status == runs["modular"].status == "ok"
    for series in ("x", "fc", "plant_state"):
        scale = max(1.0, np.abs(runs["modular"].series[series]).max())
        assert (
            np.abs(runs["fast"].series[series] - runs["modular"].series[series]).max()
            < 1e-6 * scale
        ), series


@pytest.mark.slow  # two 4.5 s insertion runs, through the contact and the pierce
def test_the_hlcmp_learns_the_same_on_both_paths():
    """θ's rate is sampled once per step on the fast path (explicit Euler at the step's
    start, as Table I); the modular path evaluates Eq. 31 at both RK2 stages after the
    plant's step. At the paper's Q (per second) the two agree closely."""
    runs = _paths("insertion", "hlcmp", 4.5)
    fast, modular = runs["fast"], runs["modular"]
    assert fast.status == modular.status == "ok"
    for k, (a, b) in enumerate(zip(fast.theta, modular.theta)):
        assert np.abs(b).max() > 0.1, "the run must have learned something to compare"
        assert np.abs(a - b).max() < 0.01 * np.abs(b).max(), f"theta[{k}]"
    assert np.abs(fast.series["x"] - modular.series["x"]).max() < 5e-5  # tip path within 0.05 mm
    assert (
        np.abs(fast.series["Ks"] - modular.series["Ks"]).max()
        < 0.01 * np.abs(modular.series["Ks"]).max()
    )


def test_the_fast_path_makes_at_most_four_python_calls_per_step():
    """Counted, not timed: the loop's tick, the foam's update and its tear hook each step,
    and the 100 Hz loggers and safety monitor."""
    scenario, _ = load_scenario("insertion", ["duration_s=0.3"])
    built = arm.build(scenario, "hlcmp", arm.prepare(scenario))
    assert isinstance(built.controller.system, ControlLoop)
    calls = count_python_calls(built, scenario)
    assert 1.0 <= calls <= 4.0
    modular, _ = load_scenario("insertion", ["duration_s=0.3", "task.control_path=modular"])
    assert (
        count_python_calls(arm.build(modular, "hlcmp", arm.prepare(modular)), modular) > 3 * calls
    )


def test_a_skill_of_the_wrong_size_is_refused_on_the_fast_path(insertion):
    scenario, setup = insertion
    wrong = tuple(np.zeros((3, 5)) for _ in range(3))  # N = 5, the scenario has 30
    with pytest.raises(ValueError, match="theta0 must hold 270 values, got 45"):
        arm.build(scenario, "hlcmp", setup, theta0=wrong)


def test_a_pose_demonstration_must_keep_the_tool_axis_the_arm_holds():
    """A translational skill follows positions only: a pose demonstration is accepted when
    its tool axis is task.tool_direction's, and refused at the first line that strays."""
    from hlcmp_drake.core.quaternion import from_rotation_vector, multiply
    from hlcmp_drake.io.demos import read_demonstration
    from hlcmp_drake.io.errors import InputError
    from hlcmp_drake.worlds.common import check_held_orientation

    scenario, _ = load_scenario("peg_in_hole")
    _, _, _, quaternions, lines = read_demonstration(
        scenario.reference.file, with_lines=True, with_orientation=True
    )
    check_held_orientation("demo.csv", quaternions, scenario.task.tool_direction, lines)
    tilted = quaternions.copy()
    tilted[40:] = multiply(from_rotation_vector(np.array([0.0, np.radians(2.0), 0.0])), tilted[40:])
    with pytest.raises(InputError, match=rf"demo.csv:{lines[40]}: the tool's \+z is 2.0 deg"):
        check_held_orientation("demo.csv", tilted, scenario.task.tool_direction, lines)


@pytest.mark.parametrize("orientation", [None, RotationMatrix()])
def test_a_start_out_of_reach_names_the_orientation_it_was_asked_for(orientation):
    scenario, _ = load_scenario("insertion")
    with pytest.raises(InputError) as error:
        solve_start_posture(scenario, [3.0, 0.0, 0.5], orientation)
    message = str(error.value)
    assert message.startswith("inverse kinematics found no posture with the tool at [3.  0.  0.5]")
    if orientation is None:  # the task's tool direction, free about it
        assert f"pointing along {scenario.task.tool_direction} (orientation free" in message
    else:
        assert (
            "turned as the demonstration's first orientation (rpy [0.0, 0.0, 0.0] rad)" in message
        )
    # Reach is one reason; an orientation the solver does not find from its seed is another.
    assert message.endswith("a seed nearer such a posture may find one")
