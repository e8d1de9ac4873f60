"""Where the time goes: the measurements behind docs/performance.md (hlcmp bench).

Every ratio is measured side by side in one invocation, the two sides alternating, and
reported as the median of the pair ratios, since a shared 2-core machine is noisy.
"""

import inspect
import os
import platform
import statistics
import sys
import tempfile
import time
from functools import partial

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.controllers import InverseDynamicsController
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.core.dmp import Dmp, DmpSettings
from hlcmp_drake.core.kernels import kernel_chosen, kernel_path, numba_available
from hlcmp_drake.core.orientation_dmp import OrientationDmp
from hlcmp_drake.experiments import EXPERIMENTS
from hlcmp_drake.experiments.table import Table, number
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.run.report import run_report
from hlcmp_drake.run.runner import run_scenario
from hlcmp_drake.run.simulate import prepared_simulator, simulate
from hlcmp_drake.systems.ports import REFERENCE_PORTS
from hlcmp_drake.worlds import arm
from hlcmp_drake.worlds.build import diagram_factory
from hlcmp_drake.worlds.common import BuiltDiagram, add_reference
from hlcmp_drake.worlds.controllers import initial_theta
from hlcmp_drake.worlds.models import load_models
from hlcmp_drake.worlds.pose import add_pose_reference, pose_tick


def _wall(function):
    start = time.perf_counter()
    result = function()
    return time.perf_counter() - start, result


def advance(built: BuiltDiagram, scenario: Scenario) -> Simulator:
    """Simulate a built diagram for scenario.duration_s as a run does, in one AdvanceTo and
    without reading anything back: every side of the benchmark's ratios is timed this way.

    Parameters
    ----------
    built : BuiltDiagram
    scenario : Scenario
        Its simulator config and duration.

    Returns
    -------
    Simulator
        At the end of the run.
    """
    simulator = prepared_simulator(built, scenario)
    simulator.AdvanceTo(scenario.duration_s)
    return simulator


def advance_alternately(simulators: dict, seconds: float, chunk_s: float = 0.1) -> dict:
    """Advance several initialized simulators to `seconds` side by side: in chunks of
    `chunk_s` simulated seconds, one after the other, the order reversed every chunk, so
    that the machine's drift falls on every side alike (the scripts' side-by-side
    measurements).

    Parameters
    ----------
    simulators : dict of str to Simulator
        By side, each initialized at t = 0.
    seconds : float
        Where they all end [s].
    chunk_s : float
        Simulated seconds per chunk.

    Returns
    -------
    dict of str to float
        The wall time each side spent in AdvanceTo [s].
    """
    spent = dict.fromkeys(simulators, 0.0)
    sides = list(simulators)
    now, chunk = 0.0, 0
    while now < seconds - 1e-9:
        now, chunk = min(seconds, now + chunk_s), chunk + 1
        for side in sides if chunk % 2 else sides[::-1]:
            start = time.perf_counter()
            simulators[side].AdvanceTo(now)
            spent[side] += time.perf_counter() - start
    return spent


def side_by_side_line(
    label: str, spent: dict, steps: int, ratio: tuple[str, str], same: bool
) -> str:
    """One line of a two-sided measurement (the side-by-side scripts): µs a plant step on
    each side, the ratio of two sides' times, and whether they ended in the same state.

    Parameters
    ----------
    label : str
        What was run, e.g. the controller.
    spent : dict of str to float
        Wall time in AdvanceTo by side [s] (`advance_alternately`).
    steps : int
        Plant steps each side took.
    ratio : (str, str)
        The sides whose times are divided, numerator first.
    same : bool
        `ended_alike` of the sides.

    Returns
    -------
    str
    """
    top, bottom = ratio
    return (
        f"{label}: "
        + ", ".join(f"{side} {spent[side] / steps * 1e6:.1f}" for side in spent)
        + f" µs a step; {top} / {bottom} {spent[top] / spent[bottom]:.3f}"
        + f"; the same state to the bit: {same}"
    )


def ended_alike(simulators: dict) -> bool:
    """Whether the simulators' contexts hold the same discrete and continuous state to the
    bit (two sides of a side-by-side measurement that must compute the same thing).

    Parameters
    ----------
    simulators : dict of str to Simulator
        Of one diagram's structure each.

    Returns
    -------
    bool
    """

    def whole_state(simulator) -> np.ndarray:
        context = simulator.get_context()
        groups = range(context.num_discrete_state_groups())
        return np.concatenate(
            [context.get_discrete_state(i).get_value() for i in groups]
            + [context.get_continuous_state_vector().CopyToVector()]
        )

    first, *others = (whole_state(simulator) for simulator in simulators.values())
    return all(np.array_equal(first, other) for other in others)


