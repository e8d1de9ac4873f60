"""What more than one test file shares: the checkout's paths, the bundled scenarios' whole
runs (session fixtures, slow) and small helpers. Test files import the constants and
helpers by name (`from conftest import REPO_ROOT`); pytest finds the fixtures itself."""

import contextlib
import dataclasses
import fcntl
import logging
import os
import subprocess
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np
import pytest

from hlcmp_drake.io.paths import DIAGRAMS_DIR

# --- paths ---------------------------------------------------------------------------

# The checkout: README.md, pyproject.toml, scripts/, .ci/.
REPO_ROOT = Path(__file__).resolve().parents[1]
# The bundled insertion demonstration.
INSERTION_DEMO = DIAGRAMS_DIR / "demos" / "insertion_demo.csv"
# A short 3-axis demonstration (20 samples, 0.1 s apart) as CSV text.
DEMO_CSV = "t,x,y,z\n" + "".join(
    f"{0.1 * k:.1f},{0.01 * k:.2f},0,{0.2 - 0.01 * k:.2f}\n" for k in range(20)
)

# --- the slow marker, and what stays on one worker ------------------------------------------

# A test that takes about 1.5 s or more alone is slow (`pytest --durations`), so that
# -m "not slow" stays a check to run after each change; the whole suite runs them all.
# Every slow test says so itself with @pytest.mark.slow; one that uses a whole bundled
# scenario's run (tens of seconds) and forgets is still deselected, and collecting it warns.
SCENARIO_RUNS = {"one_dof_run", "insertion_run", "cutting_run"}

# The costly fixtures, costliest first. pytest-xdist (-n, with --dist loadgroup) sends the
# tests that use one of them to one worker, so that a module's fixture is made once and a
# worker does not sit waiting for a run the other is computing.
COSTLY_FIXTURES = (
    "report",
    "served_insertion",
    "learned",
    "insertion_skill",
    "tiny_library",
    "insertion_run",
    "cutting_run",
    "one_dof_run",
)


# First: pytest-xdist's own hook reads the xdist_group marks on the workers.
@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(items):
    for item in items:
        used = set(getattr(item, "fixturenames", ()))
        if SCENARIO_RUNS & used and not item.get_closest_marker("slow"):
            item.add_marker(pytest.mark.slow)
            item.warn(pytest.PytestWarning(f"{item.name} uses a whole run: mark it slow"))
        costly = next((name for name in COSTLY_FIXTURES if name in used), None)
        if costly:
            item.add_marker(pytest.mark.xdist_group(costly))
    # Slow tests first: pytest-xdist hands tests out in this order, so the long ones start
    # early and the short ones fill the workers' ends.
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


# --- fixtures ----------------------------------------------------------------------------


def minimum_jerk(u):
    return 10 * u**3 - 15 * u**4 + 6 * u**5


@pytest.fixture
def smooth_demo():
    """A rest-to-rest 3-axis demonstration, 2 s at 200 Hz: (t, positions (T, 3))."""
    t = np.linspace(0.0, 2.0, 401)
    u = t / 2.0
    x = 0.3 * minimum_jerk(u)
    y = 0.1 * np.sin(np.pi * u) ** 2 - 0.05 * minimum_jerk(u)
    z = 0.2 * np.sin(np.pi * u) ** 2 * np.cos(np.pi * u) + 0.05 * minimum_jerk(u)
    return t, np.column_stack([x, y, z])


