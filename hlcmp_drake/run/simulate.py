"""Run one built diagram and read its loggers back as arrays."""

from __future__ import annotations

import time
from typing import Callable

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import EventStatus

from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.present.recording import LiveView
from hlcmp_drake.worlds.common import BuiltDiagram


def simulate(built: BuiltDiagram, scenario: Scenario, controller_name: str,
             progress: Callable | None = None, live: LiveView | None = None) -> RunResult:
    """Simulate `built` for scenario.duration_s and read its loggers back.

    A monitor checks every step that the plant state is finite, its positions stay within
    scenario.max_abs_position_m, and whatever `built.monitor` checks for its world (e.g.
    the contact force); otherwise the run stops at once
    with status "unstable", and the logs up to that moment are kept.

    Parameters
    ----------
    built : BuiltDiagram
        A diagram of one controller in its world (from `diagram_factory`).
    scenario : Scenario
        Its simulator config, duration and position bound.
    controller_name : str
        The label the RunResult gets.
    progress : callable(label, t, duration, wall_s), optional
        Called about once a wall-clock second.
    live : LiveView, optional
        Draws the run in a live Meshcat while it simulates (`hlcmp run --meshcat`).

    Returns
    -------
    RunResult
        The logs on their common time base [s], the status, and a learner's final theta.
    """
    simulator = Simulator(built.diagram)
    ApplySimulatorConfig(scenario.simulator_config, simulator)
    context = simulator.get_mutable_context()
    plant_context = built.plant.GetMyContextFromRoot(context)
    if built.initial_positions is not None:
        built.plant.SetPositions(plant_context, built.initial_positions)
    trouble = {}
    wall_start = time.perf_counter()
    last_report = [wall_start]

    def monitor(root_context):
        if live is not None:   # throttled to the view's frame rate by the wall clock
            live.show(controller_name, root_context.get_time(), built.plant.GetPositions(plant_context))
        if progress is not None and time.perf_counter() - last_report[0] > 1.0:
            last_report[0] = time.perf_counter()
            progress(controller_name, root_context.get_time(), scenario.duration_s,
                     last_report[0] - wall_start)
        state = built.plant.GetPositionsAndVelocities(plant_context)
        problem = None
        if not np.all(np.isfinite(state)):
            problem = "plant state is not finite"
        elif np.max(np.abs(state[: built.plant.num_positions()])) > scenario.max_abs_position_m:
            problem = f"a joint position beyond {scenario.max_abs_position_m} m/rad"
        elif built.monitor is not None:
            problem = built.monitor(root_context)
        if problem:
            trouble.update(reason=problem, time=root_context.get_time())
            return EventStatus.ReachedTermination(built.diagram, problem)
        return EventStatus.DidNothing()

    simulator.set_monitor(monitor)
    simulator.Initialize()
    try:
        simulator.AdvanceTo(scenario.duration_s)
    except RuntimeError as error:  # e.g. the integrator failing on a diverging state
        trouble.setdefault("reason", " ".join(str(error).split())[:300])
        trouble.setdefault("time", context.get_time())
    if live is not None:   # the run's last state, whatever the view's frame rate skipped
        live.show(controller_name, context.get_time(), built.plant.GetPositions(plant_context), final=True)
    series, t = {}, None
    for name, logger in built.loggers.items():
        log = logger.FindLog(context)
        t = log.sample_times() if t is None else t
        series[name] = log.data().T.copy()
    theta = built.controller.read_theta(context) if built.controller.read_theta else None
    if trouble:
        return RunResult(controller_name, t, series, "unstable", trouble["reason"], trouble["time"], theta)
    return RunResult(controller_name, t, series, theta=theta)
