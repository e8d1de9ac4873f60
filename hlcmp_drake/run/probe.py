"""`hlcmp probe`: measure a scenario's world alone -- the tool pushed through its object
on a stiff carriage, no controller under test -- and write probe.json and probe.png."""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import EventStatus

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.core.metrics import probe_readings, wrist_readings
from hlcmp_drake.experiments.plots import new_figure
from hlcmp_drake.io import outputs
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.worlds.build import world_of
from hlcmp_drake.worlds.probe import ProbeWorld

if TYPE_CHECKING:
    from matplotlib.figure import Figure


@dc.dataclass
class ProbeResult:
    """What `run_probe` returns: the probe.json content, where the files went, and
    whether any force acted on the tool (False: the path missed the world)."""

    readings: dict
    out_dir: Path
    touched: bool


def simulate_probe(
    world: ProbeWorld, scenario: Scenario
) -> tuple[np.ndarray, np.ndarray, np.ndarray, str, np.ndarray | None]:
    """Drive the carriage along its path; returns (t, tool point (T, 3) [m], force on the
    tool (T, 3) [N], status, the wrist's state (T, 6) [rad, rad/s] or None without a
    wrist), the status "ok" or why the simulation stopped.

    Parameters
    ----------
    world : ProbeWorld
    scenario : Scenario
        Its simulator config.
    """
    simulator = Simulator(world.diagram)
    ApplySimulatorConfig(scenario.simulator_config, simulator)
    context = simulator.get_mutable_context()
    plant_context = world.plant.GetMyMutableContextFromRoot(context)
    world.plant.SetPositions(
        plant_context, world.plant.GetModelInstanceByName("probe_carriage"), world.waypoints[0]
    )

    def monitor(root_context):
        if world.after_step is not None:
            world.after_step(root_context)
        return EventStatus.DidNothing()

    simulator.set_monitor(monitor)
    status = "ok"
    try:
        simulator.AdvanceTo(world.times[-1])
    except RuntimeError as error:  # e.g. the contact solver failing
        status = "failed: " + " ".join(str(error).split())[:200]
    state = world.state_log.FindLog(context)
    force = world.force_log.FindLog(context)
    wrist = None if world.wrist_log is None else world.wrist_log.FindLog(context).data().T
    return state.sample_times(), state.data()[:3].T, force.data().T, status, wrist


def readings_of(
    world: ProbeWorld, scenario: Scenario, t: np.ndarray, position: np.ndarray, force: np.ndarray
) -> tuple:
    """probe.json's numbers from the logs (see `core.metrics.probe_readings`), and the
    travel [m], resisting and lateral forces [N] they come from.

    Parameters
    ----------
    world : ProbeWorld
    scenario : Scenario
        Its probe section (the push and the lateral axis).
    t : (T,) array
    position, force : (T, 3) arrays
        The tool point [m] and the force on the tool [N], world.
    """
    push = np.asarray(scenario.probe.push_m, float)
    direction = push / np.linalg.norm(push)
    t0, t1 = world.push
    start_point = np.array([np.interp(t0, world.times, world.waypoints[:, k]) for k in range(3)])
    distance = (position - start_point) @ direction
    resisting = -(force @ direction)
    if scenario.probe.lateral_axis:
        axis = np.asarray(scenario.probe.lateral_axis, float)
        lateral = force @ (axis / np.linalg.norm(axis))
    else:
        lateral = np.linalg.norm(force - np.outer(force @ direction, direction), axis=1)
    return (
        probe_readings(distance, resisting, lateral, (t >= t0) & (t <= t1)),
        distance,
        resisting,
        lateral,
    )


def probe_figure(
    name: str,
    distance: np.ndarray,
    resisting: np.ndarray,
    lateral: np.ndarray,
    in_push: np.ndarray,
    readings: dict,
) -> Figure:
    """Force along and across the path against the travel along the push.

    Parameters
    ----------
    name : str
        The scenario's name, for the title.
    distance, resisting, lateral : (T,) arrays
        Travel along the push [m], the force against it and across it [N].
    in_push : (T,) bool array
        The samples of the push itself (the rest, after it, is the way back).
    readings : dict
        probe.json's numbers, for the title.
    """
    fig, (axis,) = new_figure(1, 1, size=(8, 4.5))
    way_back = ~in_push & (np.cumsum(in_push) > 0)
    axis.plot(1000 * distance[in_push], resisting[in_push], color="C0", label="resisting the push")
    axis.plot(
        1000 * distance[way_back],
        resisting[way_back],
        color="C0",
        lw=0.8,
        ls="--",
        label="along the push, on the way back",
    )
    axis.plot(1000 * distance, lateral, color="C3", label="lateral")
    axis.axhline(0.0, color="k", lw=0.5)
    axis.set_xlabel("travel along the push [mm]")
    axis.set_ylabel("force on the tool [N]")
    axis.set_title(
        f"hlcmp probe {name}: peak {readings['peak_force_N']:.1f} N, residual "
        f"{readings['residual_force_N']:.1f} N, max lateral {readings['max_lateral_force_N']:.2f} N"
    )
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
    return fig


