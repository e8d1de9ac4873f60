"""The `hlcmp` command line.

    hlcmp run SCENARIO [--out DIR] [--set KEY=VALUE ...] [--iiwa ours|drake_models]
              [--variant real_arm]
    hlcmp report [--out DIR] [--scenarios NAME|YAML ...] [--jobs N] [--variants V ...]
                 [--engine local|ray]          scenarios, one offline page
    hlcmp learn DEMO.csv --scenario S --out DIR [--trials K] [--skill SKILL.npz [--any-scenario]]
                [--demo-force] [--controller C]
    hlcmp reproduce SKILL.npz --scenario S --out DIR [--freeze] [--any-scenario] [--controller C]
    hlcmp bench [--out DIR] [--quick]        measure where the time goes
    hlcmp fit DEMO.csv --out SKILL.npz       fit the DMP of a demonstration (positions or pose,
                                             and its force)
    hlcmp rollout SKILL.npz --out TRAJ.csv   roll a skill's DMP out (with its orientation and
                                             the demonstration's encoded force)
    hlcmp sweep SWEEP.yaml [--out DIR] [--engine local|ray] [--address A] [--workers N] [--dry-run]
    hlcmp serve SCENARIO --lcm URL [--controller C] [--skill SKILL.npz [--freeze]
                [--any-scenario]] [--duration S] [--out DIR]
    hlcmp sim-driver SCENARIO --lcm URL [--realtime] [--command-delay N] [--duration S]
                [--idle-timeout S]
    hlcmp sim-driver SCENARIO --lcm URL --drake-driver [--status-period S] [--duration S]
    hlcmp library SPEC.yaml --out DIR [--engine local|ray] [--address A] [--workers N]
    hlcmp generalize DIR --query KEY=VALUE [...] --out SKILL.npz [--method regression|nearest]
                [--extrapolate]

Exit codes: 0 success, 2 bad input (one line on stderr; --debug shows the traceback),
3 a simulation went unstable or a served run was stopped (metrics.json / serve.json say
where and why; a served run also in one line on stderr), 4 the simulated driver aborted,
5 a served run finished but missed more ticks than iiwa_driver allows (degraded).

This module is argparse and printing only: every command calls one library function.
"""

import argparse
import contextlib
import functools
import gc
import logging
import math
import os
import shlex
import sys
from pathlib import Path

import numpy as np

from hlcmp_drake.core.dmp import MAX_BASIS_FUNCTIONS, DmpSettings
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.present.progress import Progress

DEFAULTS = DmpSettings()

EXIT_BAD_INPUT = 2
EXIT_UNSTABLE = 3
EXIT_DRIVER_ABORT = 4
EXIT_DEGRADED = 5  # served to the end, but missed more ticks than iiwa_driver allows
EXIT_INTERRUPTED = 130  # Ctrl-C, as a shell reports SIGINT
EXIT_BROKEN_PIPE = 141  # the output's reader has gone, as a shell reports SIGPIPE


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


class _Typed(float):
    """A number read from the command line that keeps its text as typed (`text`), for a
    message that names the option (`--duration 1e9`, not 1000000000.0)."""

    text: str

    def __new__(cls, value: float, text: str) -> "_Typed":
        typed = super().__new__(cls, value)
        typed.text = text
        return typed


def _positive_as_typed(text):
    return _Typed(_positive(text), text)


def _non_negative(text):
    return _number(text, 0.0, inclusive=True)


def _step_count(text):
    value = _number(text, 0.0, inclusive=True)
    if value != int(value):
        raise argparse.ArgumentTypeError(f"expected a whole number of steps, got '{text}'")
    return int(value)


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


def _path(text):
    """A file or folder argument (every --out, and each input a command reads). An empty
    one, most often an unset shell variable ("$OUT"), names none: the commands would read
    it as the working directory, their default, or a folder."""
    if not text:
        raise argparse.ArgumentTypeError("an empty path (an unset shell variable?)")
    return text


def _quiet_drake(args):
    """Drake's INFO lines (the Meshcat server a recording starts, package downloads) are
    not for this command's user; warnings and errors still show. pydrake sets this
    logger's level when it is imported, so call this after importing it."""
    if not args.debug:
        logging.getLogger("drake").setLevel(logging.WARNING)


@functools.cache
def _notes_on_a_terminal() -> None:
    """The package's notes (its INFO log records: a first compile of the kernels) as plain
    lines on stderr, as the progress lines: only on a terminal, never in a pipe or a log."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(message)s"))
    package = logging.getLogger("hlcmp_drake")
    package.addHandler(handler)
    package.setLevel(logging.INFO)


def _print_table(table):
    """A table on stdout; on a terminal its first column wraps to the terminal's width
    (the benchmark's labels are long), into a pipe or a file each row stays one line."""
    import shutil

    from hlcmp_drake.present.tables import to_text

    width = shutil.get_terminal_size().columns if sys.stdout.isatty() else None
    print(to_text(table, width=width))


def _verdict_word(holds):
    from hlcmp_drake.experiments.claims import NOT_JUDGED

    return NOT_JUDGED if holds is None else ("reproduced" if holds else "NOT reproduced")


def _evidence(verdict: dict, undone: dict) -> str:
    """A claim's evidence as the summary prints it: for a claim not judged, the runs that
    did not do the task by name (their reasons are printed once above the claims)."""
    evidence = verdict["evidence"]
    if verdict["holds"] is not None:
        return evidence
    named = [name for name, why in undone.items() if f"{name}: {why}" in evidence]
    return ", ".join(named) if named else evidence


def _print_instabilities(
    metrics: dict, controller: str | None = None, run_dir: Path | None = None
) -> None:
    """One line per unstable run of a metrics.json's `instability`: which run, why and
    when (a learning's runs are its trials, of `controller`; a report's folders are many,
    so its lines name each run's `run_dir`)."""
    logs = "timeseries.npz" if run_dir is None else run_dir / "timeseries.npz"
    for label, problem in metrics.get("instability", {}).items():
        run = f"{label.replace('_', ' ')} ({controller})" if controller else label
        when = "" if problem["time_s"] is None else f" at t = {problem['time_s']:.3f} s"
        print(
            f"UNSTABLE {run}: {problem['reason']}{when} "
            f"(stopped there; its logs up to then are in {logs})"
        )


def print_summary(result) -> None:
    """A scenario's table, instabilities, claims and where its files went."""
    metrics = result.metrics
    _print_table(result.table)
    _print_instabilities(metrics)
    undone = {
        name: run["task"]["evidence"]
        for name, run in metrics.get("controllers", {}).items()
        if run.get("task") and not run["task"]["done"]
    }
    for name, why in undone.items():
        print(f"task not done by {name}: {why}")
    for learner, claims in metrics.get("claims", {}).items():
        for claim, verdict in claims.items():
            word = _verdict_word(verdict["holds"])
            print(f"{claim} [{learner}]: {word} -- {_evidence(verdict, undone)}")
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
            variant=args.variant,
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
    result = run_report(
        args.out,
        args.scenarios,
        Progress(args.quiet),
        jobs=args.jobs,
        variants=args.variants,
        engine=args.engine,
    )
    for run_dir, metrics in result.runs.items():
        _print_instabilities(metrics, run_dir=run_dir)
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
        demo_force=args.demo_force,
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
        controller=args.controller,
        reporter=Progress(args.quiet),
        overrides=args.set,
        warn=_warn,
    )


