"""Every public function and class of the library says what it takes and gives: a
numpydoc docstring (a Parameters section where there are parameters) and type hints on
its signature. The command line (cli.py) is argparse and printing, not API."""

import ast
from pathlib import Path

import hlcmp_drake

PACKAGE = Path(hlcmp_drake.__file__).parent
NOT_API = {"cli.py"}


def _public_definitions():
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name in NOT_API:
            continue
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and not node.name.startswith("_"):
                yield path, node
                if isinstance(node, ast.ClassDef):
                    for method in node.body:
                        # Drake's own overrides (DoCalc...) are documented by Drake.
                        if (
                            isinstance(method, ast.FunctionDef)
                            and not method.name.startswith("_")
                            and not method.name.startswith("Do")
                        ):
                            yield path, method


def _problems(path, node):
    where = f"{path.relative_to(PACKAGE.parent)}:{node.lineno} {node.name}"
    doc = ast.get_docstring(node)
    if not doc:
        return [f"{where}: no docstring"]
    if isinstance(node, ast.ClassDef):
        return []
    args = [a for a in node.args.args + node.args.kwonlyargs if a.arg not in ("self", "cls")]
    problems = []
    if args and "Parameters" not in doc:
        problems.append(f"{where}: no Parameters section")
    if any(a.annotation is None for a in args) or (
        node.returns is None and node.name != "__init__"
    ):
        problems.append(f"{where}: signature without type hints")
    return problems


def test_the_scan_sees_the_public_api():
    names = {node.name for _, node in _public_definitions()}
    assert {"adaptation_rates", "load_scenario", "LawController", "simulate"} <= names


def test_public_functions_are_documented_and_typed():
    problems = [p for path, node in _public_definitions() for p in _problems(path, node)]
    assert not problems, f"{len(problems)} to fix:\n" + "\n".join(problems)
