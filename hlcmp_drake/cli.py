"""The `hlcmp` command line.

    hlcmp run SCENARIO [--out DIR] [--set KEY=VALUE ...] [--iiwa ours|drake_models]
    hlcmp report [--out DIR] [--scenarios NAME|YAML ...] [--jobs N]   scenarios, one offline page
    hlcmp learn DEMO.csv --scenario S --out DIR [--trials K] [--skill SKILL.npz [--any-scenario]]
    hlcmp reproduce SKILL.npz --scenario S --out DIR [--freeze] [--any-scenario]
    hlcmp bench [--out DIR] [--quick]        measure where the time goes
    hlcmp fit DEMO.csv --out SKILL.npz       fit the DMP of a demonstration
    hlcmp rollout SKILL.npz --out TRAJ.csv   roll a skill's DMP out
    hlcmp sweep SWEEP.yaml [--out DIR] [--engine local|ray] [--address A] [--workers N] [--dry-run]
    hlcmp serve SCENARIO --lcm URL [--controller C] [--skill SKILL.npz [--freeze]
                [--any-scenario]] [--duration S] [--out DIR]
    hlcmp sim-driver SCENARIO --lcm URL [--realtime] [--duration S] [--idle-timeout S]

Exit codes: 0 success, 2 bad input (one line on stderr; --debug shows the traceback),
3 a simulation went unstable or a served run was stopped (metrics.json / serve.json say
where and why), 4 the simulated driver aborted.

This module is argparse and printing only: every command calls one library function.
"""

import argparse
import gc
import logging
import os
import sys

import numpy as np

from hlcmp_drake.core.dmp import DmpSettings
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.present.progress import Progress

DEFAULTS = DmpSettings()

EXIT_BAD_INPUT = 2
EXIT_UNSTABLE = 3
EXIT_DRIVER_ABORT = 4
EXIT_DEGRADED = 5  # served to the end, but missed more ticks than iiwa_driver allows


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage problem in one line, like every other bad input."""

    def error(self, message):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see --help)\n")


def _floats(text, what):
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"{what}: expected comma-separated numbers, got '{text}'") from None
    if not all(np.isfinite(values)):
        raise InputError(f"{what}: values must be finite, got '{text}'")
    return values


def _number(text, minimum, inclusive):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got '{text}'") from None
    if not (np.isfinite(value) and (value >= minimum if inclusive else value > minimum)):
        kind = "a non-negative" if inclusive else "a positive"
        raise argparse.ArgumentTypeError(f"must be {kind} number, got '{text}'")
    return value


def _positive(text):
    return _number(text, 0.0, inclusive=False)


def _non_negative(text):
    return _number(text, 0.0, inclusive=True)


def _trial_count(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got '{text}'") from None
    if not 1 <= value <= 100:
        raise argparse.ArgumentTypeError(f"must be between 1 and 100, got {value}")
    return value


def _whole_number(text):
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got '{text}'") from None


def _quiet_drake(args):
    """Drake's INFO lines (the Meshcat server a recording starts, package downloads) are
    not for this command's user; warnings and errors still show. pydrake sets this
    logger's level when it is imported, so call this after importing it."""
    if not args.debug:
        logging.getLogger("drake").setLevel(logging.WARNING)


def _print_table(table):
    from hlcmp_drake.present.tables import to_text

    print(to_text(table))


def _verdict_word(holds):
    from hlcmp_drake.experiments.claims import NOT_JUDGED

    return NOT_JUDGED if holds is None else ("reproduced" if holds else "NOT reproduced")


def print_summary(result) -> None:
    """A scenario's table, instabilities, claims and where its files went."""
    metrics = result.metrics
    _print_table(result.table)
    for controller, problem in metrics.get("instability", {}).items():
        print(
            f"UNSTABLE {controller}: {problem['reason']} at t = {problem['time_s']:.3f} s "
            "(stopped there; its logs up to then are in timeseries.npz)"
        )
    for learner, claims in metrics.get("claims", {}).items():
        for claim, verdict in claims.items():
            print(
                f"{claim} [{learner}]: {_verdict_word(verdict['holds'])} -- {verdict['evidence']}"
            )
    print(f"status: {metrics['status']}; results in {result.out_dir}")


