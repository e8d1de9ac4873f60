"""Where the bundled models and scenarios live, and how Drake finds them.

The worlds are one folder, the data root: ``package.xml`` with ``models/`` and
``diagrams/`` beside it. In a checkout (and an editable install) that is the repository's
top level; an installed wheel carries the same files as ``hlcmp_drake/data/`` (see
pyproject.toml's package-dir and package-data), and that copy is used when it is there.
"""

from pathlib import Path
from typing import Any

PACKAGE_NAME = "hlcmp_drake"

_PACKAGE_DIR = Path(__file__).resolve().parents[1]


def _data_root() -> Path:
    shipped = _PACKAGE_DIR / "data"  # a wheel: site-packages/hlcmp_drake/data
    if (shipped / "package.xml").is_file():
        return shipped
    return _PACKAGE_DIR.parent  # a checkout: the repository root


DATA_ROOT = _data_root()
MODELS_DIR = DATA_ROOT / "models"
DIAGRAMS_DIR = DATA_ROOT / "diagrams"
VARIANTS_DIR = DIAGRAMS_DIR / "variants"
PACKAGE_XML = DATA_ROOT / "package.xml"


def register_package(package_map: Any) -> None:
    """Make package://hlcmp_drake/... resolve to the bundled models, through the
    package.xml that sits beside them (Drake's own way of finding a package).

    Parameters
    ----------
    package_map : pydrake.multibody.parsing.PackageMap
        A parser's package map; left as it is when it already knows the package.
    """
    if not package_map.Contains(PACKAGE_NAME):
        package_map.AddPackageXml(str(PACKAGE_XML))


def data_file(file: str, folder: Path) -> Path:
    """A data file a scenario names (its demonstration): package://hlcmp_drake/PATH is
    PATH in the bundled data (e.g. package://hlcmp_drake/diagrams/demos/insertion_demo.csv,
    so that a copied scenario still finds the bundled demonstration), anything else a path
    relative to `folder`, the scenario file's own (an absolute path stays as it is).

    Parameters
    ----------
    file : str
        As the scenario gives it.
    folder : Path
        The scenario file's folder.

    Returns
    -------
    Path
    """
    prefix = f"package://{PACKAGE_NAME}/"
    if file.startswith(prefix):
        return DATA_ROOT / file[len(prefix) :]
    return Path(folder) / file


def data_url(path: str | Path) -> str:
    """A data file's name as a scenario may give it wherever the package is installed: a
    bundled file (under the bundled data's diagrams/) as package://hlcmp_drake/PATH, which
    `data_file` reads back; any other as its absolute path.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str
    """
    absolute = Path(path).resolve()
    if absolute.is_relative_to(DIAGRAMS_DIR.resolve()):
        return f"package://{PACKAGE_NAME}/{absolute.relative_to(DATA_ROOT.resolve()).as_posix()}"
    return str(absolute)


def bundled_scenarios() -> list[str]:
    """Names of the bundled scenarios (diagrams/NAME.yaml), sorted."""
    return sorted(p.stem for p in DIAGRAMS_DIR.glob("*.yaml"))


def bundled_variants() -> list[str]:
    """Names of the bundled scenario variants (diagrams/variants/NAME.yaml), sorted."""
    return sorted(p.stem for p in VARIANTS_DIR.glob("*.yaml"))