def count_python_calls(built: BuiltDiagram, scenario: Scenario) -> float:
    """Python calls per plant step while `built` is simulated, counted by instrumentation:
    every Python function that Drake's C++ calls into during AdvanceTo -- an output port's
    or cache entry's calc, an event handler, the Simulator's monitor, also when a Python
    calc's port evaluation calls into Python again -- from a profile hook that sees which
    Python frames are inside a call to pydrake.

    Parameters
    ----------
    built : BuiltDiagram
    scenario : Scenario
        Its duration and plant time step.

    Returns
    -------
    float
        Calls per plant step.
    """
    simulator = prepared_simulator(built, scenario)
    simulator.Initialize()
    in_c_call, calls = {}, [0]  # per Python frame: a stack of its calls into C, True for Drake's

    def hook(frame, event, arg):
        if event == "c_call":
            in_c_call.setdefault(frame, []).append(_is_drake(arg))
        elif event in ("c_return", "c_exception"):
            in_c_call[frame].pop()
        elif (
            event == "call"
            and in_c_call.get(frame.f_back)
            and in_c_call[frame.f_back][-1]
            and not frame.f_code.co_flags & inspect.CO_GENERATOR
        ):  # a generator resumed by C is not a call
            calls[0] += 1

    sys.setprofile(hook)
    try:
        simulator.AdvanceTo(scenario.duration_s)
    finally:
        sys.setprofile(None)
    return calls[0] / round(scenario.duration_s / scenario.plant_config.time_step)


def _is_drake(function):
    """Whether a builtin is pydrake's (numpy's C code calls Python helpers too)."""
    module = (
        getattr(function, "__module__", None)
        or type(getattr(function, "__self__", None)).__module__
    )
    return str(module).startswith("pydrake")


def insertion_runs(duration: float, repetitions: int) -> dict:
    """The insertion's Hl-CMP on the fast path, against the same world driven along the
    Hl-CMP run's own joint motion by Drake's C++ InverseDynamicsController, alternating;
    each side with the run's harness (safety monitor, wrist sensor, loggers) and bare
    (neither), the build outside the timing; and the modular path alongside.

    Parameters
    ----------
    duration : float
        Simulated seconds of each run.
    repetitions : int
        Rounds of runs; ratios are the median of the per-round ratios.

    Returns
    -------
    dict
        insertion_rtf, controller_overhead_ratio (harnessed), controller_overhead_ratio_bare,
        modular_over_fast, controller_tick_us {p50, p99}, python_calls_per_step (fast
        path) and python_calls_per_step_modular, and the wall times [s].
    """
    scenario, _ = load_scenario("insertion", [f"duration_s={duration}", "task.control_path=fast"])
    modular, _ = load_scenario("insertion", [f"duration_s={duration}", "task.control_path=modular"])
    setup = arm.prepare(scenario)
    run = simulate(arm.build(scenario, "hlcmp", setup), scenario, "hlcmp")  # the motion to replay
    walls = {key: [] for key in ("fast", "cpp", "fast_bare", "cpp_bare", "modular")}
    ticks = []
    for _ in range(repetitions):
        built = arm.build(scenario, "hlcmp", setup)
        ticks.append(built.controller.system.record_tick_times())  # filled as the run goes
        walls["fast"].append(_wall(partial(advance, built, scenario))[0])
        replay = joint_space_replay(scenario, setup, run, harness=True)
        walls["cpp"].append(_wall(partial(advance, replay, scenario))[0])
        bare = arm.build(scenario, "hlcmp", setup, harness=False)
        walls["fast_bare"].append(_wall(partial(advance, bare, scenario))[0])
        replay = joint_space_replay(scenario, setup, run, harness=False)
        walls["cpp_bare"].append(_wall(partial(advance, replay, scenario))[0])
        built = arm.build(modular, "hlcmp", setup)
        walls["modular"].append(_wall(partial(advance, built, modular))[0])

    def ratio(a, b):
        return statistics.median([x / y for x, y in zip(walls[a], walls[b])])

    tick_us = 1e6 * np.concatenate(ticks)
    return tick_paths(scenario, setup, run, repetitions) | {
        "insertion_rtf": duration / statistics.median(walls["fast"]),
        "controller_overhead_ratio": ratio("fast", "cpp"),
        "controller_overhead_ratio_bare": ratio("fast_bare", "cpp_bare"),
        "modular_over_fast": ratio("modular", "fast"),
        "controller_tick_us": {
            "p50": float(np.percentile(tick_us, 50)),
            "p99": float(np.percentile(tick_us, 99)),
        },
        "python_calls_per_step": count_python_calls(arm.build(scenario, "hlcmp", setup), scenario),
        "python_calls_per_step_modular": count_python_calls(
            arm.build(modular, "hlcmp", setup), modular
        ),
        "insertion_wall_s": walls,
        "insertion_simulated_s": duration,
    }


def tick_paths(scenario: Scenario, setup: arm.ArmSetup, run: RunResult, repetitions: int) -> dict:
    """One Hl-CMP tick of the insertion (`FusedArmTick.evaluate`, θ' included) at every logged
    state of `run` and its reference there, on the numpy path and on the compiled one
    (`core.kernels`), the two alternating (`_tick_times`); empty without numba.

    Parameters
    ----------
    scenario : Scenario
        The insertion.
    setup : ArmSetup
    run : RunResult
        A run of the insertion's Hl-CMP: its plant states and times are the inputs.
    repetitions : int
        Rounds; the ratio is the median of the per-round ratios of the median ticks.

    Returns
    -------
    dict
        controller_tick_numpy_over_compiled, and each path's median tick per round [µs].
    """
    if not numba_available():
        return {}
    sides = {}
    references = _reference_along(
        partial(add_reference, scenario=scenario, dmp=setup.dmp, compiled=True), scenario, run.t
    )
    inputs = list(zip(run.series["plant_state"], references))
    for path in ("numpy", "compiled"):
        with kernel_chosen(path):
            tick = arm.arm_tick(scenario, "hlcmp", plant=_control_plant(scenario), setup=setup)
        theta = np.random.default_rng(0).uniform(0, 300, tick.law.theta_size)
        sides[path] = (tick, inputs, theta)
    kept = {
        path: [1e6 * float(np.median(times)) for times in rounds]
        for path, rounds in _tick_times(sides, repetitions).items()
    }
    return {
        "controller_tick_numpy_over_compiled": statistics.median(
            [n / c for n, c in zip(kept["numpy"], kept["compiled"])]
        ),
        "controller_tick_median_us_by_path": kept,
    }


