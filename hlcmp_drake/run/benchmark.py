"""Where the time goes: the measurements behind docs/performance.md (hlcmp bench).

Every ratio is measured side by side in one invocation, the two sides alternating, and
reported as the median of the pair ratios, since a shared 2-core machine is noisy.
"""

import platform
import statistics
import tempfile
import time

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.controllers import InverseDynamicsController
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core.dmp import Dmp, DmpSettings, basis_centers_and_widths
from hlcmp_drake.experiments import EXPERIMENTS
from hlcmp_drake.experiments.table import Table, number
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.run.runner import run_scenario
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.systems.hlcmp_controller import HlcmpController, HlcmpGains
from hlcmp_drake.worlds.build import diagram_factory
from hlcmp_drake.worlds.models import add_plant, load_models


def _wall(function):
    start = time.perf_counter()
    result = function()
    return time.perf_counter() - start, result


def insertion_runs(duration: float, repetitions: int) -> dict:
    """insertion_rtf and controller_overhead_ratio: the Hl-CMP insertion run against the
    same world and contact driven along the Hl-CMP run's own joint motion by Drake's C++
    InverseDynamicsController, alternating.

    Parameters
    ----------
    duration : float
        Simulated seconds of each run.
    repetitions : int
        Pairs of runs; ratios are the median of the pair ratios.
    """
    scenario, _ = load_scenario("insertion", [f"duration_s={duration}"])
    build = diagram_factory(scenario)
    hlcmp_walls, cpp_walls = [], []
    for _ in range(repetitions):
        wall, run = _wall(lambda: simulate(build("hlcmp"), scenario, "hlcmp"))
        hlcmp_walls.append(wall)
        cpp_diagram, plant, q0 = _joint_space_replay(scenario, run)
        cpp_walls.append(_wall(lambda: _simulate_plain(cpp_diagram, plant, q0, scenario))[0])
    ratios = [h / c for h, c in zip(hlcmp_walls, cpp_walls)]
    return {
        "insertion_rtf": duration / statistics.median(hlcmp_walls),
        "controller_overhead_ratio": statistics.median(ratios),
        "insertion_hlcmp_wall_s": hlcmp_walls,
        "insertion_cpp_controller_wall_s": cpp_walls,
        "insertion_simulated_s": duration,
    }


def _joint_space_replay(scenario, run):
    """The same plant, driven by InverseDynamicsController along the run's logged joint
    positions and velocities (piecewise-linear between the 100 Hz log samples)."""
    builder = DiagramBuilder()
    plant, _ = add_plant(builder, scenario)
    nq = plant.num_positions()
    states = run.series["plant_state"]
    trajectory = PiecewisePolynomial.FirstOrderHold(run.t, states.T)
    source = builder.AddSystem(TrajectorySource(trajectory))
    control_plant = _control_plant(scenario)
    controller = builder.AddSystem(InverseDynamicsController(
        control_plant, kp=np.full(nq, 400.0), ki=np.zeros(nq), kd=np.full(nq, 40.0),
        has_reference_acceleration=False))
    builder.Connect(plant.get_state_output_port(), controller.get_input_port_estimated_state())
    builder.Connect(source.get_output_port(), controller.get_input_port_desired_state())
    builder.Connect(controller.get_output_port_control(), plant.get_actuation_input_port())
    return builder.Build(), plant, states[0, :nq]


def _control_plant(scenario):
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    load_models(plant, scenario)
    return plant


def _simulate_plain(diagram, plant, q0, scenario):
    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator_config, simulator)
    plant.SetPositions(plant.GetMyMutableContextFromRoot(simulator.get_mutable_context()), q0)
    simulator.AdvanceTo(scenario.duration_s)


def controller_eval_us(basis_counts: tuple = (10, 50, 200), iterations: int = 2000) -> dict:
    """Median and p99 of one evaluation of the Hl-CMP's derivatives (Eq. 31) plus its force
    output (Eqs. 33-34) at a contact-like state, by basis count N. The state is nudged
    before each evaluation so that Drake's caches cannot answer from the last one.

    Parameters
    ----------
    basis_counts : tuple of int
        The N to measure.
    iterations : int
        Evaluations per N.

    Returns
    -------
    dict
        {str(N): {"median", "p99"}} in microseconds.
    """
    out = {}
    rng = np.random.default_rng(0)
    for n in basis_counts:
        centers, widths = basis_centers_and_widths(n, 4.0)
        gains = HlcmpGains(np.full(3, 3000.0), np.full(3, 90.0), np.full(3, 9.0), 5.0, np.full(3, 10.0))
        theta = rng.uniform(0, 50, 9 * n)
        controller = HlcmpController(centers, widths, gains, theta)
        context = controller.CreateDefaultContext()
        inputs = dict(position=[0.60, 0.0, 0.31], velocity=[0.0, 0.0, -0.02],
                      desired_position=[0.60, 0.0, 0.30], desired_velocity=[0.0, 0.0, -0.03],
                      desired_acceleration=[0.0, 0.0, 0.01], phase=[0.3],
                      task_inertia=np.diag([4.0, 4.0, 3.0]).ravel(), task_coriolis=np.zeros(9),
                      task_gravity=[0.0, 0.0, 60.0])
        for name, value in inputs.items():
            controller.GetInputPort(name).FixValue(context, value)
        force = controller.GetOutputPort("force")
        samples = []
        for k in range(iterations):
            theta[0] = k   # invalidates the cache entry, as a new integrator stage would
            context.SetContinuousState(theta)
            start = time.perf_counter()
            controller.EvalTimeDerivatives(context)
            force.Eval(context)
            samples.append((time.perf_counter() - start) * 1e6)
        out[str(n)] = {"median": float(np.median(samples)), "p99": float(np.percentile(samples, 99))}
    return out


