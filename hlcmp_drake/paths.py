"""Where the bundled models and scenarios live, and how Drake finds them."""

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
MODELS_DIR = REPO_ROOT / "models"
DIAGRAMS_DIR = REPO_ROOT / "diagrams"
PACKAGE_NAME = "hlcmp_drake"


def register_package(package_map):
    """Make package://hlcmp_drake/... resolve to this repository (its package.xml)."""
    if not package_map.Contains(PACKAGE_NAME):
        package_map.Add(PACKAGE_NAME, str(REPO_ROOT))


def bundled_scenarios():
    return sorted(p.stem for p in DIAGRAMS_DIR.glob("*.yaml"))