def cmd_run(args):
    from hlcmp_drake.run.runner import run_scenario

    _quiet_drake(args)
    meshcat = None
    if args.meshcat:
        from pydrake.geometry import Meshcat

        meshcat = Meshcat()
        print(
            f"live view: {meshcat.web_url()} (open it in a browser; it closes when the command "
            "ends)",
            flush=True,
        )
    try:
        result = run_scenario(
            args.scenario,
            args.out,
            reporter=Progress(args.quiet),
            drake_models_iiwa=args.iiwa == "drake_models",
            overrides=args.set,
            meshcat=meshcat,
        )
    finally:
        # The live view's replay diagrams keep the Meshcat in reference cycles (pybind keep-alives),
        # so its server would outlive the command until Python's next collection.
        if meshcat is not None:
            del meshcat
            gc.collect()
    print_summary(result)
    return EXIT_UNSTABLE if result.metrics["status"] != "ok" else 0


def cmd_report(args):
    from hlcmp_drake.run.report import run_report

    _quiet_drake(args)
    result = run_report(args.out, args.scenarios, Progress(args.quiet), jobs=args.jobs)
    print(
        f"report: {result.page} ({result.wall_s:.0f} s for "
        f"{', '.join(s.name for s in result.sections)})"
    )
    return 0 if result.all_ok else EXIT_UNSTABLE


def cmd_learn(args):
    from hlcmp_drake.io.skill import load_skill
    from hlcmp_drake.run.learning import learn

    skill = load_skill(args.skill) if args.skill else None
    if args.any_scenario and skill is None:
        raise InputError("--any-scenario needs --skill: it lets a skill from another world start")
    result = learn(
        args.scenario,
        args.out,
        demo=args.demo,
        skill=skill,
        skill_path=args.skill,
        trials=args.trials,
        any_scenario=args.any_scenario,
        **_learning_options(args),
    )
    return _print_learning(result)


def cmd_reproduce(args):
    from hlcmp_drake.io.skill import load_skill
    from hlcmp_drake.run.learning import reproduce

    result = reproduce(
        args.scenario,
        args.out,
        load_skill(args.skill),
        skill_path=args.skill,
        freeze=args.freeze,
        any_scenario=args.any_scenario,
        **_learning_options(args),
    )
    return _print_learning(result)


def _learning_options(args):
    """What learn and reproduce both take from the command line."""
    _quiet_drake(args)
    return dict(
        reporter=Progress(args.quiet),
        overrides=args.set,
        warn=_warn,
    )


def _warn(line):
    print(f"hlcmp: warning: {line}", file=sys.stderr)


def _print_learning(result):
    from hlcmp_drake.run.learning import trials_table

    _print_table(trials_table(result.metrics))
    if result.skill_path is not None:
        print(f"skill: {result.skill_path}")
    print(f"status: {result.metrics['status']}; results in {result.out_dir}")
    return EXIT_UNSTABLE if result.metrics["status"] != "ok" else 0


def cmd_bench(args):
    from pathlib import Path

    from hlcmp_drake.io.outputs import write_json
    from hlcmp_drake.run.benchmark import run_benchmark, table

    _quiet_drake(args)
    results = run_benchmark(quick=args.quick, reporter=Progress(stream=sys.stderr))
    path = write_json(Path(args.out) / "bench.json", results)
    _print_table(table(results))
    smoke = " (a quick smoke run: no target judged; `hlcmp bench` measures)" if args.quick else ""
    print(f"bench.json: {path}{smoke}")
    return 0