def tilted_turn(seed, samples=400, duration=3.0, noise_deg=0.2):
    """A pose demonstration no one tuned for, made from `seed`: a rest-to-rest turn of 190 to
    330 deg about a random tilted axis, with a wobble of up to 15 deg about another axis,
    unevenly sampled (random times), orientation noise of `noise_deg` std-dev per axis, and
    each quaternion's sign random (samples switch hemisphere). Returns (t, positions (T, 3),
    quaternions (T, 4), truth) with truth(t) the noise-free orientation (T, 4)."""
    from hlcmp_drake.core.quaternion import from_rotation_vector, multiply

    rng = np.random.default_rng(seed)
    axis, other = rng.normal(size=(2, 3))
    axis, other = axis / np.linalg.norm(axis), other / np.linalg.norm(other)
    turn = np.radians(rng.uniform(190.0, 330.0))
    wobble = np.radians(rng.uniform(-15.0, 15.0))
    start = from_rotation_vector(rng.normal(size=3))

    def truth(t):
        u = np.clip(np.asarray(t) / duration, 0.0, 1.0)
        first = from_rotation_vector((turn * minimum_jerk(u))[:, None] * axis)
        second = from_rotation_vector((wobble * np.sin(np.pi * u) ** 2)[:, None] * other)
        return multiply(first, multiply(second, start))

    t = np.sort(np.concatenate([[0.0, duration], rng.uniform(0.0, duration, samples - 2)]))
    noise = from_rotation_vector(rng.normal(0.0, np.radians(noise_deg), (samples, 3)))
    q = multiply(noise, truth(t)) * rng.choice([-1.0, 1.0], samples)[:, None]
    u = t / duration
    positions = np.column_stack(
        [0.2 * minimum_jerk(u), 0.05 * np.sin(np.pi * u), 0.4 - 0.1 * minimum_jerk(u)]
    )
    return t, positions, q, truth


