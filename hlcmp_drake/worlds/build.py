"""The world registry: a scenario's task type -> its world kind, and diagrams built from it
once per controller.

Adding a world kind: its task config in `hlcmp_drake.config.scenario` (owning its checks,
`check_scenario`, and its axis count, `axis_count`; and in the Scenario's task Union), one
module in this folder with its `prepare` and `build` (and, for an arm an iiwa driver can
drive, `build_driven`; for a world the probe can measure, a probe builder), and one entry
in WORLDS.
"""

from __future__ import annotations

import dataclasses as dc
from typing import Any, Callable

from hlcmp_drake.config.loading import check_scenario
from hlcmp_drake.config.scenario import ArmTask, Scenario, SliderTask
from hlcmp_drake.config.validation import ReplayProblem
from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.core.orientation_dmp import OrientationDmp
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.worlds import arm, probe, slider
from hlcmp_drake.worlds.common import BuiltDiagram
from hlcmp_drake.worlds.controllers import Theta


@dc.dataclass(frozen=True)
class World:
    """What a world kind offers the runs, the iiwa driver and the probe.

    Attributes
    ----------
    name : str
        How messages name it ("slider", "arm").
    prepare : callable(scenario, dmp, orientation_dmp) -> setup
        The work every controller's diagram shares (for an arm: the DMP fits, unless the
        DMPs are given, and the start posture); its result is `build`'s `setup`.
    build : callable(scenario, controller_name, setup, theta0) -> BuiltDiagram
        One controller's diagram: the world, the controller and the harness.
    build_driven : callable(scenario, setup, *, add_driver=None) -> BuiltDiagram, optional
        The world with its joints' torques left open for an external driver (`hlcmp
        sim-driver`), or taken by the driver systems `add_driver(builder, plant)` adds;
        None for a world with no arm to drive.
    build_probe : callable(scenario, speed, tilt_rad) -> ProbeWorld, optional
        The world measured alone, the tool on a carriage (`hlcmp probe`); None for a world
        without a probe.
    """

    name: str
    prepare: Callable[[Scenario, Dmp | None, OrientationDmp | None], Any]
    build: Callable[[Scenario, str, Any, Theta | None], BuiltDiagram]
    build_driven: Callable[..., BuiltDiagram] | None = None
    build_probe: Callable[..., probe.ProbeWorld] | None = None


WORLDS: dict[type, World] = {
    SliderTask: World("slider", slider.prepare, slider.build),
    ArmTask: World("arm", arm.prepare, arm.build, arm.build_driven, probe.build_probe),
}


def world_of(scenario: Scenario) -> World:
    """The world kind of the scenario's task.

    Parameters
    ----------
    scenario : Scenario
        Its task's type picks the entry of WORLDS.

    Returns
    -------
    World
    """
    return WORLDS[type(scenario.task)]


def driven_world_of(scenario: Scenario, who: str) -> World:
    """The scenario's world kind, which must have an arm an iiwa driver can drive.

    Parameters
    ----------
    scenario : Scenario
    who : str
        What needs the arm, for the message (e.g. "hlcmp serve drives an iiwa").

    Returns
    -------
    World
        With `build_driven`.

    Raises
    ------
    InputError
        For a world without an arm to drive, or with a robot's imperfections set (those
        are simulated runs' only: a driven arm has its own).
    """
    world = world_of(scenario)
    if world.build_driven is None:
        raise InputError(
            f"scenario '{scenario.name}' has no arm: {who}, use an arm scenario such as "
            "insertion or cutting"
        )
    if not scenario.robot_imperfection.perfect:
        raise InputError(
            f"robot_imperfection is set: {who} as its model is (a served run meets a real "
            "arm's own imperfections); simulated ones are for hlcmp run and report "
            "(--variant real_arm)"
        )
    return world


def diagram_factory(
    scenario: Scenario,
    dmp: Dmp | None = None,
    orientation_dmp: OrientationDmp | None = None,
    replay_problem: ReplayProblem | None = None,
) -> Callable[..., BuiltDiagram]:
    """A builder of the scenario's diagrams, one per controller.

    The work all controllers share (for an arm: fitting the DMPs unless they are given,
    and the inverse kinematics of the start posture) is done once, here.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.
    dmp : Dmp, optional
        The arm's DMP (e.g. a saved skill's); None: fitted to the demonstration. The
        slider world ignores it.
    orientation_dmp : OrientationDmp, optional
        The arm's orientation DMP (a 6-D skill's); None: fitted to the demonstration when
        it is a pose. The slider world ignores it.
    replay_problem : callable(duration_s) -> str or None, optional
        With a DMP that is not the scenario's demonstration (a skill's, or one fitted to
        learn's own demonstration): what replaying it in `reference.duration_s` does
        wrong, as `load_scenario` checked it (default: the demonstration file's replay).

    Returns
    -------
    callable(name, theta0=None) -> BuiltDiagram
        Builds a fresh diagram for the controller labelled `name`, a learner starting from
        `theta0` (as `worlds.controllers.initial_theta` takes it) when given; a label the
        scenario does not have is an InputError that lists the labels it has.

    Raises
    ------
    InputError
        For a value `load_scenario` would refuse (`check_scenario`: the scenario may have
        been changed in Python since it was loaded), or from the world's preparation (the
        demonstration, the models, the inverse kinematics).
    """
    check_scenario(scenario, replay_problem)
    world = world_of(scenario)
    setup = world.prepare(scenario, dmp, orientation_dmp)

    def build(name: str, theta0: Theta | None = None) -> BuiltDiagram:
        if name not in scenario.controllers:
            raise InputError(
                f"no controller '{name}' (the scenario has: {', '.join(scenario.controllers)})"
            )
        return world.build(scenario, name, setup, theta0=theta0)

    return build