def cmd_probe(args):
    from hlcmp_drake.run.probe import run_probe

    _quiet_drake(args)
    result = run_probe(args.scenario, args.out, speed=args.speed, overrides=args.set)
    readings = result.readings
    print(
        f"probe {readings['scenario']} at {readings['speed_m_per_s']:.3f} m/s: peak "
        f"{readings['peak_force_N']:.2f} N "
        f"at {1000 * readings['depth_at_peak_m']:.1f} mm, residual "
        f"{readings['residual_force_N']:.2f} N, "
        f"max lateral {readings['max_lateral_force_N']:.3f} N; {readings['status']}"
    )
    print(f"probe.json, probe.png in {result.out_dir}")
    return 0 if readings["status"] == "ok" else EXIT_UNSTABLE


def cmd_fit(args):
    from hlcmp_drake.core.dmp import Dmp
    from hlcmp_drake.io.demos import read_demonstration
    from hlcmp_drake.io.skill import Skill, save_skill

    try:
        settings = DmpSettings(n_basis=args.basis, smoothing_s=args.smoothing)
    except ValueError as error:  # the message starts with the settings' field
        option = "--basis" if str(error).startswith("n_basis") else "--smoothing"
        raise InputError(f"{option}: {error}") from None
    t, positions, axes = read_demonstration(args.demo)
    dmp = Dmp.fit(t, positions, axes, settings)
    save_skill(args.out, Skill.untrained(dmp))
    flat = [a for a, scaled in zip(axes, dmp.goal_scaled) if not scaled]
    print(
        f"fitted {len(axes)} axis DMP ({','.join(axes)}), N = {args.basis}, tau = {dmp.tau:.3f} s"
        + (f"; g ~ p0 on {','.join(flat)}: amplitude = demonstration range" if flat else "")
        + f" -> {args.out}"
    )
    return 0


def cmd_rollout(args):
    from hlcmp_drake.io.demos import write_trajectory
    from hlcmp_drake.io.skill import load_skill

    dmp = load_skill(args.skill).dmp
    if args.goal is not None:
        goal = _floats(args.goal, "--goal")
        if len(goal) != dmp.n_axes:
            raise InputError(
                f"--goal: the skill has {dmp.n_axes} axes ({','.join(dmp.axis_names)}), "
                f"got {len(goal)} value(s)"
            )
        dmp = dmp.with_goal(goal)
    tau = args.duration or dmp.tau
    if tau / args.dt > 2_000_000:
        raise InputError(f"--dt {args.dt} s over {tau} s would write more than 2,000,000 samples")
    t, p, v, _, _ = dmp.rollout(dt=args.dt, tau=tau)
    write_trajectory(args.out, t, p, dmp.axis_names, v)
    print(f"rolled out {len(t)} samples over {t[-1]:.3f} s -> {args.out}")
    return 0


