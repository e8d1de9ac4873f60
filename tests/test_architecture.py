"""The package's shape, checked: no import cycle, each layer importing only from the layers
before it, and no printing outside the command line and the progress reporter."""

import ast
import subprocess
import sys
from pathlib import Path

import hlcmp_drake

PACKAGE = Path(hlcmp_drake.__file__).parent
# A module may import from its own folder and from the folders before it in this list.
LAYERS = ["core", "io", "config", "systems", "worlds", "experiments", "present", "run", "cli"]
MAY_PRINT = {"hlcmp_drake.cli", "hlcmp_drake.present.progress"}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules():
    return {_module_name(path): path for path in PACKAGE.rglob("*.py")}


def _imports(path: Path, modules) -> set:
    """The package's modules that `path` imports, at module level or inside functions."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            # `from pkg import sub` imports the submodule when there is one
            names = [
                f"{node.module}.{alias.name}"
                if f"{node.module}.{alias.name}" in modules
                else node.module
                for alias in node.names
            ]
        else:
            continue
        found |= {name for name in names if name in modules}
    return found


def _graph():
    modules = _modules()
    return {name: _imports(path, modules) - {name} for name, path in modules.items()}


def test_the_walk_sees_the_package():
    graph = _graph()
    assert "hlcmp_drake.core.dmp" in graph and "hlcmp_drake.cli" in graph
    assert "hlcmp_drake.core.dmp" in graph["hlcmp_drake.systems.references"]


def find_cycle(graph):
    """An import cycle of `graph` ({module: imported modules}) as a list, or None."""
    state, stack = {}, []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for target in sorted(graph.get(node, ())):
            if state.get(target) == "open":
                return stack[stack.index(target) :] + [target]
            if target not in state:
                cycle = visit(target)
                if cycle:
                    return cycle
        stack.pop()
        state[node] = "done"
        return None

    for node in sorted(graph):
        if node not in state:
            cycle = visit(node)
            if cycle:
                return cycle
    return None


def test_the_cycle_finder_finds_one():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None


def test_no_import_cycle():
    cycle = find_cycle(_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle or [])


def _layer(module: str):
    parts = module.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[1] in LAYERS else None


def test_each_layer_imports_only_from_the_layers_before_it():
    bad = [
        f"{module} imports {target}"
        for module, targets in _graph().items()
        if _layer(module) is not None
        for target in targets
        if _layer(target) is not None and _layer(target) > _layer(module)
    ]
    assert not bad, bad


def test_the_numpy_core_never_imports_drake():
    for name, path in _modules().items():
        if name.startswith("hlcmp_drake.core"):
            tree = ast.parse(path.read_text())
            imported = [
                alias.name
                for node in ast.walk(tree)
                if isinstance(node, ast.Import)
                for alias in node.names
            ]
            imported += [
                node.module or "" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
            ]
            assert not [m for m in imported if m.startswith("pydrake")], name


def test_the_processes_that_plot_nothing_start_without_matplotlib():
    # Half a second of each served client's, driver's and sweep worker's start-up: they
    # import matplotlib (directly or through pydrake.visualization) only when they plot.
    command = (
        "import sys, hlcmp_drake.cli, hlcmp_drake.run.serve, hlcmp_drake.run.sim_driver, "
        "hlcmp_drake.run.drake_driver, hlcmp_drake.run.sweep.tasks, hlcmp_drake.run.library; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'matplotlib'))"
    )
    loaded = subprocess.run(
        [sys.executable, "-c", command], capture_output=True, text=True, check=True
    )
    assert loaded.stdout.strip() == "[]", loaded.stdout


def test_the_config_layer_imports_no_world_or_experiment():
    for module, targets in _graph().items():
        if module.startswith("hlcmp_drake.config"):
            assert not [
                t
                for t in targets
                if t.startswith(("hlcmp_drake.worlds", "hlcmp_drake.experiments"))
            ]


def test_no_print_in_library_modules():
    offenders = []
    for name, path in _modules().items():
        if name in MAY_PRINT:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Name)
                and node.func.id == "print"
            ):
                offenders.append(f"{name}:{node.lineno}")
    assert not offenders, offenders


def test_the_public_api_resolves():
    for name in hlcmp_drake.__all__:
        assert getattr(hlcmp_drake, name) is not None, name


def test_every_controller_config_is_public():
    from hlcmp_drake.config import scenario
    from hlcmp_drake.worlds.controllers import CONTROLLER_KINDS

    for config in CONTROLLER_KINDS:
        assert getattr(hlcmp_drake, config.__name__) is getattr(scenario, config.__name__)