def pose_tick_cost(duration: float, repetitions: int) -> dict:
    """The 6-D Hl-CMP's tick (`PoseControlTick.evaluate`, θ' included) beside the
    translational Hl-CMP's (`FusedArmTick.evaluate`) in the peg-in-hole world, both at every
    state logged (every 4 ms) by a short run of the translational one (the cheaper run)
    and at the 6-D reference there (the translational tick reads its position part), each
    from its configured initial θ, alternating (`_tick_times`); both on the numpy
    path and, with numba, on the compiled one (each tick's whole arithmetic between its
    plant queries).

    Parameters
    ----------
    duration : float
        Simulated seconds of the run whose states are the inputs.
    repetitions : int
        Rounds; a ratio is the median of the per-round ratios of the median ticks.

    Returns
    -------
    dict
        pose_tick_us and translational_tick_us ({p50, p99} over every kept tick [µs]) and
        pose_over_translational_tick, on the path every fast-path run takes
        (`kernel_path`); the same by path (``..._by_path``); pose_tick_states, the
        number of states.
    """
    scenario, _ = load_scenario(
        "peg_in_hole", [f"duration_s={duration}", "log_period_s=0.004", "task.control_path=fast"]
    )
    setup = arm.prepare(scenario)
    run = simulate(arm.build(scenario, "hlcmp", setup), scenario, "hlcmp")
    references = _reference_along(
        partial(add_pose_reference, scenario=scenario, setup=setup), scenario, run.t
    )
    sides, plant = {}, _control_plant(scenario)  # each tick's model has its own context
    paths = ("numpy", "compiled") if numba_available() else ("numpy",)
    for path in paths:
        with kernel_chosen(path):
            for side, name, make, size in (
                ("pose", "hlcmp_6d", pose_tick, None),
                ("translational", "hlcmp", arm.arm_tick, len(REFERENCE_PORTS)),
            ):
                tick = make(scenario, name, plant=plant, setup=setup)
                inputs = [
                    (state, now[:size]) for state, now in zip(run.series["plant_state"], references)
                ]
                theta = initial_theta(scenario.controllers[name], scenario)
                sides[f"{side}_{path}"] = (tick, inputs, theta)
    times = _tick_times(sides, repetitions)
    out: dict = {"pose_tick_states": len(run.t)}
    for path in paths:
        for side in ("pose", "translational"):
            ticks = 1e6 * np.concatenate(times[f"{side}_{path}"])
            out.setdefault(f"{side}_tick_us_by_path", {})[path] = {
                "p50": float(np.percentile(ticks, 50)),
                "p99": float(np.percentile(ticks, 99)),
            }
        out.setdefault("pose_over_translational_tick_by_path", {})[path] = statistics.median(
            [
                float(np.median(pose) / np.median(translational))
                for pose, translational in zip(
                    times[f"pose_{path}"], times[f"translational_{path}"]
                )
            ]
        )
    path = kernel_path()
    for key in ("pose_tick_us", "translational_tick_us", "pose_over_translational_tick"):
        out[key] = out[f"{key}_by_path"][path]
    return out


def _reference_along(add, scenario: Scenario, times: np.ndarray) -> list[tuple]:
    """A run's reference at its log times: `add(builder)` adds the reference system alone,
    which is simulated as the scenario's runs are (it reads nothing of the plant), and its
    output ports read at each of `times`, in port order."""
    builder = DiagramBuilder()
    reference = add(builder)
    simulator = Simulator(builder.Build())
    ApplySimulatorConfig(scenario.simulator_config, simulator)
    context = reference.GetMyContextFromRoot(simulator.get_mutable_context())
    ports = [reference.get_output_port(k) for k in range(reference.num_output_ports())]
    values = []
    for t in times:
        simulator.AdvanceTo(t)
        values.append(tuple(port.Eval(context).copy() for port in ports))
    return values


def _tick_times(sides: dict, rounds: int) -> dict[str, list[np.ndarray]]:
    """The wall time [s] of each tick at each of its inputs, evaluated and its θ' read, the
    sides alternating round by round; the first round compiles (or loads the cache) and
    is not kept.

    Parameters
    ----------
    sides : dict of str to (tick, list of (state, reference), theta)
        `ControlTick` or `PoseControlTick`, its inputs, and θ.
    rounds : int
        The kept rounds.

    Returns
    -------
    dict of str to list of arrays
        Per side, one array of tick times per kept round.
    """
    times: dict[str, list[np.ndarray]] = {side: [] for side in sides}
    for _ in range(rounds + 1):
        for side, (tick, inputs, theta) in sides.items():
            round_times = np.empty(len(inputs))
            for k, (state, now) in enumerate(inputs):
                start = time.perf_counter()
                _ = tick.evaluate(state, now, theta).law.rates
                round_times[k] = time.perf_counter() - start
            times[side].append(round_times)
    return {side: kept[1:] for side, kept in times.items()}