def _warn(line):
    print(f"hlcmp: warning: {line}", file=sys.stderr)


def _print_learning(result):
    from hlcmp_drake.run.learning import trials_table

    _print_table(trials_table(result.metrics))
    metrics = result.metrics
    _print_instabilities(metrics, metrics["controller"])
    last = metrics["trials"][-1]
    task = last["task"]
    verdict = "done" if task["done"] else "NOT done"
    which = "" if metrics["command"] == "reproduce" else f" in trial {last['trial']}"
    print(f"task{which} ({metrics['controller']}): {verdict} -- {task['evidence']}")
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


def _rounded(value: float, digits: int) -> str:
    """`value` to `digits` decimals, a value that rounds to zero without a minus sign."""
    return f"{round(value, digits) + 0.0:.{digits}f}"


def cmd_probe(args):
    from hlcmp_drake.run.probe import run_probe

    _quiet_drake(args)
    result = run_probe(args.scenario, args.out, speed=args.speed, overrides=args.set, warn=_warn)
    readings = result.readings
    print(
        f"probe {readings['scenario']} at {readings['speed_m_per_s']:.3g} m/s: peak "
        f"{_rounded(readings['peak_force_N'], 2)} N "
        f"at {_rounded(1000 * readings['depth_at_peak_m'], 1)} mm, residual "
        f"{_rounded(readings['residual_force_N'], 2)} N, "
        f"max lateral {_rounded(readings['max_lateral_force_N'], 3)} N; {readings['status']}"
    )
    print(f"probe.json, probe.png, probe.npz in {result.out_dir}")
    if readings["status"] == "ok" and not result.touched:
        _warn(
            "the tool touched nothing: no force along the whole path, so the probe measured "
            "no contact (probe.start_m and probe.push_m miss the world)"
        )
    return 0 if readings["status"] == "ok" else EXIT_UNSTABLE


# A fitted path this far from its demonstration somewhere [mm] is said: the bundled
# demonstrations fit within 1-3 mm at the default settings, 14-20 mm at 0.5 s of smoothing.
FIT_STRAY_WARNING_MM = 10.0


def cmd_fit(args):
    from hlcmp_drake.core.demo_force import fit_feedforward_weights
    from hlcmp_drake.core.dmp import Dmp, fit_sample_count
    from hlcmp_drake.core.orientation_dmp import OrientationDmp
    from hlcmp_drake.io.demos import read_demonstration
    from hlcmp_drake.io.skill import Skill, save_skill

    try:
        settings = DmpSettings(n_basis=args.basis, smoothing_s=args.smoothing)
    except ValueError as error:  # the message starts with the settings' field
        option = "--basis" if str(error).startswith("n_basis") else "--smoothing"
        raise InputError(f"{option}: {error}") from None
    t, positions, axes, quaternions, force = read_demonstration(
        args.demo, with_orientation=True, with_force=True
    )
    dmp = Dmp.fit(t, positions, axes, settings)
    orientation = None if quaternions is None else OrientationDmp.fit(t, quaternions, settings)
    demo_force = None if force is None else fit_feedforward_weights(t, force, settings)
    save_skill(args.out, Skill.untrained(dmp, orientation, demo_force))
    # How far the fitted path strays from the demonstration: large when the smoothing or
    # too few basis functions take its shape away, or too many for the samples leave it
    # undetermined between them.
    fitted_t, fitted = dmp.rollout(duration=float(t[-1] - t[0]))[:2]
    at_samples = np.column_stack([np.interp(t - t[0], fitted_t, axis) for axis in fitted.T])
    stray_mm = 1000 * float(np.max(np.linalg.norm(at_samples - positions, axis=1)))
    flat = [a for a, scaled in zip(axes, dmp.goal_scaled) if not scaled]
    turn = (
        ""
        if orientation is None
        else f" and orientation DMP (turning "
        f"{np.degrees(np.linalg.norm(orientation.demonstrated_rotation)):.1f} deg)"
    )
    print(
        f"fitted {len(axes)} axis DMP ({','.join(axes)}){turn}, N = {args.basis}, "
        f"tau = {dmp.tau:.3f} s"
        + (
            f"; {','.join(flat)} {'ends' if len(flat) == 1 else 'end'} where "
            f"{'it starts' if len(flat) == 1 else 'they start'} (g ~ p0): the forcing term "
            "is scaled by the demonstration's range there, not by g - p0 (README, 'g ≈ p0')"
            if flat
            else ""
        )
        + ("" if force is None else "; the demonstration's force encoded as feed-forward")
        + f"; its path keeps within {stray_mm:.1f} mm of the demonstration -> {args.out}"
    )
    if stray_mm > FIT_STRAY_WARNING_MM:
        _warn(
            f"the fitted path strays {stray_mm:.1f} mm from the demonstration: "
            f"{_fit_remedy(args.basis, args.smoothing, fit_sample_count(t))} keeps its shape"
        )
    return 0


