"""hlcmp_drake.core.kernels: the laws' arithmetic compiled by numba agrees with the numpy path
to 1e-12 on random instants; the path is chosen as documented; and without numba the
package runs the numpy path and says what the compiled one needs."""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import one_line_error, run_cli

from hlcmp_drake.core.kernels import KERNEL_VARIABLE, kernel_chosen, kernel_path, numba_available
from hlcmp_drake.core.laws import (
    ConstantImpedanceLaw,
    HlcmpForgettingLaw,
    HlcmpGains,
    HlcmpLaw,
    TaskSpaceInstant,
    VariableImpedanceLaw,
)

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba is not installed")


def assert_agree(compiled, numpy_path, what):
    """Equal to 1e-12 of the quantity's own scale (its largest magnitude, at least 1)."""
    compiled, numpy_path = np.asarray(compiled, float), np.asarray(numpy_path, float)
    scale = max(1.0, float(np.max(np.abs(numpy_path), initial=0.0)))
    np.testing.assert_allclose(compiled, numpy_path, rtol=0, atol=1e-12 * scale, err_msg=what)


def random_instant(rng, m):
    a = rng.normal(size=(m, m))
    return TaskSpaceInstant(
        x=rng.normal(0, 0.3, m),
        xdot=rng.normal(0, 0.2, m),
        xd=rng.normal(0, 0.3, m),
        xd_dot=rng.normal(0, 0.2, m),
        xd_ddot=rng.normal(0, 1.0, m),
        phase=float(rng.uniform(0.0, 1.0)),
        inertia=a @ a.T + m * np.eye(m),
        coriolis=rng.normal(0, 2.0, (m, m)),
        gravity=rng.normal(0, 20.0, m),
        time=float(rng.uniform(0, 20)),
        external_force=rng.normal(0, 10.0, m) * (rng.uniform(size=m) < 0.7),
    )


LAWS = {
    "hlcmp": lambda m: HlcmpLaw(
        np.linspace(1.0, 0.01, 20),
        np.full(20, 300.0),
        HlcmpGains(np.full(m, 2e3), np.full(m, 50.0), np.full(m, 1e2), 8.0, np.full(m, 30.0)),
    ),
    "hlcmp_forgetting": lambda m: HlcmpForgettingLaw(
        np.linspace(1.0, 0.01, 7),
        np.full(7, 40.0),
        HlcmpGains(np.full(m, 1e3), np.full(m, 20.0), np.zeros(m), 5.0, np.full(m, 10.0)),
        0.3,
    ),
    "constant": lambda m: ConstantImpedanceLaw(
        np.full(m, 500.0), np.full(m, 40.0), 8.0, np.full(m, 30.0)
    ),
    "variable": lambda m: VariableImpedanceLaw(
        np.full(m, 1.0),
        np.full(m, 60.0),
        np.full(m, 200.0),
        0.5,
        0.001,
        np.full(m, 400.0),
        np.full(m, 40.0),
        lambda t: np.where(np.arange(m) % 2 == 0, 5.0 if t > 3 else 0.0, -2.0),
    ),
}


class CoriolisOperator:
    """C_x as the fast path passes it: only its product with a vector."""

    def __init__(self, matrix):
        self._matrix = matrix

    def __matmul__(self, w):
        return self._matrix @ w


def laws_on_both_paths(monkeypatch, name, m):
    made = {}
    for path in ("compiled", "numpy"):
        monkeypatch.setenv(KERNEL_VARIABLE, path)
        made[path] = LAWS[name](m)
    return made["compiled"], made["numpy"]


@needs_numba
@pytest.mark.parametrize("coriolis", ["matrix", "operator"])
@pytest.mark.parametrize("m", [1, 3])
@pytest.mark.parametrize("name", sorted(LAWS))
def test_compiled_laws_agree_with_numpy(monkeypatch, name, m, coriolis):
    """Every law, on both forms of C_x (a matrix: the modular systems and the slider; Drake's
    product: the arm's fast path), 25 random instants."""
    compiled, numpy_path = laws_on_both_paths(monkeypatch, name, m)
    rng = np.random.default_rng(sorted(LAWS).index(name) * 10 + m)
    for _ in range(25):
        now = random_instant(rng, m)
        if coriolis == "operator":
            now = now._replace(coriolis=CoriolisOperator(now.coriolis))
        theta = (
            rng.uniform(0, 400, numpy_path.theta_size)
            if numpy_path.learns
            else np.concatenate([rng.normal(0, 0.3, m), rng.normal(0, 0.2, m), rng.normal(0, 1, m)])
            if numpy_path.theta_size
            else None
        )
        a, b = compiled.command(now, theta), numpy_path.command(now, theta)
        assert_agree(a.force, b.force, f"{name}: f_c")
        assert a.logs.keys() == b.logs.keys()
        for key in b.logs:
            assert_agree(a.logs[key], b.logs[key], f"{name}: {key}")
        if b.rates is None:
            assert a.rates is None
        else:
            assert_agree(a.rates, b.rates, f"{name}: θ'")