def one_dof_runs(duration: float, repetitions: int) -> dict:
    """Each 1-DOF controller on the slider's fast path, and the Hl-CMP on its modular path
    alongside, harnessed (monitor and loggers, no recording), the build outside the timing.

    Parameters
    ----------
    duration : float
        Simulated seconds of each run.
    repetitions : int
        Rounds; each controller's RTF is the median over them.

    Returns
    -------
    dict
        one_dof_rtf (the slowest controller's), one_dof_rtf_by_controller,
        one_dof_modular_over_fast (the Hl-CMP's), and the wall times [s].
    """
    paths = {
        path: load_scenario("one_dof", [f"duration_s={duration}", f"task.control_path={path}"])[0]
        for path in ("fast", "modular")
    }
    factories = {path: diagram_factory(scenario) for path, scenario in paths.items()}
    labels = list(paths["fast"].controllers)
    walls: dict[str, list[float]] = {label: [] for label in [*labels, "hlcmp_modular"]}
    for _ in range(repetitions):
        for label in labels:
            built = factories["fast"](label)
            walls[label].append(_wall(partial(advance, built, paths["fast"]))[0])
        built = factories["modular"]("hlcmp")
        walls["hlcmp_modular"].append(_wall(partial(advance, built, paths["modular"]))[0])
    rtf = {label: duration / statistics.median(walls[label]) for label in labels}
    return {
        "one_dof_rtf": min(rtf.values()),
        "one_dof_rtf_by_controller": rtf,
        "one_dof_modular_over_fast": statistics.median(
            [m / f for m, f in zip(walls["hlcmp_modular"], walls["hlcmp"])]
        ),
        "one_dof_wall_s": walls,
        "one_dof_simulated_s": duration,
    }


def world_alone_runs(name: str, duration: float, repetitions: int) -> dict:
    """The arm world `name` alone: its plant, physics extras and the run's harness (safety
    monitor, wrist sensor, loggers), driven by Drake's C++ InverseDynamicsController along
    the Hl-CMP run's own joint motion (`joint_space_replay`), the build outside the timing.

    Parameters
    ----------
    name : str
        A bundled arm scenario.
    duration : float
        Simulated seconds of each run.
    repetitions : int
        Runs; the RTF is from their median wall time.

    Returns
    -------
    dict
        rtf (simulated s per wall s) and wall_s, the wall time of each run [s].
    """
    scenario, _ = load_scenario(name, [f"duration_s={duration}", "task.control_path=fast"])
    setup = arm.prepare(scenario)
    run = simulate(arm.build(scenario, "hlcmp", setup), scenario, "hlcmp")
    walls = [
        _wall(partial(advance, joint_space_replay(scenario, setup, run, harness=True), scenario))[0]
        for _ in range(repetitions)
    ]
    return {"rtf": duration / statistics.median(walls), "wall_s": walls}


def report_wall_s(scenarios: list[str] | None = None) -> dict:
    """The wall time [s] of a whole `hlcmp report` (every bundled scenario's runs and probe,
    the page), its default one process per CPU, outputs in a temporary folder.

    Parameters
    ----------
    scenarios : list of str, optional
        What the report runs (default: every bundled scenario, as `hlcmp report`).

    Returns
    -------
    dict
        wall_s and jobs (the processes it ran in).
    """
    jobs = os.cpu_count() or 1
    with tempfile.TemporaryDirectory() as folder:
        wall = _wall(partial(run_report, folder, scenarios, jobs=jobs))[0]
    return {"wall_s": wall, "jobs": jobs}


def joint_space_replay(
    scenario: Scenario, setup: arm.ArmSetup, run: RunResult, harness: bool
) -> BuiltDiagram:
    """The same world (and, with `harness`, the same monitor, sensor and loggers), driven
    by InverseDynamicsController along the run's logged joint positions and velocities
    (piecewise-linear between the 100 Hz log samples).

    Parameters
    ----------
    scenario : Scenario
        An arm scenario: its world.
    setup : ArmSetup
        Its start posture (for the world's models).
    run : RunResult
        A run of that world: its logged ``plant_state`` is the motion to follow.
    harness : bool
        With the run's safety monitor and loggers (and their wrist-force reads).

    Returns
    -------
    BuiltDiagram
    """
    builder = DiagramBuilder()
    world = arm.add_world(builder, scenario)
    plant = world.plant
    nq = plant.num_positions()
    states = run.series["plant_state"]
    source = builder.AddSystem(
        TrajectorySource(PiecewisePolynomial.FirstOrderHold(run.t, states.T))
    )
    controller = builder.AddSystem(
        InverseDynamicsController(
            _control_plant(scenario),
            kp=np.full(nq, 400.0),
            ki=np.zeros(nq),
            kd=np.full(nq, 40.0),
            has_reference_acceleration=False,
        )
    )
    builder.Connect(plant.get_state_output_port(), controller.get_input_port_estimated_state())
    builder.Connect(source.get_output_port(), controller.get_input_port_desired_state())
    builder.Connect(controller.get_output_port_control(), plant.get_actuation_input_port())
    loggers = {}
    if harness:
        never_saturated = builder.AddSystem(ConstantVectorSource([0.0]))
        loggers = arm.add_harness(
            builder,
            scenario,
            world,
            log_ports={
                "plant_state": plant.get_state_output_port(),
                "f_ext": world.sensor.GetOutputPort("task_force"),
                "xd": source.get_output_port(),
                "tau": controller.get_output_port_control(),
            },
            saturated=never_saturated.get_output_port(),
        )
    return BuiltDiagram(
        builder.Build(),
        plant,
        None,
        loggers,
        states[0, :nq],
        world.sensing.after_step(),
    )


