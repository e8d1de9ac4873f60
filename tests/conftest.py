"""What more than one test file shares: the checkout's paths, the bundled scenarios' whole
runs (session fixtures, slow) and small helpers. Test files import the constants and
helpers by name (`from conftest import REPO_ROOT`); pytest finds the fixtures itself."""

from pathlib import Path

import numpy as np
import pytest

from hlcmp_drake.io.paths import DIAGRAMS_DIR

# --- paths ---------------------------------------------------------------------------

# The checkout: README.md, pyproject.toml, scripts/, .ci/.
REPO_ROOT = Path(__file__).resolve().parents[1]
# The bundled insertion demonstration.
INSERTION_DEMO = DIAGRAMS_DIR / "demos" / "insertion_demo.csv"

# --- the slow marker -------------------------------------------------------------------

# Tests that use a whole bundled scenario's run are slow (tens of seconds each).
SCENARIO_RUNS = {"one_dof_run", "insertion_run", "cutting_run"}


def pytest_collection_modifyitems(items):
    for item in items:
        if SCENARIO_RUNS & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)


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


@pytest.fixture(scope="session")
def one_dof_run(tmp_path_factory):
    """`hlcmp run one_dof` once for the whole test session (about 25 s)."""
    from hlcmp_drake.cli import main

    out = tmp_path_factory.mktemp("one_dof")
    assert main(["run", "one_dof", "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="session")
def insertion_run(tmp_path_factory):
    """`hlcmp run insertion` once for the whole session (the full scenario, about 35 s)."""
    from hlcmp_drake.cli import main

    out = tmp_path_factory.mktemp("insertion")
    assert main(["run", "insertion", "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="session")
def cutting_run(tmp_path_factory):
    """`hlcmp run cutting` once for the whole session (the full scenario, about 30 s)."""
    from hlcmp_drake.cli import main

    out = tmp_path_factory.mktemp("cutting")
    assert main(["run", "cutting", "--out", str(out), "--quiet"]) == 0
    return out