# The scenario's parts a probe never reads: it pushes the tool alone through the world.
NOT_PROBED = (
    "duration_s",
    "controllers",
    "reference",
    "dmp",
    "log_period_s",
    "recording",
    "iiwa_driver",
    "robot_imperfection",
)


def unused_by_the_probe(overrides: Sequence[str]) -> list[str]:
    """The overrides a probe would take and never read (`NOT_PROBED`), for a warning.

    Parameters
    ----------
    overrides : sequence of str
        ``dotted.key=value``.

    Returns
    -------
    list of str
        Those whose first key is in NOT_PROBED, as given.
    """
    return [o for o in overrides if o.partition("=")[0].strip().split(".")[0] in NOT_PROBED]


def run_probe(
    name_or_path: str | Path,
    out_dir: str | Path | None = None,
    *,
    speed: float | None = None,
    overrides: Sequence[str] = (),
    warn: Callable[[str], None] | None = None,
) -> ProbeResult:
    """Probe a scenario's world and write probe.json, probe.png and probe.npz.

    Parameters
    ----------
    name_or_path : str or Path
        A bundled arm scenario (insertion, cutting, peg_in_hole) or a YAML file with a
        `probe` section.
    out_dir : str or Path, optional
        Default out/probe_<scenario>.
    speed : float, optional
        The carriage's speed [m/s] (default the scenario's probe.speed_m_per_s).
    overrides : sequence of str
        ``dotted.key=value`` overrides, e.g. ``probe.tilt_rad=0.001``.
    warn : callable(str), optional
        Told of each override the probe never reads (`unused_by_the_probe`), once the
        scenario with them all has loaded: a value it refuses is an error, not a warning.
    """
    scenario, _ = load_scenario(name_or_path, overrides)
    build_probe = world_of(scenario).build_probe
    if build_probe is None or not scenario.probe.given:
        raise InputError(
            f"scenario '{scenario.name}' has no probe: it needs an arm task and probe.start_m, "
            "probe.push_m"
        )
    # As a run's reference is (`worlds.arm.prepare`): a tool started in the foam never
    # tears it, and the probe would read the memoryless field's pull as the foam's.
    from hlcmp_drake.worlds.puncture import check_start_outside

    check_start_outside(
        scenario,
        scenario.probe.start_m,
        f"{scenario.name}: probe.start_m puts",
        "start it above the face (the bundled probe starts 5 mm above it)",
    )
    # Checked here, not at load: only a probe moves the carriage (a run at another time
    # step never uses it).
    given = scenario.probe.speed_m_per_s if speed is None else speed
    problem = scenario.probe.speed_problem(given, scenario.plant_config.time_step)
    if problem:
        where = f"{scenario.name}: probe.speed_m_per_s" if speed is None else "--speed"
        raise InputError(f"{where}: {problem}")
    for override in unused_by_the_probe(overrides) if warn is not None else ():
        warn(f"--set {override}: the probe does not use it (it pushes the tool alone)")
    world = build_probe(scenario, speed)
    t, position, force, status, wrist = simulate_probe(world, scenario)
    readings, distance, resisting, lateral = readings_of(world, scenario, t, position, force)
    in_push = (t >= world.push[0]) & (t <= world.push[1])
    if wrist is not None:
        readings |= {
            "max_travel_m": float(np.max(distance)),
            **wrist_readings(
                world.tool_rotation.matrix(),
                wrist[:, :3],
                wrist[:, 3:],
                np.asarray(scenario.probe.wrist_stiffness_Nm_per_rad, float),
                scenario.probe.wrist_damping_Nms_per_rad,
                np.asarray(scenario.probe.push_m, float),
                in_push,
            ),
        }
    out_dir = Path(out_dir or Path("out") / f"probe_{scenario.name}")
    result = {
        "scenario": scenario.name,
        "speed_m_per_s": float(
            np.linalg.norm(np.diff(world.waypoints[:2], axis=0)) / np.diff(world.times[:2])[0]
        ),
        **readings,
        "tilt_rad": scenario.probe.tilt_rad,
        "status": status,
    }
    series = {"t": t, "tool_position": position, "force": force}
    if wrist is not None:
        result["wrist_stiffness_Nm_per_rad"] = list(scenario.probe.wrist_stiffness_Nm_per_rad)
        series["wrist_state"] = wrist
    with outputs.replacing_outputs(out_dir):
        outputs.write_npz(out_dir / "probe.npz", series)
        outputs.save_figure(
            out_dir / "probe.png",
            probe_figure(scenario.name, distance, resisting, lateral, in_push, readings),
        )
        outputs.write_json(out_dir / "probe.json", result)
    return ProbeResult(result, out_dir, bool(np.any(force)))