def _demo(samples=2000):
    t = np.linspace(0.0, 4.0, samples)
    u = t / 4.0
    smooth = 10 * u**3 - 15 * u**4 + 6 * u**5
    return t, np.column_stack([0.3 * smooth, 0.1 * np.sin(np.pi * u) ** 2, 0.4 - 0.2 * smooth])


def dmp_timings(repetitions: int) -> dict:
    """dmp_fit_ms, dmp_rollout_ms (3 axes, 2000 samples, N = 50, rollout at 1 ms), and,
    when movement_primitives is installed, our time over its time for the same fit and
    rollout, alternating.

    Parameters
    ----------
    repetitions : int
        Timed repetitions of each (medians are reported).
    """
    t, positions = _demo()
    settings = DmpSettings(n_basis=50, smoothing_s=0.0)
    ours_fit, ours_rollout, theirs = [], [], []
    try:
        from movement_primitives.dmp import DMP
    except ImportError:
        DMP = None
    for _ in range(repetitions):
        fit_s, dmp = _wall(lambda: Dmp.fit(t, positions, "xyz", settings))
        rollout_s, _ = _wall(lambda: dmp.rollout(dt=0.001))
        ours_fit.append(fit_s)
        ours_rollout.append(rollout_s)
        if DMP is not None:
            def reference():
                other = DMP(n_dims=3, execution_time=float(t[-1]), dt=0.001, n_weights_per_dim=50)
                other.imitate(t, positions)
                other.open_loop()
            theirs.append(_wall(reference)[0])
    out = {"dmp_fit_ms": 1e3 * statistics.median(ours_fit),
           "dmp_rollout_ms": 1e3 * statistics.median(ours_rollout)}
    if theirs:
        out["dmp_vs_movement_primitives"] = statistics.median(
            [(f + r) / m for f, r, m in zip(ours_fit, ours_rollout, theirs)])
        out["movement_primitives_fit_and_rollout_ms"] = 1e3 * statistics.median(theirs)
    else:
        out["dmp_vs_movement_primitives"] = None
        out["movement_primitives_note"] = "not installed: pip install -e '.[bench]'"
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
            out[name] = _wall(lambda: run_scenario(name, folder, overrides=overrides))[0]
    return out


def run_benchmark(quick: bool = False, reporter: Progress = SILENT) -> dict:
    """All measurements: the bench.json content.

    Parameters
    ----------
    quick : bool
        A few iterations of everything, for CI (no thresholds).
    reporter : Progress, optional
        Told what is being measured.
    """
    results = {"machine": {"python": platform.python_version(), "processor": platform.processor(),
                           "mode": "quick" if quick else "full"}}
    reporter.say("insertion: Hl-CMP vs. C++ inverse dynamics along the same motion ...")
    results.update(insertion_runs(duration=1.0 if quick else 9.5, repetitions=1 if quick else 3))
    reporter.say("controller evaluation ...")
    results["controller_eval_us"] = controller_eval_us(iterations=50 if quick else 2000)
    reporter.say("DMP fit and rollout ...")
    results.update(dmp_timings(repetitions=2 if quick else 15))
    reporter.say("bundled scenarios ...")
    results["scenario_wall_s"] = scenario_walls(list(EXPERIMENTS), duration=0.5 if quick else None)
    return results


# The targets, once: (measure, its value from bench.json, the target's text, met?).
def _rows(results):
    eval_us = results["controller_eval_us"]
    ratio = results.get("dmp_vs_movement_primitives")
    rows = [
        ("insertion_rtf: simulated s per wall s, Hl-CMP insertion (9.5 s, no recording)",
         number(results["insertion_rtf"]), "≥ 2", results["insertion_rtf"] >= 2),
        ("controller_overhead_ratio: Hl-CMP run / same world driven by Drake's C++ "
         "InverseDynamicsController along the same joint motion",
         number(results["controller_overhead_ratio"]), "≤ 1.3", results["controller_overhead_ratio"] <= 1.3),
    ]
    for n, v in eval_us.items():
        rows.append((f"controller_eval_us, N = {n}: derivatives + force output, median / p99",
                     f"{v['median']:.0f} / {v['p99']:.0f} µs", "p99 ≤ 100" if n == "50" else "",
                     v["p99"] <= 100 if n == "50" else None))
    rows += [
        ("dmp_fit_ms: 3 axes, 2000 samples, N = 50", f"{results['dmp_fit_ms']:.1f} ms", "", None),
        ("dmp_rollout_ms: the same DMP at 1 ms steps", f"{results['dmp_rollout_ms']:.1f} ms", "", None),
        ("dmp_vs_movement_primitives: our fit + rollout / movement_primitives 0.9.1's",
         "n/a" if ratio is None else number(ratio), "≤ 1.0", None if ratio is None else ratio <= 1.0),
    ]
    rows += [(f"wall time of `hlcmp run {name}` (all its controllers, figures, recording)", f"{wall:.1f} s", "", None)
             for name, wall in results["scenario_wall_s"].items()]
    return rows


def table(results: dict) -> Table:
    """bench.json's measures and their targets as a Table.

    Parameters
    ----------
    results : dict
        The bench.json content.
    """
    result = Table(["measure", "value", "target", ""])
    for measure, value, target, met in _rows(results):
        result.add(measure, value, target, "" if met is None else ("met" if met else "**missed**"))
    return result
