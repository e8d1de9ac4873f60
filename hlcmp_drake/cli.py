"""The `hlcmp` command line.

    hlcmp run SCENARIO [--out DIR] [--iiwa ours|drake_models]   run a scenario
    hlcmp report [--out DIR]                 every bundled scenario and one offline page
    hlcmp learn DEMO.csv --scenario S --out DIR [--trials K] [--skill SKILL.npz]
    hlcmp reproduce SKILL.npz --scenario S --out DIR [--freeze]
    hlcmp bench --out DIR [--quick]          measure where the time goes
    hlcmp fit DEMO.csv --out SKILL.npz       fit the DMP of a demonstration
    hlcmp rollout SKILL.npz --out TRAJ.csv   roll a skill's DMP out

Exit codes: 0 success, 2 bad input (one line on stderr; --debug shows the traceback),
3 a simulation went unstable (metrics.json says where and why).
"""

import argparse
import logging
import sys

import numpy as np

from hlcmp_drake.dmp import DmpSettings
from hlcmp_drake.progress import Progress
from hlcmp_drake.errors import InputError

DEFAULT_SMOOTHING_S = DmpSettings().smoothing_s

EXIT_BAD_INPUT = 2
EXIT_UNSTABLE = 3


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


def _basis_count(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got '{text}'") from None
    if value < 2:
        raise argparse.ArgumentTypeError(f"needs at least 2 basis functions, got {value}")
    return value


def _quiet_drake(args):
    """Drake's INFO lines (the Meshcat server a recording starts, package downloads) are
    not for this command's user; warnings and errors still show. pydrake sets this
    logger's level when it is imported, so call this after importing it."""
    if not args.debug:
        logging.getLogger("drake").setLevel(logging.WARNING)


def cmd_run(args):
    from hlcmp_drake.runner import print_summary, run_scenario

    _quiet_drake(args)
    metrics, out_dir, table = run_scenario(args.scenario, args.out, Progress(args.quiet),
                                           drake_models_iiwa=args.iiwa == "drake_models")
    print_summary(metrics, out_dir, table)
    return EXIT_UNSTABLE if metrics["status"] != "ok" else 0


def cmd_report(args):
    import time
    from pathlib import Path

    from hlcmp_drake.outputs import write_text
    from hlcmp_drake.report import report_page
    from hlcmp_drake.runner import run_scenario

    _quiet_drake(args)
    out = Path(args.out)
    progress = Progress(args.quiet)
    sections, status, start = [], 0, time.perf_counter()
    for name in args.scenarios:
        progress.say(f"running {name} ...")
        began = time.perf_counter()
        metrics, run_dir, _ = run_scenario(name, out / name, progress)
        sections.append((name, run_dir, time.perf_counter() - began))
        status = max(status, 0 if metrics["status"] == "ok" else EXIT_UNSTABLE)
    page = write_text(out / "index.html", report_page(out, sections))
    print(f"report: {page} ({time.perf_counter() - start:.0f} s for {', '.join(args.scenarios)})")
    return status


def cmd_learn(args):
    from hlcmp_drake.learning import learning_scenario
    from hlcmp_drake.skill import load_skill

    skill = load_skill(args.skill) if args.skill else None
    return _learn_or_reproduce(args, demo=args.demo, skill=skill, trials=args.trials, freeze=False,
                               fit=True, learning_scenario=learning_scenario)


def cmd_reproduce(args):
    from hlcmp_drake.learning import learning_scenario
    from hlcmp_drake.skill import load_skill

    return _learn_or_reproduce(args, demo=None, skill=load_skill(args.skill), trials=1,
                               freeze=args.freeze, fit=False, learning_scenario=learning_scenario)


def _learn_or_reproduce(args, demo, skill, trials, freeze, fit, learning_scenario):
    from pathlib import Path

    from hlcmp_drake.builders import fit_demonstration
    from hlcmp_drake.learning import trial_outputs
    from hlcmp_drake.runner import write_results
    from hlcmp_drake.scenario import load_scenario
    from hlcmp_drake.skill import Skill, save_skill

    _quiet_drake(args)
    base, _ = load_scenario(args.scenario)
    scenario = learning_scenario(base, demo, skill, freeze)
    dmp = fit_demonstration(scenario) if fit else skill.dmp
    theta0 = (skill.theta_k, skill.theta_d, skill.theta_v) if skill else None
    out = Path(args.out)
    runs, metrics, figures = trial_outputs(scenario, dmp, trials, theta0, Progress(args.quiet),
                                           demo=demo, skill_path=args.skill, frozen=freeze)
    last = list(runs.values())[-1]
    if last.status == "ok" and not freeze:
        save_skill(out / "skill.npz", Skill(dmp, *last.theta))
    write_results(out, scenario, runs, metrics, figures)
    for row in metrics["trials"]:
        print(f"trial {row['trial']}: mean |e| {sum(row['mean_abs_position_error_m'].values()) * 1000:.2f} mm, "
              f"mean |f| {sum(row['mean_abs_force_N'].values()):.2f} N, "
              f"smoothness z {row['force_smoothness_N']['z']:.2f} N, effort {row['effort_N']:.2f} N")
    print(f"status: {metrics['status']}; results in {out}")
    return EXIT_UNSTABLE if metrics["status"] != "ok" else 0


def cmd_bench(args):
    from pathlib import Path

    from hlcmp_drake.benchmark import run_benchmark, table
    from hlcmp_drake.outputs import write_json

    _quiet_drake(args)
    results = run_benchmark(quick=args.quick,
                            progress=lambda message: print(message, file=sys.stderr, flush=True))
    write_json(Path(args.out) / "bench.json", results)
    print(table(results))
    print(f"bench.json in {args.out}")
    return 0


def cmd_fit(args):
    from hlcmp_drake.demos import read_demonstration
    from hlcmp_drake.dmp import Dmp, DmpSettings
    from hlcmp_drake.skill import Skill, save_skill

    t, positions, axes = read_demonstration(args.demo)
    dmp = Dmp.fit(t, positions, axes, DmpSettings(n_basis=args.basis, smoothing_s=args.smoothing))
    save_skill(args.out, Skill.untrained(dmp))
    flat = [a for a, scaled in zip(axes, dmp.goal_scaled) if not scaled]
    print(f"fitted {len(axes)} axis DMP ({','.join(axes)}), N = {args.basis}, tau = {dmp.tau:.3f} s"
          + (f"; g ~ p0 on {','.join(flat)}: amplitude = demonstration range" if flat else "")
          + f" -> {args.out}")
    return 0


def cmd_rollout(args):
    from hlcmp_drake.demos import write_trajectory
    from hlcmp_drake.skill import load_skill

    dmp = load_skill(args.skill).dmp
    if args.goal is not None:
        goal = _floats(args.goal, "--goal")
        if len(goal) != dmp.n_axes:
            raise InputError(f"--goal: the skill has {dmp.n_axes} axes ({','.join(dmp.axis_names)}), "
                             f"got {len(goal)} value(s)")
        dmp = dmp.with_goal(goal)
    tau = args.duration or dmp.tau
    if tau / args.dt > 2_000_000:
        raise InputError(f"--dt {args.dt} s over {tau} s would write more than 2,000,000 samples")
    t, p, v, _, _ = dmp.rollout(dt=args.dt, tau=tau)
    write_trajectory(args.out, t, p, dmp.axis_names, v)
    print(f"rolled out {len(t)} samples over {t[-1]:.3f} s -> {args.out}")
    return 0


def build_parser():
    parser = _Parser(prog="hlcmp", description="Hl-CMPs: learn human-like compliant skills on Drake.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of errors")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    run = sub.add_parser("run", help="run a scenario (bundled name or YAML path)")
    run.add_argument("scenario", help="one_dof, or a path to a scenario .yaml")
    run.add_argument("--out", help="output folder (default out/SCENARIO)")
    run.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    run.add_argument("--iiwa", choices=("ours", "drake_models"), default="ours",
                     help="the iiwa14 model: ours (models/iiwa14.sdf, default) or Drake's official "
                          "one from drake_models (downloaded by Drake on first use: needs internet)")
    run.set_defaults(func=cmd_run)

    report = sub.add_parser("report", help="run every bundled scenario and write one offline report page")
    report.add_argument("--out", default="out/report", help="output folder (default out/report)")
    report.add_argument("--scenarios", nargs="+", choices=("one_dof", "insertion", "cutting"),
                        default=["one_dof", "insertion", "cutting"], help="a subset to run")
    report.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    report.set_defaults(func=cmd_report)

    bench = sub.add_parser("bench", help="measure where the time goes (bench.json and a table)")
    bench.add_argument("--out", required=True, help="output folder for bench.json")
    bench.add_argument("--quick", action="store_true", help="a few iterations of everything (CI smoke mode)")
    bench.set_defaults(func=cmd_bench)

    learn = sub.add_parser("learn", help="learn a skill from your demonstration by reproducing it in a scenario")
    learn.add_argument("demo", help="demonstration CSV (t,x,y,z; world frame of the scenario, metres)")
    learn.add_argument("--scenario", required=True, help="the world: insertion, cutting, or a YAML path")
    learn.add_argument("--out", required=True, help="output folder (skill.npz, metrics, figures, recording)")
    learn.add_argument("--trials", type=_trial_count, default=1, help="reproductions, each continuing "
                       "from the previous one's learned profiles (default 1)")
    learn.add_argument("--skill", help="start from this saved skill's profiles instead of theta = 0")
    learn.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    learn.set_defaults(func=cmd_learn)

    reproduce = sub.add_parser("reproduce", help="replay a learned skill in a scenario")
    reproduce.add_argument("skill", help="skill file (.npz) from hlcmp learn or fit")
    reproduce.add_argument("--scenario", required=True, help="the world: insertion, cutting, or a YAML path")
    reproduce.add_argument("--out", required=True, help="output folder")
    reproduce.add_argument("--freeze", action="store_true", help="no adaptation: the learned profiles as they are")
    reproduce.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    reproduce.set_defaults(func=cmd_reproduce)

    fit = sub.add_parser("fit", help="fit the DMP of a demonstration CSV (t,x,y,z)")
    fit.add_argument("demo")
    fit.add_argument("--out", required=True, help="skill file to write (.npz)")
    fit.add_argument("--basis", type=_basis_count, default=30, help="basis functions N (default 30)")
    fit.add_argument("--smoothing", type=_non_negative, default=DEFAULT_SMOOTHING_S,
                     help=f"std-dev in s of the Gaussian smoothing before differentiation "
                          f"(default {DEFAULT_SMOOTHING_S}; about 0.05 removes a hand's 8-12 Hz tremor)")
    fit.set_defaults(func=cmd_fit)

    rollout = sub.add_parser("rollout", help="roll a skill's DMP out into a trajectory CSV")
    rollout.add_argument("skill")
    rollout.add_argument("--out", required=True, help="trajectory CSV to write")
    rollout.add_argument("--duration", type=_positive, help="new duration tau in s (temporal scaling)")
    rollout.add_argument("--goal", help="new goal, comma-separated, one value per axis")
    rollout.add_argument("--dt", type=_positive, default=0.01, help="sample period in s (default 0.01)")
    rollout.set_defaults(func=cmd_rollout)
    return parser


def main(argv=None):
    from hlcmp_drake.outputs import WRITTEN

    parser = build_parser()
    args = parser.parse_args(argv)
    WRITTEN.clear()   # this command's files only (main may run more than once in a process)
    try:
        return args.func(args)
    except InputError as error:
        if args.debug:
            raise
        print(f"hlcmp: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        done = f"written before it: {', '.join(map(str, WRITTEN))}" if WRITTEN else "nothing was written"
        print(f"hlcmp: interrupted; {done}; every other file is as it was before", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