def _positive_count(text):
    value = _whole_number(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def cmd_sweep(args):
    from pathlib import Path

    from hlcmp_drake.run.sweep import plan_sweep, run_sweep

    if args.dry_run:
        plan = plan_sweep(args.sweep, args.out)
        counts = {
            state: list(plan.states.values()).count(state) for state in ("done", "stale", "pending")
        }
        print(
            f"sweep {plan.sweep.path}: {len(plan.tasks)} tasks of {plan.sweep.scenario_path.name} "
            "into "
            f"{plan.out_dir} ({counts['done']} done, {counts['stale']} to rerun (changed), "
            f"{counts['pending']} to run)"
        )
        for task in plan.tasks:
            print(f"  {plan.states[task.id]:8s} {task.id}   " + " ".join(task.overrides))
        return 0
    _quiet_drake(args)
    try:
        result = run_sweep(
            args.sweep, args.out, args.engine, args.workers, args.address, Progress(args.quiet)
        )
    except KeyboardInterrupt:
        out = args.out or f"out/sweeps/{Path(args.sweep).stem}"
        print(
            f"hlcmp: interrupted; every finished task is kept (listed in {out}/sweep.csv); "
            "the same command again runs only the rest",
            file=sys.stderr,
        )
        return 130
    counts = result.summary["counts"]
    _print_table(result.table)
    for task_id, error in result.failed.items():
        print(f"FAILED {task_id}: {error}")
    for task_id in result.unstable:
        print(f"UNSTABLE {task_id} (its metrics.json says where and why)")
    for problem in result.missing:
        print(f"metric not found: {problem}")
    if not result.ran:
        print(f"all {counts['tasks']} tasks were already done; nothing to run")
    else:
        done = result.already_done
        print(
            f"{len(result.ran)} task(s) ran, {done} {'was' if done == 1 else 'were'} already done"
            + (f", {result.stale} ran again because their scenario changed" if result.stale else "")
            + (f", {len(result.failed)} failed (a re-run retries them)" if result.failed else "")
            + f"; {result.wall_s:.1f} s"
        )
    print(f"results in {result.out_dir}: sweep.csv, sweep.json, plots/, tasks/")
    if result.failed:
        return 1
    if result.missing:
        return EXIT_BAD_INPUT
    return EXIT_UNSTABLE if result.unstable else 0


def cmd_serve(args):
    from hlcmp_drake.io.skill import load_skill
    from hlcmp_drake.run.serve import serve_scenario
    from hlcmp_drake.run.sim_driver import DriverAbort

    _quiet_drake(args)
    skill = load_skill(args.skill) if args.skill else None
    if args.any_scenario and skill is None:
        raise InputError("--any-scenario needs --skill: it lets a skill from another world serve")
    overrides = list(args.set) + ([f"duration_s={args.duration}"] if args.duration else [])
    try:
        result = serve_scenario(
            args.scenario,
            args.lcm,
            args.out or _default_out(args),
            controller=args.controller,
            skill=skill,
            freeze=args.freeze,
            any_scenario=args.any_scenario,
            overrides=overrides,
            reporter=Progress(args.quiet),
            warn=_warn,
        )
    except DriverAbort as error:  # memq://: the simulated driver runs in this process
        print(f"hlcmp serve: the simulated driver aborted: {error}", file=sys.stderr)
        return EXIT_DRIVER_ABORT
    record = result.record
    ticks = record["tick_us"]
    timing = (
        f"tick p50 {ticks['p50']:.0f} us, p99 {ticks['p99']:.0f} us"
        if ticks["p50"] is not None
        else "no tick"
    )
    print(
        f"served {record['controller']} for {record['served_s']:.3f} s: {record['ticks']} ticks, "
        f"{record['missed_ticks']} missed, {timing}"
    )
    print(f"{record['status']}: {record['stopped_because']}")
    served = ", timeseries.npz, recording.html" if len(result.run.t) else ""
    print(f"serve.json, metrics.json{served} in {result.out_dir}")
    if record["status"] == "degraded":
        return EXIT_DEGRADED
    return 0 if record["status"] == "ok" else EXIT_UNSTABLE


def cmd_sim_driver(args):
    from hlcmp_drake.run.sim_driver import DriverAbort, run_sim_driver

    _quiet_drake(args)
    try:
        summary = run_sim_driver(
            args.scenario,
            args.lcm,
            args.realtime,
            args.duration,
            args.idle_timeout,
            args.set,
            Progress(args.quiet),
        )
    except DriverAbort as error:
        print(f"hlcmp sim-driver: aborted: {error}", file=sys.stderr)
        return EXIT_DRIVER_ABORT
    late = f", {summary.late_steps} late" if args.realtime else ""
    print(
        f"sim-driver: {summary.steps} steps ({summary.commanded_steps} commanded, "
        f"{summary.held_steps} held{late}), "
        f"{summary.sim_time_s:.3f} s simulated in {summary.wall_s:.1f} s; {summary.stopped_because}"
    )
    return 0


def build_parser():
    from hlcmp_drake import __version__
    from hlcmp_drake.io.paths import bundled_scenarios

    bundled = bundled_scenarios()
    # --debug and --quiet are accepted before or after the subcommand.
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help="show tracebacks of errors"
    )
    quiet = argparse.ArgumentParser(add_help=False)
    quiet.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    overrides = argparse.ArgumentParser(add_help=False)
    overrides.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scenario value, e.g. duration_s=4 or "
        "controllers.hlcmp.q_k=[300,300,300] (repeatable)",
    )

    world = argparse.ArgumentParser(add_help=False)  # where learn and reproduce run
    world.add_argument(
        "--scenario", required=True, help="the world: insertion, cutting, or a YAML path"
    )
    world.add_argument(
        "--any-scenario",
        action="store_true",
        help="use a skill learned in another world (scenario) all the same",
    )

    parser = _Parser(
        prog="hlcmp",
        description="Hl-CMPs: learn human-like compliant skills on Drake.",
        parents=[common],
    )
    parser.add_argument("--version", action="version", version=f"hlcmp_drake {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    run = sub.add_parser(
        "run", parents=[common, quiet, overrides], help="run a scenario (bundled name or YAML path)"
    )
    run.add_argument(
        "scenario", help=f"a bundled scenario ({', '.join(bundled)}) or a scenario .yaml"
    )
    run.add_argument("--out", help="output folder (default out/SCENARIO)")
    run.add_argument(
        "--meshcat",
        action="store_true",
        help="also show the runs in a live Meshcat while they simulate (prints its URL)",
    )
    run.add_argument(
        "--iiwa",
        choices=("ours", "drake_models"),
        default="ours",
        help="the iiwa14 model: ours (models/iiwa14.sdf, default) or Drake's official "
        "one from drake_models (downloaded by Drake on first use: needs internet)",
    )
    run.set_defaults(func=cmd_run)

    report = sub.add_parser(
        "report",
        parents=[common, quiet],
        help="run every bundled scenario and write one offline report page",
    )
    report.add_argument("--out", default="out/report", help="output folder (default out/report)")
    report.add_argument(
        "--scenarios",
        nargs="+",
        metavar="SCENARIO",
        help=f"what to run, in this order: bundled scenarios ({', '.join(bundled)}) or "
        "scenario .yaml paths of your own (default every bundled one, in the paper's order)",
    )
    report.add_argument(
        "--jobs",
        type=_positive_count,
        help="runs and probes at once, each in a process of its own (default: the number of "
        "CPUs; 1 runs them one after the other in this process)",
    )
    report.set_defaults(func=cmd_report)

    bench = sub.add_parser(
        "bench", parents=[common], help="measure where the time goes (bench.json and a table)"
    )
    bench.add_argument(
        "--out", default="out/bench", help="output folder for bench.json (default out/bench)"
    )
    bench.add_argument(
        "--quick", action="store_true", help="a few iterations of everything (CI smoke mode)"
    )
    bench.set_defaults(func=cmd_bench)

    learn = sub.add_parser(
        "learn",
        parents=[common, quiet, overrides, world],
        help="learn a skill from your demonstration by reproducing it in a scenario",
    )
    learn.add_argument(
        "demo", help="demonstration CSV (t,x,y,z; world frame of the scenario, metres)"
    )
    learn.add_argument(
        "--out",
        required=True,
        help="output folder: the learned skill.npz, metrics, figures, recording",
    )
    learn.add_argument(
        "--trials",
        type=_trial_count,
        default=1,
        help="reproductions, each continuing from the previous one's learned profiles (default 1)",
    )
    learn.add_argument(
        "--skill", help="start from this saved skill's profiles instead of theta = 0"
    )
    learn.set_defaults(func=cmd_learn)

    reproduce = sub.add_parser(
        "reproduce",
        parents=[common, quiet, overrides, world],
        help="replay a learned skill in a scenario",
    )
    reproduce.add_argument("skill", help="skill file (.npz) from hlcmp learn or fit")
    reproduce.add_argument(
        "--out",
        required=True,
        help="output folder: metrics, figures, recording; and the skill.npz it goes on "
        "learning unless --freeze",
    )
    reproduce.add_argument(
        "--freeze", action="store_true", help="no adaptation: the learned profiles as they are"
    )
    reproduce.set_defaults(func=cmd_reproduce)

    probe = sub.add_parser(
        "probe",
        parents=[common, overrides],
        help="measure a scenario's world alone: its tool pushed through its object",
    )
    probe.add_argument(
        "scenario", help="an arm scenario with a probe section (insertion, cutting) or a YAML path"
    )
    probe.add_argument("--out", help="output folder (default out/probe_SCENARIO)")
    probe.add_argument(
        "--speed", type=_positive, help="carriage speed in m/s (default the scenario's)"
    )
    probe.set_defaults(func=cmd_probe)

    fit = sub.add_parser(
        "fit", parents=[common], help="fit the DMP of a demonstration CSV (t,x,y,z)"
    )
    fit.add_argument("demo", help="demonstration CSV: t,x,y,z (time in s, then 1-3 positions in m)")
    fit.add_argument("--out", required=True, help="skill file to write (.npz)")
    fit.add_argument(
        "--basis",
        type=_whole_number,
        default=DEFAULTS.n_basis,
        help=f"basis functions N (default {DEFAULTS.n_basis})",
    )
    fit.add_argument(
        "--smoothing",
        type=_non_negative,
        default=DEFAULTS.smoothing_s,
        help=f"std-dev in s of the Gaussian smoothing before differentiation "
        f"(default {DEFAULTS.smoothing_s}; about 0.05 removes a hand's 8-12 Hz tremor)",
    )
    fit.set_defaults(func=cmd_fit)

    rollout = sub.add_parser(
        "rollout", parents=[common], help="roll a skill's DMP out into a trajectory CSV"
    )
    rollout.add_argument("skill", help="skill file (.npz) from hlcmp fit or hlcmp learn")
    rollout.add_argument("--out", required=True, help="trajectory CSV to write")
    rollout.add_argument(
        "--duration", type=_positive, help="new duration tau in s (temporal scaling)"
    )
    rollout.add_argument("--goal", help="new goal, comma-separated, one value per axis")
    rollout.add_argument(
        "--dt", type=_positive, default=0.01, help="sample period in s (default 0.01)"
    )
    rollout.set_defaults(func=cmd_rollout)

    sweep = sub.add_parser(
        "sweep",
        parents=[common, quiet],
        help="run a scenario over a grid or list of overrides (resumable)",
    )
    sweep.add_argument(
        "sweep", help="a sweep file (.yaml) or a bundled sweep's name (diagrams/sweeps/)"
    )
    sweep.add_argument(
        "--out",
        help="output folder (default out/sweeps/SWEEP): sweep.csv, sweep.json, "
        "plots/, and tasks/ID/ per task; finished tasks there are skipped",
    )
    sweep.add_argument(
        "--engine",
        choices=("local", "ray"),
        default="local",
        help="local: a process pool on this machine (default); ray: Ray tasks, "
        "needs pip install -e '.[ray]'",
    )
    sweep.add_argument("--address", help="with --engine ray: join the Ray cluster at this address")
    sweep.add_argument(
        "--workers", type=_positive_count, help="tasks at once (local default: the number of CPUs)"
    )
    sweep.add_argument(
        "--dry-run", action="store_true", help="list the tasks and which are done; run nothing"
    )
    sweep.set_defaults(func=cmd_sweep)

    lcm_help = (
        "LCM URL, e.g. 'udpm://239.255.76.67:7667?ttl=0' (this machine only); memq:// runs "
        "the scenario's simulated driver in the same process"
    )
    serve = sub.add_parser(
        "serve",
        parents=[common, quiet, overrides],
        help="serve a scenario's controller to an iiwa driver over LCM (torque-only)",
    )
    serve.add_argument("scenario", help="an arm scenario (insertion, cutting) or a YAML path")
    serve.add_argument("--lcm", required=True, help=lcm_help)
    serve.add_argument(
        "--controller", help="the controller's label (default: the scenario's Hl-CMP)"
    )
    serve.add_argument(
        "--skill", help="serve the Hl-CMP from this skill file's DMP and learned profiles"
    )
    serve.add_argument("--freeze", action="store_true", help="with --skill: no adaptation")
    serve.add_argument(
        "--any-scenario",
        action="store_true",
        help="with --skill: serve a skill learned in another world (scenario) all the same",
    )
    serve.add_argument(
        "--duration", type=_positive, help="seconds to serve (default the scenario's duration_s)"
    )
    serve.add_argument("--out", help="output folder (default out/serve_SCENARIO)")
    serve.set_defaults(func=cmd_serve)

    sim_driver = sub.add_parser(
        "sim-driver",
        parents=[common, quiet, overrides],
        help="a scenario's simulated iiwa, driven over LCM like drake-iiwa-driver "
        "in torque-only mode (status every 1 ms)",
    )
    sim_driver.add_argument("scenario", help="an arm scenario (insertion, cutting) or a YAML path")
    sim_driver.add_argument("--lcm", required=True, help=lcm_help)
    sim_driver.add_argument(
        "--realtime",
        action="store_true",
        help="one period of wall-clock time per step (default: as fast as the client answers)",
    )
    sim_driver.add_argument(
        "--duration",
        type=_positive,
        help="stop at this simulated time in s (default: when the client stops commanding)",
    )
    sim_driver.add_argument(
        "--idle-timeout",
        type=_positive,
        default=1.0,
        help="seconds without a command after which the client counts as gone (default 1)",
    )
    sim_driver.set_defaults(func=cmd_sim_driver)
    return parser