def _fit_remedy(basis, smoothing, samples):
    """What brings a fitted path nearer its demonstration: with at least as many basis
    functions as the samples that set their weights (`core.dmp.fit_sample_count`), fewer
    (their weights are not determined between samples); else more, and a shorter smoothing
    where there is any."""
    if basis >= samples:
        return f"fewer --basis (now {basis}, for a fit of {samples} samples)"
    more = f"more --basis (now {basis}, up to {min(samples - 1, MAX_BASIS_FUNCTIONS)})"
    return f"a shorter --smoothing (now {smoothing:g} s) or {more}" if smoothing > 0 else more


def cmd_rollout(args):
    from hlcmp_drake.core.demo_force import feedforward_along
    from hlcmp_drake.core.dmp import rollout_times
    from hlcmp_drake.io.demos import (
        as_written,
        bound_problem,
        sampling_problem,
        write_trajectory,
    )
    from hlcmp_drake.io.skill import load_skill

    skill = load_skill(args.skill)
    dmp, orientation = skill.dmp, skill.orientation
    if args.goal_orientation is not None:
        if orientation is None:
            raise InputError("--goal-orientation: the skill has no orientation (positions only)")
        orientation = orientation.with_goal(_unit_quaternion(args.goal_orientation))
    if args.goal is not None:
        goal = _floats(args.goal, "--goal")
        if len(goal) != dmp.n_axes:
            raise InputError(
                f"--goal: the skill has {dmp.n_axes} axes ({','.join(dmp.axis_names)}), "
                f"got {len(goal)} value(s)"
            )
        for axis, value in zip(dmp.axis_names, goal):
            problem = bound_problem(axis, value)
            if problem:
                raise InputError(f"--goal: {axis} = {value:g}: {problem}")
        dmp = dmp.with_goal(goal)
    tau = args.duration or dmp.tau
    if args.dt > tau:
        raise InputError(
            f"--dt {args.dt:.15g} s: longer than the rollout ({tau:.15g} s), which would be its "
            "start alone"
        )
    if tau / args.dt > 2_000_000:
        raise InputError(f"--dt {args.dt} s over {tau} s would write more than 2,000,000 samples")
    # fit and learn read the file as a demonstration: its times, as written, sampled as the
    # reader demands
    times = as_written(rollout_times(tau, None, args.dt, dmp.settings.alpha_s)[0])
    problem = sampling_problem(times)
    if problem:
        raise InputError(
            f"a rollout of {tau:.15g} s at --dt {args.dt:.15g} s would not read back as a "
            f"demonstration (fit and learn refuse it): {problem}"
        )
    t, p, v, _, s = dmp.rollout(dt=args.dt, tau=tau)
    q = w = force = None
    if orientation is not None:
        _, q, w, _ = orientation.rollout(dt=args.dt, tau=tau)
    _check_rolled_out(args, t, p, q, dmp.axis_names, tau)
    if skill.demo_force is not None:  # the demonstration's force, at the rollout's phase
        force = feedforward_along(skill.demo_force, s, dmp.settings)
    write_trajectory(
        args.out, t, p, dmp.axis_names, v, quaternions=q, angular_velocities=w, force=force
    )
    print(
        f"rolled out {len(t)} samples over {t[-1]:.3f} s"
        + ("" if force is None else ", with the demonstration's encoded force")
        + f" -> {args.out}"
    )
    return 0


def _check_rolled_out(args, t, positions, quaternions, axes, tau):
    """Refuse (exit 2, nothing written) a rollout that would not read back as a
    demonstration, which `fit` and `learn` take it for: a position beyond the reader's
    bound (a goal's overshoot), or faster than a demonstration may move or turn (a far
    --goal or --goal-orientation, a short --duration). A DMP's speeds scale as 1 / tau, so
    the shortest duration that keeps within the bound is said."""
    from hlcmp_drake.io.demos import (
        MAX_SPEED_M_PER_S,
        MAX_TURN_RATE_RAD_PER_S,
        bound_problem,
        fastest_speed,
        fastest_turn_rate,
    )

    given = [
        f"{option} {value}"
        for option, value in (
            ("--goal", args.goal),
            ("--goal-orientation", args.goal_orientation),
            ("--duration", None if args.duration is None else f"{args.duration:g}"),
        )
        if value is not None
    ]
    which = ", ".join(given) or args.skill
    for column, axis in zip(positions.T, axes):
        farthest = float(column[np.argmax(np.abs(column))])
        problem = bound_problem(axis, farthest)
        if problem:
            raise InputError(
                f"{which}: the rolled-out path reaches {axis} = {farthest:.4g} m: {problem}"
            )
    # A nearer goal helps only where it sets what is too fast: --goal the path's speed,
    # --goal-orientation its turn rate; a shorter --duration speeds up both.
    rates = [(fastest_speed(t, positions), MAX_SPEED_M_PER_S, "m/s", "move", args.goal, "goal")]
    if quaternions is not None:
        rates.append(
            (
                fastest_turn_rate(t, quaternions),
                MAX_TURN_RATE_RAD_PER_S,
                "rad/s",
                "turn",
                args.goal_orientation,
                "goal orientation",
            )
        )
    for rate, bound, unit, verb, goal_given, goal_name in rates:
        if rate > bound:
            shortest = math.ceil(100 * tau * rate / bound) / 100
            nearer = f"a nearer {goal_name} or " if goal_given else ""
            raise InputError(
                f"{which}: the rolled-out path would {verb} at {rate:.3g} {unit} at its "
                f"fastest, more than the {bound:g} {unit} a demonstration may {verb} (fit and "
                f"learn refuse it): give {nearer}a --duration of at least {shortest:g} s"
            )


def _unit_quaternion(text):
    """--goal-orientation's qw,qx,qy,qz, normalised; refused when off a unit norm."""
    from hlcmp_drake.io.demos import MAX_QUATERNION_NORM_ERROR

    q = np.array(_floats(text, "--goal-orientation"))
    if len(q) != 4:
        raise InputError(f"--goal-orientation: expected 4 values qw,qx,qy,qz, got {len(q)}")
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > MAX_QUATERNION_NORM_ERROR:
        raise InputError(
            f"--goal-orientation: norm {norm:.4g}; a unit quaternion qw,qx,qy,qz is expected "
            f"(norm within 1 ± {MAX_QUATERNION_NORM_ERROR:g})"
        )
    return q / norm