def _control_plant(scenario):
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    load_models(plant, scenario)
    return plant


def _demo(samples=2000):
    t = np.linspace(0.0, 4.0, samples)
    u = t / 4.0
    smooth = 10 * u**3 - 15 * u**4 + 6 * u**5
    return t, np.column_stack([0.3 * smooth, 0.1 * np.sin(np.pi * u) ** 2, 0.4 - 0.2 * smooth])


def dmp_timings(repetitions: int, compare: bool = True) -> dict:
    """dmp_fit_ms, dmp_rollout_ms (3 axes, 2000 samples, N = 50, rollout at 1 ms), and,
    when movement_primitives is installed, our time over its time for the same fit and
    rollout, alternating.

    Parameters
    ----------
    repetitions : int
        Timed repetitions of each (medians are reported).
    compare : bool
        False: our fit and rollout alone (`machine_state`), nothing of movement_primitives.
    """
    t, positions = _demo()
    settings = DmpSettings(n_basis=50, smoothing_s=0.0)
    ours_fit, ours_rollout, theirs = [], [], []
    DMP = None
    if compare:
        try:
            from movement_primitives.dmp import DMP
        except ImportError:
            pass
    for _ in range(repetitions):
        fit_s, dmp = _wall(partial(Dmp.fit, t, positions, "xyz", settings))
        rollout_s, _ = _wall(partial(dmp.rollout, dt=0.001))
        ours_fit.append(fit_s)
        ours_rollout.append(rollout_s)
        if DMP is not None:

            def reference():
                other = DMP(n_dims=3, execution_time=float(t[-1]), dt=0.001, n_weights_per_dim=50)
                other.imitate(t, positions)
                other.open_loop()

            theirs.append(_wall(reference)[0])
    out = {
        "dmp_fit_ms": 1e3 * statistics.median(ours_fit),
        "dmp_rollout_ms": 1e3 * statistics.median(ours_rollout),
    }
    if theirs:
        out["dmp_vs_movement_primitives"] = statistics.median(
            [(f + r) / m for f, r, m in zip(ours_fit, ours_rollout, theirs)]
        )
        out["movement_primitives_fit_and_rollout_ms"] = 1e3 * statistics.median(theirs)
    elif compare:
        out["dmp_vs_movement_primitives"] = None
        out["movement_primitives_note"] = "not installed: pip install -e '.[bench]'"
    return out


def machine_state() -> dict:
    """What the machine is like now, beside the code: the load average (1, 5 and 15 min)
    and plain numpy's speed, `dmp_rollout_ms` of five rollouts (`dmp_timings`; no code of
    the controllers or of Drake). `hlcmp bench` records it at its start and its end, so
    that a run on a busy or a slower machine says so: its absolute times move with both,
    its side-by-side ratios much less.

    Returns
    -------
    dict
        load_average (three numbers) and dmp_rollout_ms [ms].
    """
    return {
        "load_average": [round(load, 2) for load in os.getloadavg()],
        "dmp_rollout_ms": dmp_timings(5, compare=False)["dmp_rollout_ms"],
    }


def _say_machine(reporter: Progress, when: str, state: dict) -> None:
    reporter.say(
        f"the machine at the {when}: load average {state['load_average'][0]:.2f} on "
        f"{os.cpu_count()} CPUs, plain numpy's DMP rollout {state['dmp_rollout_ms']:.1f} ms"
    )


def _pose_demo(turn_deg, samples=2000):
    """`_demo`'s positions with an orientation: a minimum-jerk turn of `turn_deg` about the
    tilted axis (1, 2, 2) / 3, and a 20 deg swing about (0, 0.6, -0.8) out and back.
    Returns (t, positions, quaternions, truth) with truth(t) the orientation at any time."""
    t, positions = _demo(samples)
    axis, swing_axis = np.array([1.0, 2.0, 2.0]) / 3.0, np.array([0.0, 0.6, -0.8])
    start = quat.from_rotation_vector([0.3, -0.2, 0.1])

    def truth(times):
        u = np.clip(np.asarray(times) / t[-1], 0.0, 1.0)
        turn = np.radians(turn_deg) * (10 * u**3 - 15 * u**4 + 6 * u**5)
        swing = np.radians(20.0) * np.sin(np.pi * u) ** 2
        return quat.multiply(
            quat.from_rotation_vector(turn[:, None] * axis),
            quat.multiply(quat.from_rotation_vector(swing[:, None] * swing_axis), start),
        )

    return t, positions, quat.hemisphere_continuous(truth(t)), truth


