"""Run one built diagram and read its loggers back as arrays."""

from __future__ import annotations

import time
from typing import Callable

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorStatus
from pydrake.systems.framework import EventStatus

from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.present.recording import LiveView
from hlcmp_drake.worlds.common import BuiltDiagram

# The run advances in chunks of this many simulated seconds, between which it reports
# progress and draws the live view: nothing of the run's own runs in Python per step.
CHUNK_S = 0.02


def prepared_simulator(built: BuiltDiagram, scenario: Scenario) -> Simulator:
    """A fresh Simulator of `built`, set up as a run needs it: the scenario's simulator
    config, the start posture and the world's after-step hook.

    Parameters
    ----------
    built : BuiltDiagram
    scenario : Scenario
        Its simulator config.

    Returns
    -------
    Simulator
        Not yet initialized.
    """
    simulator = Simulator(built.diagram)
    ApplySimulatorConfig(scenario.simulator_config, simulator)
    if built.initial_positions is not None:
        built.plant.SetPositions(
            built.plant.GetMyMutableContextFromRoot(simulator.get_mutable_context()),
            built.initial_positions,
        )
    if built.after_step is not None:
        simulator.set_monitor(lambda root: built.after_step(root) or EventStatus.DidNothing())
    return simulator


def simulate(
    built: BuiltDiagram,
    scenario: Scenario,
    controller_name: str,
    progress: Callable | None = None,
    live: LiveView | None = None,
) -> RunResult:
    """Simulate `built` for scenario.duration_s and read its loggers back.

    The diagram's SafetyMonitor checks (at 100 Hz) that the plant state is finite, its
    positions stay within scenario.max_abs_position_m, and whatever the world checks
    (e.g. the contact force); at the first problem the run stops with status "unstable",
    and the logs up to that moment are kept. So does a simulation that fails.

    Parameters
    ----------
    built : BuiltDiagram
        A diagram of one controller in its world (from `diagram_factory`).
    scenario : Scenario
        Its simulator config and duration.
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
    simulator = prepared_simulator(built, scenario)
    context = simulator.get_mutable_context()
    plant_context = built.plant.GetMyContextFromRoot(context)
    trouble = {}
    wall_start = last_report = time.perf_counter()
    status = simulator.Initialize()  # the safety checks look at t = 0 too
    if status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
        trouble.update(reason=status.message(), time=status.return_time())
    chunks = 0 if trouble else max(1, int(np.ceil(scenario.duration_s / CHUNK_S - 1e-9)))
    for k in range(1, chunks + 1):
        try:
            status = simulator.AdvanceTo(min(k * CHUNK_S, scenario.duration_s))
        except RuntimeError as error:  # e.g. the integrator failing on a diverging state
            trouble.update(reason=" ".join(str(error).split())[:300], time=context.get_time())
            break
        if status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
            trouble.update(reason=status.message(), time=status.return_time())
            break
        if live is not None:  # throttled to the view's frame rate by the wall clock
            live.show(controller_name, context.get_time(), built.plant.GetPositions(plant_context))
        if progress is not None and time.perf_counter() - last_report > 1.0:
            last_report = time.perf_counter()
            progress(
                controller_name, context.get_time(), scenario.duration_s, last_report - wall_start
            )
    if live is not None:  # the run's last state, whatever the view's frame rate skipped
        live.show(
            controller_name, context.get_time(), built.plant.GetPositions(plant_context), final=True
        )
    series, t = {}, None
    for name, (logger, columns) in built.loggers.items():
        log = logger.FindLog(context)
        t = log.sample_times() if t is None else t
        series[name] = log.data()[columns].T.copy()
    theta = built.controller.read_theta(context) if built.controller.read_theta else None
    if trouble:
        return RunResult(
            controller_name, t, series, "unstable", trouble["reason"], trouble["time"], theta
        )
    return RunResult(controller_name, t, series, theta=theta)