@needs_numba
def test_the_comparison_sees_a_wrong_kernel(monkeypatch):
    """The agreement check fails when one path's arithmetic differs by a part in 1e9."""
    compiled, numpy_path = laws_on_both_paths(monkeypatch, "hlcmp", 3)
    now = random_instant(np.random.default_rng(1), 3)
    theta = np.random.default_rng(2).uniform(0, 400, numpy_path.theta_size)
    force = compiled.command(now, theta).force
    with pytest.raises(AssertionError):
        assert_agree(force * (1 + 1e-9), numpy_path.command(now, theta).force, "f_c")


def test_the_path_is_chosen_as_documented(monkeypatch):
    monkeypatch.delenv(KERNEL_VARIABLE, raising=False)
    assert kernel_path() == ("compiled" if numba_available() else "numpy")
    assert kernel_path("numpy") == "numpy"
    monkeypatch.setenv(KERNEL_VARIABLE, "numpy")
    assert kernel_path() == "numpy"
    assert LAWS["hlcmp"](3)._force.__module__ == "hlcmp_drake.core.laws"  # the plain function
    monkeypatch.setenv(KERNEL_VARIABLE, "fortran")
    with pytest.raises(ValueError, match="HLCMP_KERNEL='fortran': expected one of compiled, numpy"):
        kernel_path()


def test_without_numba_the_numpy_path_runs():
    """In a process where numba cannot be imported: the default path is numpy, a tick of the
    1-DOF Hl-CMP evaluates, and asking for the compiled path says what it needs."""
    script = """
import sys
sys.modules["numba"] = None  # import numba fails, as where it is not installed
import numpy as np
from hlcmp_drake.core.kernels import kernel_path, numba_available
from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.worlds.models import add_plant
from hlcmp_drake.worlds.slider import slider_tick
from pydrake.systems.framework import DiagramBuilder
assert not numba_available() and kernel_path() == "numpy"
scenario, _ = load_scenario("one_dof")
plant, _ = add_plant(DiagramBuilder(), scenario)
tick = slider_tick(scenario, "hlcmp", plant=plant)
result = tick.evaluate(np.array([0.01, 0.02]), (np.array([0.05]), np.zeros(1), np.zeros(1),
                       np.array([0.5])), np.ones(tick.law.theta_size))
print(tick.kernel, np.isfinite(result.torque).all(), result.law.rates.shape)
try:
    kernel_path("compiled")
except ValueError as error:
    print(error)
"""
    env = {k: v for k, v in os.environ.items() if k != KERNEL_VARIABLE}
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=300
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("numpy True (")
    assert lines[1] == "HLCMP_KERNEL=compiled needs numba (pip install 'hlcmp_drake[fast]')"


def test_an_unknown_path_is_refused_in_one_line():
    result = run_cli("run", "one_dof", env={**os.environ, KERNEL_VARIABLE: "fortran"})
    assert one_line_error(result) == (
        "hlcmp: error: environment: HLCMP_KERNEL='fortran': expected one of compiled, numpy"
    )


def test_kernel_chosen_sets_the_path_for_the_block_only(monkeypatch):
    monkeypatch.setenv(KERNEL_VARIABLE, "numpy")
    expected = "compiled" if numba_available() else "numpy"
    with kernel_chosen(expected):
        assert kernel_path() == expected
    assert kernel_path() == "numpy"
    with pytest.raises(ValueError, match="fortran"), kernel_chosen("fortran"):
        pass


@needs_numba
def test_a_served_client_compiles_its_tick_before_the_first_status():
    """`hlcmp serve`'s client evaluates its tick once when it is made, so that the first
    status is not answered seconds late while numba compiles or loads the kernels."""
    script = """
from pydrake.lcm import DrakeLcm
from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core import kernels
from hlcmp_drake.run.serve import TorqueClient
scenario, _ = load_scenario("insertion")
TorqueClient(scenario, "hlcmp", DrakeLcm("memq://"))
print(" ".join(sorted(f.__name__ for f, compiled in kernels._compiled.items()
                      if compiled.signatures)))
"""
    env = {k: v for k, v in os.environ.items() if k != KERNEL_VARIABLE}
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=600
    )
    assert done.returncode == 0, done.stderr
    # the arm's Hl-CMP tick is two compiled calls (`systems.arm_tick.FusedArmTick`)
    assert done.stdout.split() == ["arm_tick_start", "hlcmp_arm_tick_finish"]