def orientation_dmp_comparison(repetitions: int) -> dict:
    """The pose DMP (`Dmp` for the position, `OrientationDmp`) against movement_primitives'
    `CartesianDMP` on the same pose demonstrations (`_pose_demo`: 2000 samples over 4 s,
    turns of 150 and 270 deg), both with 50 weights per dimension and rolled out at 1 ms:
    the geodesic RMS error [deg] of the rolled-out orientation against the demonstrated
    one at the rollout's times, and the fit + rollout time of the 150 deg demonstration,
    alternating.

    Parameters
    ----------
    repetitions : int
        Timed repetitions of each side (medians are reported).

    Returns
    -------
    dict
        orientation_dmp_rms_deg and cartesian_dmp_rms_deg ({"150": ..., "270": ...}),
        pose_dmp_fit_rollout_ms, cartesian_dmp_fit_rollout_ms and their ratio
        pose_dmp_vs_cartesian_dmp; movement_primitives' entries None when it is not
        installed.
    """
    try:
        from movement_primitives.dmp import CartesianDMP
    except ImportError:
        CartesianDMP = None
    settings = DmpSettings(n_basis=50, smoothing_s=0.0)

    def ours(t, positions, quaternions):
        position = Dmp.fit(t, positions, "xyz", settings)
        orientation = OrientationDmp.fit(t, quaternions, settings)
        position.rollout(dt=0.001)
        times, q, _, _ = orientation.rollout(dt=0.001)
        return times, q

    def theirs(t, positions, quaternions):
        dmp = CartesianDMP(execution_time=float(t[-1]), dt=0.001, n_weights_per_dim=50)
        dmp.imitate(t, np.hstack([positions, quaternions]))
        times, pose = dmp.open_loop()
        return times, pose[:, 3:]

    sides = {"orientation_dmp": ours, "cartesian_dmp": theirs if CartesianDMP else None}
    out: dict = {}
    for turn in (150, 270):
        t, positions, quaternions, truth = _pose_demo(turn)
        for name, side in sides.items():
            if side is None:
                out[f"{name}_rms_deg"] = None
                continue
            times, q = side(t, positions, quaternions)
            error = np.degrees(quat.geodesic_angle(q, truth(times)))
            out.setdefault(f"{name}_rms_deg", {})[str(turn)] = float(np.sqrt(np.mean(error**2)))
    t, positions, quaternions, _ = _pose_demo(150)
    walls: dict[str, list[float]] = {name: [] for name in sides}
    for _ in range(repetitions):
        for name, side in sides.items():
            if side is not None:
                walls[name].append(_wall(partial(side, t, positions, quaternions))[0])
    out["pose_dmp_fit_rollout_ms"] = 1e3 * statistics.median(walls["orientation_dmp"])
    if walls["cartesian_dmp"]:
        out["cartesian_dmp_fit_rollout_ms"] = 1e3 * statistics.median(walls["cartesian_dmp"])
        out["pose_dmp_vs_cartesian_dmp"] = statistics.median(
            [a / b for a, b in zip(walls["orientation_dmp"], walls["cartesian_dmp"])]
        )
    else:
        out["cartesian_dmp_fit_rollout_ms"] = out["pose_dmp_vs_cartesian_dmp"] = None
    return out


def scenario_walls(names: list[str], duration: float | None = None) -> dict:
    """The wall time [s] of each bundled scenario's full `hlcmp run` (outputs in a temp dir).

    Parameters
    ----------
    names : list of str
        Bundled scenarios.
    duration : float, optional
        Cut each short to this many simulated seconds (quick mode: the path works).
    """
    overrides = [] if duration is None else [f"duration_s={duration}"]
    out = {}
    for name in names:
        with tempfile.TemporaryDirectory() as folder:
            out[name] = _wall(partial(run_scenario, name, folder, overrides=overrides))[0]
    return out


# Simulated seconds of the runs: the full benchmark's, and the quick smoke run's (CI: every
# path is exercised once; its numbers are too short to be measurements).
FULL = {
    "insertion_s": 9.5,
    "cutting_s": 9.0,
    "one_dof_s": 20.0,
    "pose_tick_s": 0.4,
    "repetitions": 3,
    "dmp_repetitions": 15,
    "scenario_s": None,
}
QUICK = {
    "insertion_s": 1.0,
    "cutting_s": 1.0,
    "one_dof_s": 0.5,
    "pose_tick_s": 0.1,
    "repetitions": 1,
    "dmp_repetitions": 2,
    "scenario_s": 0.5,
}


def run_benchmark(quick: bool = False, reporter: Progress = SILENT) -> dict:
    """All measurements: the bench.json content.

    Parameters
    ----------
    quick : bool
        A smoke run for CI: one round of shortened runs (QUICK), recorded as
        ``machine.mode = "quick"``; its table judges no target.
    reporter : Progress, optional
        Told what is being measured.
    """
    plan = QUICK if quick else FULL
    results = {
        "machine": {
            "python": platform.python_version(),
            "processor": platform.processor(),
            "mode": "quick" if quick else "full",
            "tick_kernel": kernel_path(),
            "cpus": os.cpu_count(),
            "at_start": machine_state(),
        }
    }
    _say_machine(reporter, "start", results["machine"]["at_start"])
    reporter.say(
        "insertion: fast path, modular path and C++ inverse dynamics along the same motion ..."
    )
    results.update(insertion_runs(duration=plan["insertion_s"], repetitions=plan["repetitions"]))
    reporter.say("cutting: the world alone, C++ inverse dynamics along the Hl-CMP's motion ...")
    cutting = world_alone_runs("cutting", plan["cutting_s"], plan["repetitions"])
    results["world_alone_rtf"] = {
        "insertion": plan["insertion_s"] / statistics.median(results["insertion_wall_s"]["cpp"]),
        "cutting": cutting["rtf"],
    }
    results["world_alone_simulated_s"] = {
        "insertion": plan["insertion_s"],
        "cutting": plan["cutting_s"],
    }
    results["cutting_world_wall_s"] = cutting["wall_s"]
    reporter.say("peg_in_hole: the 6-D Hl-CMP's tick beside the translational one's ...")
    results.update(pose_tick_cost(plan["pose_tick_s"], plan["repetitions"]))
    reporter.say("one_dof: each controller on the fast path, the Hl-CMP on the modular path ...")
    results.update(one_dof_runs(duration=plan["one_dof_s"], repetitions=plan["repetitions"]))
    reporter.say("DMP fit and rollout ...")
    results.update(dmp_timings(repetitions=plan["dmp_repetitions"]))
    reporter.say("pose DMP against movement_primitives' CartesianDMP ...")
    results.update(orientation_dmp_comparison(repetitions=plan["dmp_repetitions"]))
    reporter.say("bundled scenarios ...")
    results["scenario_wall_s"] = scenario_walls(list(EXPERIMENTS), duration=plan["scenario_s"])
    if quick:
        results["scenario_simulated_s"] = plan["scenario_s"]
    else:  # the whole report: a smoke run's numbers would say nothing about it
        reporter.say("hlcmp report ...")
        results["report"] = report_wall_s()
    results["machine"]["at_end"] = machine_state()
    _say_machine(reporter, "end", results["machine"]["at_end"])
    return results