def _positive_count(text):
    value = _whole_number(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def cmd_sweep(args):
    from pathlib import Path

    from hlcmp_drake.io.outputs import check_output_folder
    from hlcmp_drake.run.sweep import check_engine, plan_sweep, run_sweep
    from hlcmp_drake.run.sweep.planning import foreign_task_folders

    if args.dry_run:
        check_engine(args.engine, args.workers, args.address)  # the command as it would run
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
        _say_foreign_folders(plan.out_dir, foreign_task_folders(plan))
        try:  # a dry run writes nothing, so a folder it cannot write is only said
            check_output_folder(plan.out_dir)
        except InputError as error:
            _warn(f"the sweep itself could not run: {error}")
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
    plots = "plots/, " if result.plots else ""
    print(f"results in {result.out_dir}: sweep.csv, sweep.json, {plots}tasks/")
    _say_foreign_folders(result.out_dir, result.foreign)
    if result.failed:
        return 1
    if result.missing:
        return EXIT_BAD_INPUT
    return EXIT_UNSTABLE if result.unstable else 0


def _say_foreign_folders(out_dir, foreign):
    """One line for the folders in OUT/tasks that are no task of this sweep."""
    if foreign:
        shown = ", ".join(foreign[:3]) + (
            f" and {len(foreign) - 3} more" if len(foreign) > 3 else ""
        )
        print(
            f"{len(foreign)} folder(s) in {out_dir}/tasks are no task of this sweep (an "
            f"earlier grid's?), left as they are and out of its tables: {shown}"
        )


def cmd_serve(args):
    from hlcmp_drake.config.loading import OptionOverride
    from hlcmp_drake.io.skill import load_skill
    from hlcmp_drake.run.serve import serve_scenario
    from hlcmp_drake.run.sim_driver import DriverAbort

    _quiet_drake(args)
    skill = load_skill(args.skill) if args.skill else None
    if args.any_scenario and skill is None:
        raise InputError("--any-scenario needs --skill: it lets a skill from another world serve")
    overrides = list(args.set)
    if args.duration:  # named --duration in a message, as typed
        overrides.append(
            OptionOverride(f"duration_s={float(args.duration)}", f"--duration {args.duration.text}")
        )
    try:
        result = serve_scenario(
            args.scenario,
            args.lcm,
            args.out or _default_out(args),
            controller=args.controller,
            skill=skill,
            skill_path=args.skill,
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
    # The task as learn and reproduce say it, judged on the client's own world.
    task = result.metrics["controllers"].get(record["controller"], {}).get("task")
    if task is not None:
        verdict = "done" if task["done"] else "NOT done"
        print(f"task ({record['controller']}): {verdict} -- {task['evidence']}")
    served = ", timeseries.npz, recording.html" if len(result.run.t) else ""
    if record["status"] == "ok":
        print(f"ok: {record['stopped_because']}")
    else:  # one line on stderr says why, as for every other failure
        print(f"hlcmp serve: {record['status']}: {record['stopped_because']}", file=sys.stderr)
    print(f"serve.json, metrics.json{served} in {result.out_dir}")
    exits = {"ok": 0, "degraded": EXIT_DEGRADED, "interrupted": EXIT_INTERRUPTED}
    return exits.get(record["status"], EXIT_UNSTABLE)  # stopped or unstable: 3


def cmd_sim_driver(args):
    from hlcmp_drake.run.sim_driver import DriverAbort, run_sim_driver

    _quiet_drake(args)
    if args.drake_driver:
        if args.command_delay is not None or args.realtime:
            raise InputError(
                "--drake-driver runs Drake's driver as it is: always in real time, each "
                "command acting one plant step after its status (no --realtime, --command-delay)"
            )
        return _drake_driver(args)
    if args.status_period is not None:
        raise InputError(
            "--status-period needs --drake-driver (the project's driver publishes every "
            "iiwa_driver.period_s)"
        )
    if args.command_delay is None:
        args.command_delay = 0
    try:
        summary = run_sim_driver(
            args.scenario,
            args.lcm,
            args.realtime,
            args.duration,
            args.idle_timeout,
            args.set,
            Progress(args.quiet),
            command_delay_steps=args.command_delay,
        )
    except DriverAbort as error:
        print(f"hlcmp sim-driver: aborted: {error}", file=sys.stderr)
        return EXIT_DRIVER_ABORT
    print(_driver_summary(summary, args))
    return _driver_status(summary)


def _driver_status(summary):
    """sim-driver's exit status after its summary: interrupted (one line on stderr; it
    writes no file, so its summary says what it simulated) or 0."""
    if summary.interrupted:
        print(f"hlcmp sim-driver: interrupted: {summary.stopped_because}", file=sys.stderr)
        return EXIT_INTERRUPTED
    return 0


def _driver_summary(summary, args):
    """sim-driver's line: the steps a command acted in, held, still waiting out
    --command-delay (and late, in real time); and, where no command acted, that it did not."""
    waiting = summary.steps - summary.commanded_steps - summary.held_steps
    counts = [f"{summary.commanded_steps} commanded", f"{summary.held_steps} held"]
    if waiting:
        counts.append(f"{waiting} waiting out --command-delay {args.command_delay}")
    if args.realtime:
        counts.append(f"{summary.late_steps} late")
    line = (
        f"sim-driver: {summary.steps} steps ({', '.join(counts)}), {summary.sim_time_s:.3f} s "
        f"simulated in {summary.wall_s:.1f} s; {summary.stopped_because}"
    )
    if waiting and not summary.commanded_steps:
        delay = (
            f"--command-delay {args.command_delay} ({summary.command_delay_s:g} s of plant steps)"
        )
        line += (
            f"; no command acted: stopped within {delay}"
            if summary.interrupted
            else f"; no command acted: {delay} is longer than the run"
        )
    return line


def _drake_driver(args):
    from hlcmp_drake.run.drake_driver import run_drake_driver
    from hlcmp_drake.run.sim_driver import DriverAbort

    try:
        summary = run_drake_driver(
            args.scenario,
            args.lcm,
            0.005 if args.status_period is None else args.status_period,
            args.duration,
            args.idle_timeout,
            args.set,
            Progress(args.quiet),
        )
    except DriverAbort as error:
        print(f"hlcmp sim-driver: aborted: {error}", file=sys.stderr)
        return EXIT_DRIVER_ABORT
    print(
        f"sim-driver (Drake's iiwa driver, status every {summary.status_period_s * 1000:g} ms): "
        f"{summary.commands} commands, {summary.sim_time_s:.3f} s simulated in "
        f"{summary.wall_s:.1f} s; {summary.stopped_because}"
    )
    return _driver_status(summary)


def cmd_library(args):
    from hlcmp_drake.run.library import build_library

    _quiet_drake(args)
    try:
        result = build_library(
            args.spec, args.out, args.engine, args.workers, args.address, Progress(args.quiet)
        )
    except KeyboardInterrupt:
        print(
            "hlcmp: interrupted; every learned skill is kept (listed in "
            f"{args.out}/library.json); the same command again learns only the rest",
            file=sys.stderr,
        )
        return 130
    record = result.record
    for entry in record["skills"]:
        error_mm = 1000 * sum(entry["metrics"]["mean_abs_position_error_m"].values())
        print(f"  {entry['id']}: last trial mean |e| {error_mm:.2f} mm -> {entry['skill']}")
    for entry in record["not_learned"]:
        print(f"  {entry['id']}: {_not_learned_because(entry)}")
    learned = len(record["skills"])
    ran, unstable = set(result.ran), set(result.unstable)
    if not ran:
        kept = f"run, {len(unstable)} of them unstable (no skill saved)" if unstable else "learned"
        print(f"all {result.already_done} skills were already {kept}; nothing relearned")
    else:
        # Of this call's skills only the stable ones saved a skill: the others counted apart.
        counts = [f"{sum(entry['id'] in ran for entry in record['skills'])} skill(s) learned"]
        if ran & unstable:
            counts.append(f"{len(ran & unstable)} unstable (no skill saved)")
        if result.failed:
            counts.append(f"{len(result.failed)} failed")
        print(f"{', '.join(counts)}, {result.already_done} already learned; {result.wall_s:.1f} s")
    print(f"library: {result.out_dir}/library.json ({learned} skill{'' if learned == 1 else 's'})")
    if result.failed:
        return 1
    return EXIT_UNSTABLE if result.unstable else 0


def _not_learned_because(entry: dict) -> str:
    """Why a skill of a library is not in it, in one line: ERROR and the error, UNSTABLE
    and each unstable trial's reason and time (its metrics.json's), or PENDING."""
    status = entry["status"].upper()
    if entry.get("error"):
        return f"{status} {entry['error']}"
    reasons = [
        f"{trial.replace('_', ' ')}: {problem['reason']}"
        + (f" at t = {problem['time_s']:.3f} s" if problem.get("time_s") is not None else "")
        for trial, problem in entry.get("instability", {}).items()
    ]
    return f"{status}, no skill saved: {'; '.join(reasons)}" if reasons else status


def _query(items):
    """--query KEY=VALUE ... as {key: number}, each number keeping its text as typed (for
    the library's messages); a malformed or repeated one is bad input. A value that is not
    one finite number (11mm, 0.011,0.012, nan) is named as the library names a value it
    refuses: `--query KEY=VALUE: ...`."""
    query = {}
    for item in items:
        key, sep, text = item.partition("=")
        key, text = key.strip(), text.strip()
        if not sep or not key:
            raise InputError(
                f"--query {item}: expected KEY=VALUE, e.g. task.puncture.depth_m=0.011"
            )
        if key in query:
            raise InputError(f"--query {key}: given twice")
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise InputError(f"--query {key}={text}: expected one finite number")
        query[key] = _Typed(value, text)
    return query


def cmd_generalize(args):
    from hlcmp_drake.run.skill_library import SkillLibrary, save_generalized

    library = SkillLibrary.load(args.library)
    query = _query(args.query)
    skill, prediction, notes = library.generalize(query, args.method, args.extrapolate)
    for note in notes:
        _warn(note)
    save_generalized(args.out, skill, prediction, query)
    where = ", ".join(f"{key}={value:g}" for key, value in query.items())
    how = (
        f"Gaussian-process regression over {len(library.skills)} skills"
        if args.method == "regression"
        else f"the nearest skill ({prediction.nearest})"
    )
    print(f"skill at {where} by {how} -> {args.out}")
    scales = library.length_scales() if prediction.std is not None else {}
    for field, std in (prediction.std or {}).items():
        mean = prediction.mean[field]
        reach = ", ".join(
            f"{key.rsplit('.', 1)[-1]} {scale:.3g}"
            for key, scale in zip(library.regressed, scales[field])
        )
        print(
            f"  {field}: |weights| max {np.max(np.abs(mean)):.3g}, predictive std mean "
            f"{np.mean(std):.3g}, max {np.max(std):.3g} (saved as std_{field}); length "
            f"scales {reach}"
        )
    # The skill is accepted only in its query's world: each command with those --set.
    uses = " ".join(f"--set {shlex.quote(o)}" for o in library.overrides(query))
    if library.record.get("controller"):  # the learner the library's skills were learned by
        uses = f"--controller {shlex.quote(library.record['controller'])} {uses}"
    skill_file, scenario = shlex.quote(str(args.out)), shlex.quote(library.scenario_argument())
    print(f"replay it: hlcmp reproduce {skill_file} --scenario {scenario} --out DIR {uses}")
    print(
        f"learn on from it: hlcmp learn DEMO.csv --scenario {scenario} --skill {skill_file} "
        f"--out DIR {uses}"
    )
    print(f"serve it: hlcmp serve {scenario} --skill {skill_file} --lcm URL {uses}")
    return 0


def _typed_override(text: str) -> str:
    """`--set`'s value as `config.loading.command_line_override` reads it (at parse time:
    it depends on the working directory)."""
    from hlcmp_drake.config.loading import command_line_override

    return command_line_override(text)


# Built once a process: main may run many times in one (the tests), and building costs
# about 4 ms (argparse looks up its messages' translations and the terminal's size).
@functools.cache
def build_parser():
    from hlcmp_drake import __version__
    from hlcmp_drake.io.paths import bundled_scenarios, bundled_variants

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
        type=_typed_override,
        metavar="KEY=VALUE",
        help="override a scenario value, e.g. duration_s=4 or "
        "controllers.hlcmp.q_k=[300,300,300] (repeatable; a file, reference.file, is read "
        "from the working directory)",
    )

    world = argparse.ArgumentParser(add_help=False)  # where learn and reproduce run
    world.add_argument(
        "--scenario",
        type=_path,
        required=True,
        help="the world: an arm scenario (insertion, cutting, peg_in_hole) or a YAML path",
    )
    world.add_argument(
        "--any-scenario",
        action="store_true",
        help="use a skill learned in another world (scenario) all the same",
    )
    world.add_argument(
        "--controller",
        help="the learning controller's label (default: the scenario's first learner; "
        "a 6-D one, e.g. peg_in_hole's hlcmp_6d, takes a pose demonstration or a 6-D skill)",
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
        "scenario",
        type=_path,
        help=f"a bundled scenario ({', '.join(bundled)}) or a scenario .yaml",
    )
    run.add_argument("--out", type=_path, help="output folder (default out/SCENARIO)")
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
    run.add_argument(
        "--variant",
        type=_path,
        help="layer a variant over the scenario before --set: a bundled one "
        f"from diagrams/variants/ ({', '.join(bundled_variants())}; docs/worlds.md says what "
        "each changes) or a .yaml of your own; the runs go to out/SCENARIO_VARIANT",
    )
    run.set_defaults(func=cmd_run)

    report = sub.add_parser(
        "report",
        parents=[common, quiet],
        help="run every bundled scenario and write one offline report page",
    )
    report.add_argument(
        "--out", type=_path, default="out/report", help="output folder (default out/report)"
    )
    report.add_argument(
        "--scenarios",
        type=_path,
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
    report.add_argument(
        "--variants",
        type=_path,
        nargs="+",
        default=(),
        metavar="VARIANT",
        help="also run every arm scenario under these variants and show them beside its "
        f"perfect robot: bundled ({', '.join(bundled_variants())}) or .yaml files of your "
        "own; each variant runs the arm scenarios once more (default: no variant)",
    )
    report.add_argument(
        "--engine",
        choices=("local", "ray"),
        default="local",
        help="local: processes on this machine (default); ray: Ray tasks, needs "
        "pip install -e '.[ray]'",
    )
    report.set_defaults(func=cmd_report)

    bench = sub.add_parser(
        "bench", parents=[common], help="measure where the time goes (bench.json and a table)"
    )
    bench.add_argument(
        "--out",
        type=_path,
        default="out/bench",
        help="output folder for bench.json (default out/bench)",
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
        "demo",
        type=_path,
        help="demonstration CSV (t,x,y,z; world frame of the scenario, metres; for a 6-D "
        "learner also qw,qx,qy,qz, the tool's orientation; optionally fx,fy,fz, the force "
        "on the tool in N)",
    )
    learn.add_argument(
        "--out",
        type=_path,
        required=True,
        help="output folder: the learned skill.npz, metrics, figures, recording",
    )
    learn.add_argument(
        "--trials",
        type=_trial_count,
        default=1,
        help="reproductions, each continuing from the previous one's learned profiles "
        "(1-100, default 1)",
    )
    learn.add_argument(
        "--skill", type=_path, help="start from this saved skill's profiles instead of theta = 0"
    )
    learn.add_argument(
        "--demo-force",
        action="store_true",
        help="start the feed-forward theta_v from the demonstration's force columns "
        "(fx,fy,fz) instead of 0",
    )
    learn.set_defaults(func=cmd_learn)

    reproduce = sub.add_parser(
        "reproduce",
        parents=[common, quiet, overrides, world],
        help="replay a learned skill in a scenario",
    )
    reproduce.add_argument("skill", type=_path, help="skill file (.npz) from hlcmp learn or fit")
    reproduce.add_argument(
        "--out",
        type=_path,
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
        "scenario",
        type=_path,
        help="an arm scenario with a probe (insertion, cutting, peg_in_hole) or a YAML path",
    )
    probe.add_argument("--out", type=_path, help="output folder (default out/probe_SCENARIO)")
    probe.add_argument(
        "--speed", type=_positive, help="carriage speed in m/s (default the scenario's)"
    )
    probe.set_defaults(func=cmd_probe)

    fit = sub.add_parser(
        "fit",
        parents=[common],
        help="fit the DMP of a demonstration CSV (t,x,y,z or the pose t,x,y,z,qw,qx,qy,qz)",
    )
    fit.add_argument(
        "demo",
        type=_path,
        help="demonstration CSV: t,x,y,z (time in s, then 1-3 positions in m), optionally "
        "followed by qw,qx,qy,qz (the tool's orientation in the world frame, unit quaternion), "
        "then optionally fx,fy,fz (the force on the tool in N)",
    )
    fit.add_argument("--out", type=_path, required=True, help="skill file to write (.npz)")
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
        "rollout",
        parents=[common],
        help="roll a skill's DMP out into a trajectory CSV (a pose skill's: "
        "t,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz, angular velocity in the world frame)",
    )
    rollout.add_argument(
        "skill", type=_path, help="skill file (.npz) from hlcmp fit or hlcmp learn"
    )
    rollout.add_argument("--out", type=_path, required=True, help="trajectory CSV to write")
    rollout.add_argument(
        "--duration", type=_positive, help="new duration tau in s (temporal scaling)"
    )
    rollout.add_argument("--goal", help="new goal, comma-separated, one value per axis")
    rollout.add_argument(
        "--goal-orientation",
        help="a pose skill's new goal orientation: qw,qx,qy,qz (unit quaternion, world frame)",
    )
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
        "sweep",
        type=_path,
        help="a sweep file (.yaml) or a bundled sweep's name (diagrams/sweeps/)",
    )
    sweep.add_argument(
        "--out",
        type=_path,
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

    lcm_help = "LCM URL, e.g. 'udpm://239.255.76.67:7667?ttl=0' (ttl=0: this machine only)"
    arm_scenario_help = "an arm scenario (insertion, cutting, peg_in_hole) or a YAML path"
    serve = sub.add_parser(
        "serve",
        parents=[common, quiet, overrides],
        help="serve a scenario's controller to an iiwa driver over LCM (torque-only)",
    )
    serve.add_argument("scenario", type=_path, help=arm_scenario_help)
    serve.add_argument(
        "--lcm",
        required=True,
        help=f"{lcm_help}; memq:// runs the scenario's simulated driver in this process, in "
        "lockstep",
    )
    serve.add_argument(
        "--controller", help="the controller's label (default: the scenario's Hl-CMP)"
    )
    serve.add_argument(
        "--skill",
        type=_path,
        help="serve the Hl-CMP from this skill file's DMP and learned profiles",
    )
    serve.add_argument("--freeze", action="store_true", help="with --skill: no adaptation")
    serve.add_argument(
        "--any-scenario",
        action="store_true",
        help="with --skill: serve a skill learned in another world (scenario) all the same",
    )
    serve.add_argument(
        "--duration",
        type=_positive_as_typed,
        help="seconds to serve (default the scenario's duration_s)",
    )
    serve.add_argument("--out", type=_path, help="output folder (default out/serve_SCENARIO)")
    serve.set_defaults(func=cmd_serve)

    sim_driver = sub.add_parser(
        "sim-driver",
        parents=[common, quiet, overrides],
        help="a scenario's simulated iiwa, driven over LCM like drake-iiwa-driver "
        "in torque-only mode (status every 1 ms)",
    )
    sim_driver.add_argument("scenario", type=_path, help=arm_scenario_help)
    sim_driver.add_argument(
        "--lcm",
        required=True,
        help=f"{lcm_help}; the client (hlcmp serve) in another process must reach it",
    )
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
    sim_driver.add_argument(
        "--command-delay",
        type=_step_count,
        help="plant steps between a status and the first step its command acts on "
        "(default 0, as in a simulated run; 1 is Drake's simulated driver), shorter in "
        "time than the run",
    )
    sim_driver.add_argument(
        "--drake-driver",
        action="store_true",
        help="drive the world with Drake's own simulated iiwa driver (pydrake's "
        "BuildIiwaControl, torque-only), always in real time",
    )
    sim_driver.add_argument(
        "--status-period",
        type=_positive,
        help="with --drake-driver: seconds between statuses (default 0.005, Drake's "
        "BuildIiwaControl as it is; any other: Drake's driver systems behind a publisher "
        "of this period)",
    )
    sim_driver.set_defaults(func=cmd_sim_driver)
    _add_library_parsers(sub, common, quiet)
    return parser


def _add_library_parsers(sub, common, quiet):
    """The skill-library commands: `library` (learn one) and `generalize` (use one)."""
    library = sub.add_parser(
        "library",
        parents=[common, quiet],
        help="learn a skill at every combination of task parameters (resumable)",
    )
    library.add_argument(
        "spec",
        type=_path,
        help="a library file (.yaml) or a bundled library's name (diagrams/libraries/)",
    )
    library.add_argument(
        "--out",
        type=_path,
        required=True,
        help="the library's folder: library.json and skills/ID/; learned skills there are kept",
    )
    library.add_argument(
        "--engine",
        choices=("local", "ray"),
        default="local",
        help="local: a process pool on this machine (default); ray: Ray tasks, "
        "needs pip install -e '.[ray]'",
    )
    library.add_argument(
        "--address", help="with --engine ray: join the Ray cluster at this address"
    )
    library.add_argument(
        "--workers",
        type=_positive_count,
        help="skills learned at once (local default: the number of CPUs)",
    )
    library.set_defaults(func=cmd_library)

    generalize = sub.add_parser(
        "generalize",
        parents=[common],
        help="a skill at new task parameters, by regression over a skill library",
    )
    generalize.add_argument("library", type=_path, help="a folder written by hlcmp library")
    generalize.add_argument(
        "--query",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a task parameter's value (repeatable; every parameter the library varies)",
    )
    generalize.add_argument("--out", type=_path, required=True, help="skill file to write (.npz)")
    generalize.add_argument(
        "--method",
        choices=("regression", "nearest"),
        default="regression",
        help="regression: Gaussian-process regression (default); nearest: the nearest skill",
    )
    generalize.add_argument(
        "--extrapolate",
        action="store_true",
        help="allow values beyond the library's range by more than 10%% of it (a warning)",
    )
    generalize.set_defaults(func=cmd_generalize)


# Commands whose --out is a file, and what each writes there (its kind, its suffix); every
# other --out is a folder.
WRITES_A_FILE = {
    "fit": ("a skill file", ".npz"),
    "rollout": ("a trajectory CSV", ".csv"),
    "generalize": ("a skill file", ".npz"),
}


def _default_out(args):
    """Where a command writes when --out is not given and its default depends on what it
    runs (run: out/SCENARIO, probe: out/probe_SCENARIO, serve: out/serve_SCENARIO, sweep:
    out/sweeps/SWEEP)."""
    from pathlib import Path

    if args.command in ("run", "probe", "serve"):
        from hlcmp_drake.config.loading import load_scenario

        replay_problem = None
        if args.command == "serve" and args.skill:
            # A skill is what serve replays: reference.duration_s is checked against it.
            from hlcmp_drake.io.skill import load_skill
            from hlcmp_drake.run.learning import replayed_reference_problem

            replay_problem = replayed_reference_problem(None, load_skill(args.skill), args.skill)
        scenario, _ = load_scenario(
            args.scenario,
            args.set,
            variant=getattr(args, "variant", None),
            replay_problem=replay_problem,
        )
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
    """Refuse an output path that cannot be written before any work is done (exit 2).

    Returns
    -------
    str or Path or None
        The output folder the command writes, to be locked while it runs (None for a
        command that writes a file or nothing).
    """

    from hlcmp_drake.io.outputs import check_output_file, check_output_folder

    if getattr(args, "dry_run", False):  # writes nothing: a read-only sweep may be looked at
        return None
    out = getattr(args, "out", None)
    if out is None:
        default = _default_out(args)
        if default is not None:
            check_output_folder(default, "output folder")
            _check_skill_not_lost(args, default)
            _check_inputs_kept(args, default)
        return default
    if args.command in WRITES_A_FILE:
        check_output_file(out)
        _check_output_file_kind(args, out)
        return None
    check_output_folder(out)
    _check_folder_name(args, out)
    _check_skill_not_lost(args, out)
    _check_inputs_kept(args, out)
    if args.command == "report" and args.scenarios:  # one folder per scenario, by its name
        from hlcmp_drake.run.report import report_folders

        for folder in report_folders(out, args.scenarios).values():
            check_output_folder(folder, "--out")
    return out


def _check_folder_name(args, out):
    """Refuse (exit 2) an --out folder not made yet whose name ends in the suffix of a file
    this tool writes (`FILE_SUFFIXES`): a file's name given where the command writes a
    folder. An existing folder of that name, or one written with a final separator, is
    taken as it is."""
    from hlcmp_drake.io.outputs import FILE_SUFFIXES

    suffix = Path(out).suffix
    if suffix.lower() not in FILE_SUFFIXES or os.path.isdir(out) or out.endswith(("/", os.sep)):
        return
    raise InputError(
        f"--out {out}: {args.command} writes a folder, not a {suffix} file: give a folder's "
        f"name, e.g. --out {Path(out).with_suffix('')}"
    )


def _check_skill_not_lost(args, folder):
    """Refuse (exit 2) a command that would lose a learned skill in its output folder: one
    that writes no skill where an earlier learn left one (a reused folder keeps only the
    last command's files: a frozen replay of the skill there would replace the results of
    the run that learned it, and leave the skill out of the folder's list), or a learn or
    replay that would write over the skill it was given."""
    from pathlib import Path

    from hlcmp_drake.io.outputs import listed_outputs

    skill = Path(folder) / "skill.npz"
    if not skill.is_file():
        return
    given = getattr(args, "skill", None)
    is_input = given is not None and os.path.isfile(given) and os.path.samefile(given, skill)
    writes_skill = args.command == "learn" or (args.command == "reproduce" and not args.freeze)
    learned_here = "skill.npz" in listed_outputs(folder)
    if writes_skill and is_input:
        # Where learn left the skill, a frozen replay into the folder is refused too.
        freeze = args.command == "reproduce" and not learned_here
        raise InputError(
            f"--out {folder}: holds the input skill {given}, which {args.command} would "
            "overwrite with the skill it learns: give another --out"
            + (", or --freeze" if freeze else "")
        )
    if writes_skill or not learned_here:
        return
    if is_input and args.command == "reproduce":  # --freeze keeps the skill, not its run
        raise InputError(
            f"--out {folder}: holds the learned skill {given} and the results of the run "
            "that learned it, which the replay's would replace: give another --out"
        )
    raise InputError(
        f"--out {folder}: holds a learned skill ({skill}), which {args.command} would "
        "remove as a file of an earlier command: give another --out, or move the skill"
    )


def _check_inputs_kept(args, folder):
    """Refuse (exit 2) a command whose output folder holds one of its own input files
    under a name it writes there (a scenario.yaml of yours, a demonstration called
    recording.html), unless an earlier command of this tool wrote that file (a run's
    scenario.yaml run again into its own folder). A skill.npz is `_check_skill_not_lost`'s."""
    from pathlib import Path

    from hlcmp_drake.io.outputs import is_output_name, listed_outputs

    root = Path(folder).resolve()
    for name, value in vars(args).items():
        if name == "out" or not isinstance(value, str) or not os.path.isfile(value):
            continue
        path = Path(value).resolve()
        if root not in path.parents or path.name == "skill.npz":
            continue
        inside = path.relative_to(root).as_posix()
        if is_output_name(inside) and inside not in listed_outputs(root):
            raise InputError(
                f"--out {folder}: holds the input {value}, which {args.command} would write "
                f"over with its own {inside}: give another --out, or move the file"
            )


# The positional arguments of the commands that write a file, as their usage lines name them.
_POSITIONAL = {"fit": ("demo",), "rollout": ("skill",)}


def _check_output_file_kind(args, out):
    """Refuse (exit 2) an output file the command would wrongly write over: one of its
    input files, a file of the library it generalises over (`owned_by_library`) or of
    another command's output folder (its manifest lists it: a run's timeseries.npz), a path
    whose suffix is not the kind of file it writes (a skill over a demonstration, a CSV
    over a skill), or a learned skill: for fit, which learns nothing, any (an earlier fit's
    may be replaced); for generalize, whose skill is predicted, one trained by learn or
    reproduce (an earlier generalized skill may be replaced, as a new query's)."""
    from hlcmp_drake.io.skill import load_skill

    if args.command == "generalize":
        from hlcmp_drake.run.skill_library import is_generalized, owned_by_library

        if owned_by_library(args.library, out):
            raise InputError(
                f"--out {out}: is a file of the library {args.library} (its library.json, "
                "in its skills/ or a skill it lists); it would be overwritten: give a file "
                "outside them"
            )
    from hlcmp_drake.io.outputs import listed_outputs

    exists = os.path.isfile(out)
    if exists and os.path.basename(out) in listed_outputs(os.path.dirname(out) or "."):
        raise InputError(
            f"--out {out}: is a file of the output folder an earlier command wrote (its "
            f"{os.path.basename(out)}); it would be overwritten: give a file outside it"
        )
    for name, value in vars(args).items():
        if exists and name != "out" and isinstance(value, str) and os.path.isfile(value):
            if os.path.samefile(value, out):
                option = name.replace("_", "-")
                where = option if name in _POSITIONAL.get(args.command, ()) else f"--{option}"
                raise InputError(f"--out {out}: is the input {where}; it would be overwritten")
    kind, suffix = WRITES_A_FILE[args.command]
    if os.path.splitext(out)[1].lower() != suffix:
        raise InputError(
            f"--out {out}: {args.command} writes {kind}: give a path ending in {suffix}"
        )
    if args.command in ("fit", "generalize") and exists:
        try:
            learned = load_skill(out).learned
        except InputError:  # no skill there to lose: it is replaced as any file
            learned = False
        if learned and args.command == "fit":
            raise InputError(
                f"--out {out}: holds a learned skill, which fit would replace with one that "
                "has learned nothing: choose another path"
            )
        if learned and args.command == "generalize" and not is_generalized(out):
            raise InputError(
                f"--out {out}: holds a skill trained by learn or reproduce, which generalize "
                "would replace with one predicted from the library: choose another path"
            )


def main(argv=None):
    from hlcmp_drake.io.outputs import WRITTEN, folder_locked

    parser = build_parser()
    args = parser.parse_args(argv)
    args.debug = getattr(args, "debug", False)
    WRITTEN.clear()  # this command's files only (main may run more than once in a process)
    if not getattr(args, "quiet", False) and sys.stderr.isatty():
        _notes_on_a_terminal()
    try:
        _check_kernel()
        folder = _check_output(args)
        with folder_locked(folder) if folder is not None else contextlib.nullcontext():
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
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # Whoever read the output has gone (`hlcmp run ... | head`): the rest of it goes
        # nowhere, as Python would otherwise report the pipe again when it flushes at exit.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE


if __name__ == "__main__":
    sys.exit(main())