def test_every_jitable_function_is_in_core():
    """The kernels' cache folder is named by core's sources (`kernel_cache_folder`): that
    covers a kernel only if every function it may inline (`jitable`, or compiled by another
    implementation, `compiled_by`) is defined there."""
    import hlcmp_drake
    from hlcmp_drake.core.kernels import CORE_DIR

    package = Path(hlcmp_drake.__file__).parent
    marked = {
        path.relative_to(package)
        for path in package.rglob("*.py")
        if re.search(r"@(jitable|compiled_by)\b", path.read_text(encoding="utf-8"))
        and path.name != "kernels.py"
    }
    assert Path("core/small_linalg.py") in marked  # compiled_by's, found too
    assert all(path.parent == CORE_DIR.relative_to(package) for path in marked)


def test_an_edited_equation_gets_a_cache_folder_of_its_own(tmp_path):
    """numba checks only the compiled function's own file; an edit of any core file (e.g.
    an equation inlined from control_law.py) must name another folder."""
    import shutil

    from hlcmp_drake.core.kernels import CORE_DIR, kernel_cache_folder, sources_digest

    sources = tmp_path / "core"
    shutil.copytree(CORE_DIR, sources, ignore=shutil.ignore_patterns("__pycache__"))
    first = kernel_cache_folder(tmp_path / "cache", sources_digest(sources))
    assert first == kernel_cache_folder(tmp_path / "cache", sources_digest(sources))  # stable
    assert first.parent == tmp_path / "cache"
    law = sources / "control_law.py"
    law.write_text(law.read_text(encoding="utf-8").replace("pi * e", "pi * (e)", 1))
    assert kernel_cache_folder(tmp_path / "cache", sources_digest(sources)) != first


def test_a_process_files_its_kernels_under_the_sources_it_imported(tmp_path):
    """A process that outlives an edit of core (a notebook, a sweep's fork server) still
    compiles the equations it imported: their machine code goes to the imported sources'
    folder, never to the edited sources' (where a new process would load it)."""
    import shutil

    import hlcmp_drake

    package = tmp_path / "hlcmp_drake"
    shutil.copytree(
        Path(hlcmp_drake.__file__).parent / "core",
        package / "core",
        ignore=shutil.ignore_patterns("__pycache__"),
    )
    shutil.copy(hlcmp_drake.__file__, package / "__init__.py")
    script = (
        "import sys\n"
        "from pathlib import Path\n"
        "from hlcmp_drake.core import kernels\n"
        f"assert Path(kernels.__file__).is_relative_to({str(tmp_path)!r}), kernels.__file__\n"
        "before = kernels.kernel_cache_folder()\n"
        "law = Path(kernels.__file__).parent / 'control_law.py'\n"
        "law.write_text(law.read_text().replace('pi * e', 'pi * (e)', 1))\n"
        "print(before == kernels.kernel_cache_folder())\n"
    )
    done = subprocess.run(  # -S: no site-packages, where the editable install's finder is
        [sys.executable, "-S", "-c", script],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(tmp_path)},
    )
    assert done.stdout.split() == ["True"], done.stderr


@needs_numba
def test_numba_keeps_the_kernels_in_the_folder_of_these_sources():
    import numba

    from hlcmp_drake.core.kernels import kernel_cache_folder

    assert Path(numba.config.CACHE_DIR).name == kernel_cache_folder().name


@needs_numba
def test_a_first_compile_is_said_once_before_the_wait(tmp_path):
    """Where the kernels' folder does not exist yet (a new installation, an edit of core),
    one note (an INFO record, which `hlcmp` shows on a terminal) says why the run is slow;
    nothing is compiled to say it."""
    script = (
        "import logging; logging.basicConfig(level=logging.INFO, format='%(message)s')\n"
        "from hlcmp_drake.core.kernels import implementation\n"
        "from hlcmp_drake.core import slider_tick\n"
        "implementation(slider_tick.impedance_slider_tick, 'compiled')\n"
        "implementation(slider_tick.hlcmp_slider_tick, 'compiled')\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)},
    )
    lines = done.stderr.splitlines()
    assert done.returncode == 0 and len(lines) == 1, done.stderr
    assert lines[0].startswith("hlcmp: compiling the controller's kernels with numba")
    assert str(tmp_path) in lines[0] and not [p for p in tmp_path.rglob("*") if p.is_file()]


def test_the_compiler_set_up_in_advance_never_raises_and_skips_the_numpy_path(monkeypatch):
    """The fork server imports it: a problem there (no home folder for the kernels' cache)
    would end the server and every task, where a worker fails its task in one line."""
    from hlcmp_drake.core import kernels

    asked = []

    def no_home():
        asked.append(1)
        raise RuntimeError("Could not determine home directory.")

    monkeypatch.setattr(kernels, "numba_available", no_home)
    kernels.prepare_compiler()
    assert asked == [1]
    monkeypatch.setenv(KERNEL_VARIABLE, "numpy")
    kernels.prepare_compiler()
    assert asked == [1]  # not even asked