# Commands whose --out is a file; every other --out is a folder.
WRITES_A_FILE = ("fit", "rollout")


def _default_out(args):
    """Where a command writes when --out is not given and its default depends on what it
    runs (run: out/SCENARIO, probe: out/probe_SCENARIO, serve: out/serve_SCENARIO, sweep:
    out/sweeps/SWEEP)."""
    from pathlib import Path

    if args.command in ("run", "probe", "serve"):
        from hlcmp_drake.config.loading import load_scenario

        scenario, _ = load_scenario(args.scenario, args.set)
        prefix = {"run": "", "probe": "probe_", "serve": "serve_"}[args.command]
        return Path("out") / f"{prefix}{scenario.name}"
    if args.command == "sweep":
        from hlcmp_drake.config.sweep import load_sweep
        from hlcmp_drake.run.sweep import default_out_dir

        return default_out_dir(load_sweep(args.sweep))
    return None


def _check_kernel():
    """Refuse an HLCMP_KERNEL the tick cannot run (exit 2), before any work is done."""
    from hlcmp_drake.core.kernels import KERNEL_VARIABLE, kernel_path

    if not os.environ.get(KERNEL_VARIABLE):
        return  # the default path: compiled where numba imports, numpy elsewhere
    try:
        kernel_path()
    except ValueError as error:
        raise InputError(f"environment: {error}") from None


