"""The built wheel carries the worlds: package.xml, the models, the bundled scenarios and
the demonstrations, found by hlcmp_drake.io.paths where a wheel puts them; the version is
written once, in hlcmp_drake/__init__.py."""

import ast
import os
import re
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import pytest
from conftest import REPO_ROOT

DATA = "hlcmp_drake/data/"  # where a wheel puts the repository's data


def _pyproject() -> dict:
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    return tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())


def test_every_subpackage_is_listed():
    # The package list is explicit (the data package cannot be found by a directory
    # search); a folder left out of it would be missing from the wheel.
    listed = set(_pyproject()["tool"]["setuptools"]["packages"])
    found = {
        ".".join(p.parent.relative_to(REPO_ROOT).parts)
        for p in (REPO_ROOT / "hlcmp_drake").rglob("__init__.py")
    }
    assert found <= listed, f"add to [tool.setuptools] packages: {sorted(found - listed)}"
    assert "hlcmp_drake.data" in listed


def test_every_data_file_matches_a_package_data_pattern():
    tool = _pyproject()["tool"]["setuptools"]
    assert tool["package-dir"]["hlcmp_drake.data"] == "."
    shipped = {
        path
        for pattern in tool["package-data"]["hlcmp_drake.data"]
        for path in REPO_ROOT.glob(pattern)
    }
    data = {
        path
        for folder in ("models", "diagrams")
        for path in (REPO_ROOT / folder).rglob("*")
        if path.is_file() and not path.name.startswith(".") and "__pycache__" not in path.parts
    }
    data.add(REPO_ROOT / "package.xml")
    missing = sorted(str(p.relative_to(REPO_ROOT)) for p in data - shipped)
    assert not missing, f"not shipped in the wheel (add a package-data pattern): {missing}"


def _version_literal() -> str:
    """The string assigned to __version__ in hlcmp_drake/__init__.py, read without
    importing it (as setuptools reads it)."""
    init = ast.parse((REPO_ROOT / "hlcmp_drake" / "__init__.py").read_text())
    (literal,) = [
        node.value.value
        for node in init.body
        if isinstance(node, ast.Assign)
        and [getattr(t, "id", None) for t in node.targets] == ["__version__"]
        and isinstance(node.value, ast.Constant)
    ]
    return literal


def test_the_version_is_written_once():
    # pyproject.toml reads the version from hlcmp_drake/__init__.py; package.xml, which
    # only Drake reads, carries none.
    project = _pyproject()["project"]
    assert "version" not in project and "version" in project["dynamic"]
    dynamic = _pyproject()["tool"]["setuptools"]["dynamic"]
    assert dynamic["version"] == {"attr": "hlcmp_drake.__version__"}
    literal = _version_literal()
    assert re.fullmatch(r"\d+\.\d+\.\d+\S*", literal), literal
    manifest = ElementTree.parse(REPO_ROOT / "package.xml").getroot()
    assert manifest.find("version") is None, "package.xml: the version lives in __init__.py"


def test_drake_finds_the_package_without_a_version():
    # Drake's PackageMap takes the package's name from package.xml and nothing else.
    package_map = pytest.importorskip("pydrake.multibody.parsing").PackageMap.MakeEmpty()
    package_map.AddPackageXml(str(REPO_ROOT / "package.xml"))
    assert package_map.GetPackageNames() == ["hlcmp_drake"]
    assert Path(package_map.GetPath("hlcmp_drake")).resolve() == REPO_ROOT.resolve()


def _build_wheel(tmp_path: Path) -> Path:
    """The wheel of a clean copy of the checkout (no stale build/ of the checkout's own),
    built the way `pip install .` builds it (in an isolated environment with the
    build-system requirements of pyproject.toml)."""
    source = tmp_path / "src"
    shutil.copytree(
        REPO_ROOT,
        source,
        ignore=shutil.ignore_patterns(
            ".git", ".venv*", "build", "dist", "out", "*.egg-info", "__pycache__", ".pytest_cache"
        ),
    )
    command = [
        sys.executable,
        "-m",
        "pip",
        "wheel",
        str(source),
        "--no-deps",
        "-q",
        "-w",
        str(tmp_path / "dist"),
    ]
    result = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    (wheel,) = (tmp_path / "dist").glob("hlcmp_drake-*.whl")
    return wheel


@pytest.mark.slow
def test_wheel_carries_the_worlds_and_paths_find_them(tmp_path):
    wheel = _build_wheel(tmp_path)
    names = set(zipfile.ZipFile(wheel).namelist())
    for name in [
        "package.xml",
        "models/iiwa14.sdf",
        "models/one_dof_slider.sdf",
        "diagrams/one_dof.yaml",
        "diagrams/insertion.yaml",
        "diagrams/cutting.yaml",
        "diagrams/demos/insertion_demo.csv",
        "diagrams/demos/cutting_demo.csv",
    ]:
        assert DATA + name in names, name
    assert "hlcmp_drake/io/paths.py" in names
    (metadata,) = [n for n in names if n.endswith(".dist-info/METADATA")]
    version_line = f"Version: {_version_literal()}"
    assert version_line in zipfile.ZipFile(wheel).read(metadata).decode().splitlines()
    assert [n for n in names if n.endswith(".dist-info/licenses/LICENSE")]
    assert not [n for n in names if n.startswith(DATA) and n.endswith((".py", ".md", ".toml"))]

    # The wheel's files are the installed layout: put them first on the path and, from a
    # folder outside the checkout, resolve every bundled scenario and load its models.
    site = tmp_path / "site"
    bundled = sorted(p.stem for p in (REPO_ROOT / "diagrams").glob("*.yaml"))
    zipfile.ZipFile(wheel).extractall(site)
    check = textwrap.dedent(f"""
        from pathlib import Path
        import hlcmp_drake
        from hlcmp_drake.io import paths
        from hlcmp_drake.config.loading import load_scenario, resolve_scenario_path
        from hlcmp_drake.worlds.models import load_models
        from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
        from pydrake.systems.framework import DiagramBuilder

        site = Path({str(site)!r}).resolve()
        assert Path(hlcmp_drake.__file__).resolve().is_relative_to(site), hlcmp_drake.__file__
        assert paths.DATA_ROOT == site / "hlcmp_drake" / "data", paths.DATA_ROOT
        assert paths.PACKAGE_XML.is_file()
        assert paths.bundled_scenarios() == {bundled!r}, paths.bundled_scenarios()
        for name in paths.bundled_scenarios():
            assert resolve_scenario_path(name) == paths.DIAGRAMS_DIR / (name + ".yaml")
            scenario, _ = load_scenario(name)
            demo = getattr(scenario.reference, "file", None)
            assert demo is None or Path(demo).resolve().is_relative_to(site), demo
            plant, _ = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.001)
            load_models(plant, scenario)
            assert plant.num_positions() > 0, name
        print("ok")
    """)
    env = {**os.environ, "PYTHONPATH": str(site)}
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    result = subprocess.run(
        [sys.executable, "-c", check], capture_output=True, text=True, cwd=outside, env=env
    )
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stdout + result.stderr
