"""Where the bundled models and scenarios live, and how Drake finds them."""

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
MODELS_DIR = REPO_ROOT / "models"
DIAGRAMS_DIR = REPO_ROOT / "diagrams"
PACKAGE_XML = REPO_ROOT / "package.xml"
PACKAGE_NAME = "hlcmp_drake"


def register_package(package_map: object) -> None:
    """Make package://hlcmp_drake/... resolve to the bundled models, through the
    package.xml that sits beside them (Drake's own way of finding a package).

    Parameters
    ----------
    package_map : pydrake.multibody.parsing.PackageMap
        A parser's package map; left as it is when it already knows the package.
    """
    if not package_map.Contains(PACKAGE_NAME):
        package_map.AddPackageXml(str(PACKAGE_XML))


def bundled_scenarios() -> list[str]:
    """Names of the bundled scenarios (diagrams/NAME.yaml), sorted."""
    return sorted(p.stem for p in DIAGRAMS_DIR.glob("*.yaml"))