def _check_output(args):
    """Refuse an output path that cannot be written before any work is done (exit 2)."""

    from hlcmp_drake.io.outputs import check_output_file, check_output_folder

    if getattr(args, "dry_run", False):  # writes nothing: a read-only sweep may be looked at
        return
    out = getattr(args, "out", None)
    if out is None:
        default = _default_out(args)
        if default is not None:
            check_output_folder(default, "output folder")
        return
    if args.command in WRITES_A_FILE:
        check_output_file(out)
        return
    check_output_folder(out)
    if args.command == "report" and args.scenarios:  # one folder per scenario, by its name
        from hlcmp_drake.run.report import report_folders

        for folder in report_folders(out, args.scenarios).values():
            check_output_folder(folder, "--out")


def main(argv=None):
    from hlcmp_drake.io.outputs import WRITTEN

    parser = build_parser()
    args = parser.parse_args(argv)
    args.debug = getattr(args, "debug", False)
    WRITTEN.clear()  # this command's files only (main may run more than once in a process)
    try:
        _check_kernel()
        _check_output(args)
        return args.func(args)
    except InputError as error:
        if args.debug:
            raise
        print(f"hlcmp: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        done = (
            f"written before it: {', '.join(map(str, WRITTEN))}"
            if WRITTEN
            else "nothing was written"
        )
        print(f"hlcmp: interrupted; {done}; every other file is as it was before", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
