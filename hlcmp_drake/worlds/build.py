"""From a scenario to diagrams: the world kind its task names, built once per controller."""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

from hlcmp_drake.config.scenario import ArmTask, Scenario, SliderTask
from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.worlds import arm, slider
from hlcmp_drake.worlds.common import BuiltDiagram

if TYPE_CHECKING:
    from types import ModuleType

# A scenario's task type -> the module that builds its world (prepare, build).
# Adding a world kind: its task config and one module.
WORLDS = {SliderTask: slider, ArmTask: arm}


def world_of(scenario: Scenario) -> ModuleType:
    """The world module for the scenario's task.

    Parameters
    ----------
    scenario : Scenario
        Its task's type (SliderTask, ArmTask) picks the module in WORLDS.

    Returns
    -------
    module
        `hlcmp_drake.worlds.slider` or `hlcmp_drake.worlds.arm`: its `prepare` and `build`.
    """
    return WORLDS[type(scenario.task)]


def diagram_factory(scenario: Scenario, dmp: Dmp | None = None) -> Callable[..., BuiltDiagram]:
    """A builder of the scenario's diagrams, one per controller.

    The work all controllers share (for an arm: fitting the DMP unless `dmp` is given, and
    the inverse kinematics of the start posture) is done once, here.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.
    dmp : Dmp, optional
        The arm's DMP (e.g. a saved skill's); None: fitted to the demonstration. The
        slider world ignores it.

    Returns
    -------
    callable(name, theta0=None) -> BuiltDiagram
        Builds a fresh diagram for the controller labelled `name`, a learner starting from
        `theta0` (three (M, N) arrays) when given.

    Raises
    ------
    InputError
        From the world's preparation (the demonstration, the models, the inverse kinematics).
    """
    world = world_of(scenario)
    setup = world.prepare(scenario, dmp)
    return lambda name, theta0=None: world.build(scenario, name, setup, theta0)