def _shared_run(tmp_path_factory, scenario):
    """`hlcmp run SCENARIO` once for the whole session, however many pytest-xdist workers
    ask: the first computes it under a lock in the folder the workers share, the others
    wait and read it."""
    from hlcmp_drake.cli import main

    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    out = shared / f"run_{scenario}"
    with open(shared / f"run_{scenario}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (out / "metrics.json").exists():
            assert main(["run", scenario, "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="session")
def one_dof_run(tmp_path_factory):
    """`hlcmp run one_dof` once for the whole test session (about 25 s)."""
    return _shared_run(tmp_path_factory, "one_dof")


@pytest.fixture(scope="session")
def insertion_run(tmp_path_factory):
    """`hlcmp run insertion` once for the whole session (the full scenario, about 35 s)."""
    return _shared_run(tmp_path_factory, "insertion")


@pytest.fixture(scope="session")
def cutting_run(tmp_path_factory):
    """`hlcmp run cutting` once for the whole session (the full scenario, about 30 s)."""
    return _shared_run(tmp_path_factory, "cutting")


@pytest.fixture(scope="session")
def insertion():
    """The insertion scenario and its ArmSetup (the fitted DMP, the start posture q0 and the
    tool orientation), shared read-only by the arm's tests."""
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.worlds.arm import prepare

    scenario, _ = load_scenario("insertion")
    return scenario, prepare(scenario)


@pytest.fixture(scope="session")
def arm():
    """The iiwa of the insertion at rest in its start posture: the scenario, its ArmSetup,
    a control-side plant, the tool frame, the task-space terms there and the state."""
    import dataclasses as dc

    from pydrake.multibody.parsing import ModelDirectives, Parser, ProcessModelDirectives
    from pydrake.multibody.plant import MultibodyPlant

    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.io.paths import register_package
    from hlcmp_drake.systems.task_space import TaskSpaceDynamics
    from hlcmp_drake.worlds.arm import prepare as prepare_arm
    from hlcmp_drake.worlds.models import scoped_frame

    scenario, _ = load_scenario("insertion")
    setup = prepare_arm(scenario)
    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    register_package(parser.package_map())
    ProcessModelDirectives(ModelDirectives(directives=scenario.directives), plant, parser)
    plant.Finalize()
    tip = scoped_frame(plant, scenario.task.tool_frame)
    task_space = TaskSpaceDynamics(plant, tip)
    context = task_space.CreateDefaultContext()
    state = np.concatenate([setup.q0, np.zeros(7)])
    task_space.plant_state.FixValue(context, state)
    return dc.make_dataclass("Arm", ["scenario", "setup", "plant", "tip", "terms", "state"])(
        scenario, setup, plant, tip, task_space.terms(context), state
    )


# --- helpers ---------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class CliResult:
    """What `hlcmp ARGS` ended with: its exit code and everything it printed."""

    returncode: int
    stdout: str
    stderr: str


def run_cli(*args, cwd=None, separate_process=False, env=None, timeout=600):
    """`hlcmp ARGS`. By default in this process: the `main` the console script calls, its
    output taken at file descriptors 1 and 2 (so Drake's C++ messages and its Python log
    count as lines too) and an escaping exception turned into the traceback and exit code 1
    that Python would give; a new interpreter costs about a second of imports. A test that
    needs its own process (an environment, a signal, the module's entry point) says
    `separate_process=True`."""
    args = [str(a) for a in args]
    if separate_process or env is not None:
        done = subprocess.run(
            [sys.executable, "-m", "hlcmp_drake.cli", *args],
            capture_output=True,
            text=True,
            cwd=cwd,
            env=env,
            timeout=timeout,
        )
        return CliResult(done.returncode, done.stdout, done.stderr)
    from hlcmp_drake.cli import main

    with _output_captured() as read, _working_directory(cwd):
        try:
            code = main(args)
        except SystemExit as exit_:
            code = exit_.code if isinstance(exit_.code, int) or exit_.code is None else 1
            if not isinstance(exit_.code, int | None):
                print(exit_.code, file=sys.stderr)
        except Exception:
            traceback.print_exc()
            code = 1
    stdout, stderr = read()
    return CliResult(code or 0, stdout, stderr)


@contextlib.contextmanager
def _working_directory(folder):
    """`folder` as the working directory for the block (contextlib.chdir is Python 3.11+)."""
    before = Path.cwd()
    os.chdir(folder or before)
    try:
        yield
    finally:
        os.chdir(before)


@contextlib.contextmanager
def _output_captured():
    """Descriptors 1 and 2, sys.stdout/sys.stderr and the log's stream handlers (pydrake
    routes Drake's messages through Python's logging) all into two files; yields the reader
    of what was written."""
    sys.stdout.flush()
    sys.stderr.flush()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        saved_fds = os.dup(1), os.dup(2)
        saved_streams = sys.stdout, sys.stderr
        os.dup2(out.fileno(), 1)
        os.dup2(err.fileno(), 2)
        sys.stdout = open(1, "w", closefd=False, buffering=1, encoding="utf-8")
        sys.stderr = open(2, "w", closefd=False, buffering=1, encoding="utf-8")
        handlers = [
            h
            for name in (None, "drake")
            for h in logging.getLogger(name).handlers
            if type(h) is logging.StreamHandler
        ]
        saved_handler_streams = [h.setStream(sys.stderr) for h in handlers]
        texts = []
        try:
            yield lambda: tuple(texts)
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            for handler, stream in zip(handlers, saved_handler_streams):
                handler.setStream(stream)
            sys.stdout, sys.stderr = saved_streams
            os.dup2(saved_fds[0], 1)
            os.dup2(saved_fds[1], 2)
            for fd in saved_fds:
                os.close(fd)
            for file in (out, err):
                file.seek(0)
                texts.append(file.read().decode("utf-8", errors="replace"))


def one_line_error(result, code=2):
    """The one line a refused command printed (exit `code`, no traceback)."""
    assert result.returncode == code, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert lines[0].startswith("hlcmp"), result.stderr
    return lines[0]


def assert_output_names(folder):
    """Every file a command wrote in its output folder has a name `io.outputs` knows, so
    that an input of that name there is refused before it is written over."""
    from hlcmp_drake.io.outputs import is_output_name

    files = [p.relative_to(folder) for p in Path(folder).rglob("*") if p.is_file()]
    assert files and all(is_output_name(p) for p in files), files


def short_one_dof(seconds=3.0):
    """The `run` arguments of the 1-DOF scenario cut short."""
    return ["one_dof", "--set", f"duration_s={seconds}"]


# Fuzzing the loaders: whatever the bytes, a clean InputError (exit 2) or a valid result.
def mutations(text, rng, count):
    pieces = [
        "",
        ",",
        "\n",
        "nan",
        "-",
        "1e999",
        "abc",
        "t",
        ":",
        "[",
        "]",
        "{",
        "!",
        "#",
        " ",
        "\t",
        "0",
        "-1",
        "\x00",
        "é",
        "'",
        '"',
        "x,y",
    ]
    for _ in range(count):
        chars = list(text)
        for _ in range(rng.randint(1, 4)):
            where = rng.randrange(len(chars) + 1)
            action = rng.random()
            if action < 0.4 and chars:
                del chars[min(where, len(chars) - 1)]
            elif action < 0.8:
                chars.insert(where, rng.choice(pieces))
            else:
                cut = rng.randrange(len(chars) + 1)
                chars = chars[:cut]
        yield "".join(chars)


# Fixing a task-space controller's inputs (the port layout of systems.ports).
def fix_inputs(system, context, m, x, xdot, xd, xd_dot, xd_ddot, s, inertia, coriolis, gravity):
    values = dict(
        position=x,
        velocity=xdot,
        desired_position=xd,
        desired_velocity=xd_dot,
        desired_acceleration=xd_ddot,
        phase=[s],
        task_inertia=np.ravel(inertia),
        task_coriolis=np.ravel(coriolis),
        task_gravity=gravity,
    )
    for name, value in values.items():
        system.GetInputPort(name).FixValue(context, value)


# Sweep files: TINY is a 2-task sweep of the 1-DOF scenario (pi = 1 and 5), 0.1 s each.
TINY = """\
scenario: one_dof
set:
  duration_s: {duration}
grid:
  controllers.hlcmp.pi: {values}
controllers: [hlcmp]
metrics:
- {{label: "x final [mm]", series: hlcmp/x, reduce: final, scale: 1000.0, digits: 1}}
- {{label: "max K_s [N/m]", series: hlcmp/Ks, reduce: max}}
- {{label: "final x [m]", path: controllers.hlcmp.final_position_m, digits: 4}}
"""


def write_sweep(folder, text, name="sweep.yaml"):
    path = Path(folder) / name
    path.write_text(text)
    return path


def tiny(folder, duration=0.1, values="[1.0, 5.0]", name="sweep.yaml"):
    return write_sweep(folder, TINY.format(duration=duration, values=values), name)


def arm_tick_inputs(setup, law, seed):
    """Inputs of an arm's tick near the insertion's start: a plant state near the start
    posture, moving, a reference a little below the DMP's start, and θ: (state, (x_d, x_d',
    x_d'', s), θ or None)."""
    rng = np.random.default_rng(seed)
    state = np.concatenate([setup.q0 + rng.normal(0, 0.02, 7), rng.normal(0, 0.2, 7)])
    reference = (
        setup.dmp.start + rng.normal(0, 0.01, 3),
        rng.normal(0, 0.03, 3),
        rng.normal(0, 0.02, 3),
        np.array([rng.uniform(0.2, 0.8)]),
    )
    theta = rng.uniform(0, 300, law.theta_size) if law.learns else None
    return state, reference, theta


def assert_held_command_is_evaluates(tick, result, state, reference, theta, **keywords):
    """`tick.held_command` at these inputs gives `result`'s (its `evaluate`'s) torque and
    θ' to the bit: what `ControlLoop` holds is what the tick evaluates."""
    torque, rates = tick.held_command(state, reference, theta, **keywords)
    np.testing.assert_array_equal(torque, result.torque)
    assert (rates is None) == (result.law.rates is None)
    if rates is not None:
        np.testing.assert_array_equal(rates, result.law.rates)
