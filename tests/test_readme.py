"""The README's promises that a test can check."""

import re

from conftest import REPO_ROOT

README = (REPO_ROOT / "README.md").read_text()


def _quick_start_commands():
    section = README.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```bash\n(.*?)\n```", section, flags=re.S)


def test_quick_start_is_two_commands_and_ci_runs_the_test_command():
    main_job, tests = _quick_start_commands()
    assert "\n" not in main_job and "\n" not in tests
    assert "hlcmp report" in main_job and "pytest" in tests
    assert tests in (REPO_ROOT / ".ci" / "run").read_text().splitlines()


def test_every_linked_file_exists():
    for target in re.findall(r"\]\(([^)#]+)\)", README):
        if not target.startswith("http"):
            assert (REPO_ROOT / target).exists(), target


def test_the_layout_section_lists_every_folder_of_the_package():
    section = README.split("- Layout.", 1)[1].split("\n- ", 1)[0]
    listed = set(re.findall(r"^\s*\| `([a-z_]+)/` \|", section, flags=re.M))
    package = REPO_ROOT / "hlcmp_drake"
    folders = {p.name for p in package.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert listed == folders
    for name in re.findall(r"`([a-z_0-9]+\.py)`", section):
        assert list(package.rglob(name)), f"{name} is in the README's layout but not in the package"