def is_quick(results: dict) -> bool:
    """Whether bench.json content comes from a quick smoke run (``hlcmp bench --quick``).

    Parameters
    ----------
    results : dict
        The bench.json content.

    Returns
    -------
    bool
    """
    return results.get("machine", {}).get("mode") == "quick"


# The targets, once: (measure, its value from bench.json, the target's text, met?).
def _rows(results):
    tick = results["controller_tick_us"]
    insertion_s = results.get("insertion_simulated_s", FULL["insertion_s"])
    ratio = results.get("dmp_vs_movement_primitives")
    kernel = results["machine"].get("tick_kernel")  # bench.json files from before lack it
    rows = []
    if "at_end" in results["machine"]:  # bench.json files from before lack it
        start, end = results["machine"]["at_start"], results["machine"]["at_end"]
        rows.append(
            (
                "the machine during the run: load average (1 min) at its start / end on "
                f"{results['machine']['cpus']} CPUs; the DMP rollout of dmp_rollout_ms below "
                "(plain numpy: the machine's own speed) timed at its start / end",
                f"{start['load_average'][0]:.2f} / {end['load_average'][0]:.2f}; "
                f"{start['dmp_rollout_ms']:.1f} / {end['dmp_rollout_ms']:.1f} ms",
                "",
                None,
            )
        )
    if kernel:
        rows.append(
            (
                "tick_kernel: the path of the controller's arithmetic in every fast-path run "
                "below (compiled: numba, the fast extra; numpy: without it)",
                kernel,
                "",
                None,
            )
        )
    rows += [
        (
            "insertion_rtf: simulated s per wall s, Hl-CMP insertion on the fast path "
            f"({insertion_s:g} s, harnessed, no recording)",
            number(results["insertion_rtf"]),
            "≥ 4",
            results["insertion_rtf"] >= 4,
        ),
        (
            "controller_overhead_ratio: that run / the same world and harness driven by Drake's "
            "C++ "
            "InverseDynamicsController along the same joint motion",
            number(results["controller_overhead_ratio"]),
            "≤ 2.5",
            results["controller_overhead_ratio"] <= 2.5,
        ),
        (
            "controller_overhead_ratio_bare: the same, neither side with monitor, sensor or "
            "loggers",
            number(results["controller_overhead_ratio_bare"]),
            "",
            None,
        ),
        (
            "modular_over_fast: the modular path's run / the fast path's, same scenario",
            number(results["modular_over_fast"]),
            "",
            None,
        ),
        (
            "python_calls_per_step: calls from Drake into Python per 1 ms plant step, fast path "
            "(counted)",
            number(results["python_calls_per_step"]),
            "≤ 4",
            results["python_calls_per_step"] <= 4,
        ),
        (
            "python_calls_per_step_modular: the same for the modular path",
            number(results["python_calls_per_step_modular"]),
            "",
            None,
        ),
        (
            "controller_tick_us: one tick, plant state to joint torques and Eq. 31 rates, in the "
            "running "
            "insertion, p50 / p99",
            f"{tick['p50']:.0f} / {tick['p99']:.0f} µs",
            "p99 ≤ 250",
            tick["p99"] <= 250,
        ),
    ]
    for world, rtf in results.get("world_alone_rtf", {}).items():  # older bench.json: none
        rows.append(
            (
                f"world_alone_rtf[{world}]: simulated s per wall s of the {world} world alone "
                "(plant, physics extras, harness) driven by Drake's C++ "
                "InverseDynamicsController along the Hl-CMP run's joint motion "
                f"({results['world_alone_simulated_s'][world]:g} s)",
                number(rtf),
                "≥ 4" if world == "insertion" else "",
                rtf >= 4 if world == "insertion" else None,
            )
        )
    if "controller_tick_numpy_over_compiled" in results:
        rows.append(
            (
                "controller_tick_numpy_over_compiled: one tick at the insertion run's logged "
                "states on the numpy path / on the compiled path (alternating rounds)",
                number(results["controller_tick_numpy_over_compiled"]),
                "",
                None,
            )
        )
    if "pose_over_translational_tick" in results:  # bench.json files from before lack it
        rows += _pose_tick_rows(results)
    if "one_dof_rtf" in results:  # bench.json files from before the slider's fast path lack it
        slowest = min(
            results["one_dof_rtf_by_controller"], key=results["one_dof_rtf_by_controller"].get
        )
        rows += [
            (
                "one_dof_rtf: simulated s per wall s of the slowest 1-DOF controller on the "
                f"fast path ({slowest}; {results['one_dof_simulated_s']:g} s, harnessed, no "
                "recording)",
                number(results["one_dof_rtf"]),
                "≥ 20",
                results["one_dof_rtf"] >= 20,
            ),
            (
                "one_dof_modular_over_fast: the 1-DOF Hl-CMP's modular run / its fast run",
                number(results["one_dof_modular_over_fast"]),
                "",
                None,
            ),
        ]
    rows += [
        ("dmp_fit_ms: 3 axes, 2000 samples, N = 50", f"{results['dmp_fit_ms']:.1f} ms", "", None),
        (
            "dmp_rollout_ms: the same DMP at 1 ms steps",
            f"{results['dmp_rollout_ms']:.1f} ms",
            "",
            None,
        ),
        (
            "dmp_vs_movement_primitives: our fit + rollout / movement_primitives 0.9.1's",
            "n/a" if ratio is None else number(ratio),
            "≤ 1.0",
            None if ratio is None else ratio <= 1.0,
        ),
    ]
    if "orientation_dmp_rms_deg" in results:  # bench.json files from before the pose DMP lack it
        rows += _pose_dmp_rows(results)
    cut = results.get("scenario_simulated_s")
    rows += [
        (
            f"wall time of `hlcmp run {name}`"
            + (f" cut to {cut:g} s" if cut else "")
            + " (all its controllers, figures, recording)",
            f"{wall:.1f} s",
            "",
            None,
        )
        for name, wall in results["scenario_wall_s"].items()
    ]
    if "report" in results:  # full runs only
        report = results["report"]
        rows.append(
            (
                "wall time of `hlcmp report` (every bundled scenario's runs and probe, the "
                f"page; {report['jobs']} processes)",
                f"{report['wall_s']:.1f} s",
                "≤ 90 s",
                report["wall_s"] <= 90,
            )
        )
    return rows


def _pose_tick_rows(results):
    """The 6-D tick beside the translational one, on the bench's path and on the other."""

    def ticks(side, path):
        tick = results[f"{side}_tick_us_by_path"][path]
        return f"{tick['p50']:.0f} / {tick['p99']:.0f} µs"

    kernel = results["machine"]["tick_kernel"]
    rows = [
        (
            "pose_over_translational_tick: one 6-D Hl-CMP tick (PoseControlTick) / one "
            "translational Hl-CMP tick (FusedArmTick), peg-in-hole world, at "
            f"{results['pose_tick_states']} states of a short run, alternating rounds "
            f"({kernel}; 6-D {ticks('pose', kernel)}, translational "
            f"{ticks('translational', kernel)}, p50 / p99)",
            number(results["pose_over_translational_tick"]),
            "",
            None,
        )
    ]
    for path, ratio in results["pose_over_translational_tick_by_path"].items():
        if path != kernel:
            rows.append(
                (
                    f"the same on the {path} path (6-D {ticks('pose', path)}, translational "
                    f"{ticks('translational', path)})",
                    number(ratio),
                    "",
                    None,
                )
            )
    return rows


def _pose_dmp_rows(results):
    """The orientation DMP against movement_primitives' CartesianDMP (n/a: not installed)."""

    def errors(name):
        value = results[f"{name}_rms_deg"]
        return "n/a" if value is None else f"{value['150']:.4f} / {value['270']:.4f}°"

    ratio = results["pose_dmp_vs_cartesian_dmp"]
    theirs = results["cartesian_dmp_fit_rollout_ms"]
    return [
        (
            "orientation_dmp_rms_deg: geodesic RMS error of our pose DMP's orientation, "
            "turns of 150 / 270 deg about a tilted axis (2000 samples over 4 s, N = 50, 1 ms)",
            errors("orientation_dmp"),
            "",
            None,
        ),
        (
            "cartesian_dmp_rms_deg: the same for movement_primitives 0.9.1's CartesianDMP",
            errors("cartesian_dmp"),
            "",
            None,
        ),
        (
            "pose_dmp_vs_cartesian_dmp: our pose fit + rollout (150 deg) / CartesianDMP's "
            f"({results['pose_dmp_fit_rollout_ms']:.0f} ms / "
            + ("n/a" if theirs is None else f"{theirs:.0f} ms")
            + ")",
            "n/a" if ratio is None else number(ratio),
            "",
            None,
        ),
    ]


SMOKE_HEADER = "quick smoke run (shortened runs: not measurements, no target judged)"


def table(results: dict) -> Table:
    """bench.json's measures and their targets as a Table; a quick smoke run's measures
    only, under a header that says so, without targets or verdicts.

    Parameters
    ----------
    results : dict
        The bench.json content.
    """
    if is_quick(results):
        smoke = Table([SMOKE_HEADER, "value"])
        for measure, value, _, _ in _rows(results):
            smoke.add(measure, value)
        return smoke
    result = Table(["measure", "value", "target", ""])
    for measure, value, target, met in _rows(results):
        result.add(measure, value, target, "" if met is None else ("met" if met else "**missed**"))
    return result
