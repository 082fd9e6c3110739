"""The architecture, checked: a light import, no import cycles, imports that flow one way,
optional packages imported where used, public names that resolve, short modules.

The import graph is read statically from the source (``ast``, module-level imports only: an
import inside a function runs when it is called, not when the module is loaded).
"""

import ast
import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

SOURCE = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SOURCE / "granflow"

#: Packages ``import granflow`` must not load (the acceptance command of issue 11).
HEAVY = ("scipy", "matplotlib", "pandas", "numba", "dask", "jinja2", "pint")

#: Packages the core imports inside functions only.
OPTIONAL = ("matplotlib", "jinja2", "dask", "distributed", "emcee")
CORE = ("model", "simulation", "fitting", "io", "forecast")

#: What each layer may not import at module level (model at the bottom; simulation, fitting
#: and io on it; forecast on model, simulation and fitting; analysis on those; cli on top;
#: plotting a leaf only cli imports). ``families`` is beside model on the ground floor: it
#: names every family's code by ``"module:attribute"`` strings only, resolved when used, so
#: that fitting, analysis and the report can ask it which families exist.
FORBIDDEN = {
    "families": (
        "model",
        "simulation",
        "fitting",
        "io",
        "forecast",
        "analysis",
        "cli",
        "plotting",
        "watch",
        "rsf",
    ),
    "model": ("simulation", "fitting", "io", "forecast", "analysis", "cli", "plotting"),
    "simulation": ("forecast", "analysis", "cli", "plotting"),
    "fitting": ("forecast", "analysis", "cli", "plotting"),
    "io": ("forecast", "analysis", "cli", "plotting"),
    "forecast": ("io", "analysis", "cli", "plotting"),
    "analysis": ("cli", "plotting"),
    "watch": ("analysis", "cli", "plotting"),
}

#: Modules that may exceed the limit: generated tables.
GENERATED = {"granflow.model._ei_tables"}
MAX_LINES = 600


def _module_name(path, source=SOURCE):
    parts = path.relative_to(source).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(path): path for path in sorted(PACKAGE.rglob("*.py"))}


def _resolve(module, node):
    """The absolute name an ``ImportFrom`` node imports from, inside ``module``."""
    if node.level == 0:
        return node.module
    is_package = MODULES[module].name == "__init__.py"
    base = module.split(".")
    base = base if is_package else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, node.module] if node.module else base)


def module_imports(module):
    """Every name imported at module level by ``module`` (top-level statements, including
    those under ``if`` and ``try``; not inside functions or classes, nor under ``if
    TYPE_CHECKING:``, which never runs)."""
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    names = set()
    pending = list(tree.body)
    while pending:
        node = pending.pop()
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            source = _resolve(module, node)
            names.add(source)
            # "from granflow.io import reader" imports the submodule granflow.io.reader
            names.update(
                f"{source}.{alias.name}"
                for alias in node.names
                if f"{source}.{alias.name}" in MODULES
            )
        elif isinstance(node, ast.If) and ast.unparse(node.test).endswith("TYPE_CHECKING"):
            pending.extend(node.orelse)  # imports for type checkers only never run
        elif isinstance(node, ast.If | ast.Try | ast.With):
            for field in ("body", "orelse", "finalbody", "handlers"):
                for child in getattr(node, field, []):
                    pending.extend(child.body if isinstance(child, ast.ExceptHandler) else [child])
    return names


def import_graph(modules=MODULES):
    """{module: granflow modules it imports at module level}: the parent packages of what it
    imports count too (importing granflow.io.reader runs granflow/io/__init__.py), except
    the module's own packages, which Python has initialised before the module."""
    graph = {}
    for module in modules:
        own = {".".join(module.split(".")[:end]) for end in range(1, module.count(".") + 2)}
        edges = set()
        for name in module_imports(module):
            parts = name.split(".")
            for end in range(1, len(parts) + 1):
                target = ".".join(parts[:end])
                if target in modules and target not in own:
                    edges.add(target)
        graph[module] = edges
    return graph


def find_cycles(graph):
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in graph.get(node, ()):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1 or node in graph.get(node, ()):
                cycles.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return cycles


def _layer(module):
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


# --------------------------------------------------------------------------- the checks


def test_import_granflow_loads_no_heavy_package():
    code = (
        "import granflow, sys; "
        "print(sorted({m.split('.')[0] for m in sys.modules} & set(sys.argv[1:])))"
    )
    completed = subprocess.run(
        [sys.executable, "-c", code, *HEAVY],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(SOURCE)},
        check=True,
    )
    assert completed.stdout.strip() == "[]"


def test_the_command_line_help_loads_no_numeric_package():
    code = (
        "import sys; from granflow.cli import main; main(['--help']); "
        "print(sorted({m.split('.')[0] for m in sys.modules} & set(sys.argv[1:])))"
    )
    completed = subprocess.run(
        [sys.executable, "-c", code, "numpy", "yaml", *HEAVY],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(SOURCE)},
        check=True,
    )
    assert completed.stdout.strip().splitlines()[-1] == "[]"


def test_no_import_cycles():
    assert find_cycles(import_graph()) == []


def upward_imports(graph):
    """The edges ``module -> target`` of ``graph`` that go against the layers."""
    wrong = set()
    for module, targets in graph.items():
        layer = _layer(module)
        for target in targets:
            if _layer(target) in FORBIDDEN.get(layer, ()) or (
                _layer(target) == "plotting" and layer not in ("plotting", "cli")
            ):
                wrong.add(f"{module} -> {target}")
    return sorted(wrong)


def test_imports_flow_one_way():
    assert upward_imports(import_graph()) == []


def test_core_modules_import_optional_packages_inside_functions_only():
    wrong = [
        f"{module} imports {name}"
        for module in MODULES
        if _layer(module) in CORE
        for name in module_imports(module)
        if name.split(".")[0] in OPTIONAL
    ]
    assert wrong == []


def test_every_public_name_resolves():
    import granflow

    for name in granflow.__all__:
        assert getattr(granflow, name) is not None, name


def test_every_subpackage_says_what_lives_there():
    packages = [module for module, path in MODULES.items() if path.name == "__init__.py"]
    assert len(packages) >= 8
    for package in packages:
        assert (importlib.import_module(package).__doc__ or "").strip(), package


def test_no_module_is_longer_than_the_limit():
    long = {
        module: count
        for module, path in MODULES.items()
        if module not in GENERATED
        and (count := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert long == {}


# --------------------------------------------------------------------------- the checkers


def _write_package(root, files):
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")


def test_the_cycle_finder_finds_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert find_cycles(graph) == [["a", "b", "c"]]
    assert find_cycles({"a": {"b"}, "b": set()}) == []


def test_module_imports_reads_module_level_imports_only(tmp_path, monkeypatch):
    _write_package(
        tmp_path,
        {
            "granflow/__init__.py": "",
            "granflow/model/__init__.py": "from . import low\n",
            "granflow/model/low.py": (
                "import numpy\n"
                "try:\n    import matplotlib\nexcept ImportError:\n    pass\n"
                "if TYPE_CHECKING:\n    import pandas\n"
                "def late():\n    from granflow.plotting import figure\n"
            ),
            "granflow/plotting/__init__.py": "from ..model.low import late\n",
        },
    )
    modules = {
        _module_name(path, tmp_path): path for path in sorted((tmp_path / "granflow").rglob("*.py"))
    }
    monkeypatch.setitem(globals(), "MODULES", modules)
    assert module_imports("granflow.model.low") == {"numpy", "matplotlib"}
    assert module_imports("granflow.plotting") == {"granflow.model.low"}
    graph = import_graph(modules)
    assert graph["granflow.model"] == {"granflow.model.low"}
    assert graph["granflow.plotting"] == {"granflow.model", "granflow.model.low"}
    assert graph["granflow.model.low"] == set()  # numpy, matplotlib: not granflow


def test_the_layer_rule_finds_upward_imports():
    graph = {
        "granflow.model.run": {"granflow.io.reader"},
        "granflow.io.reader": {"granflow.model.run"},
        "granflow.analysis.engine": {"granflow.plotting.paper", "granflow.fitting"},
        "granflow.cli.app": {"granflow.plotting", "granflow.analysis"},
    }
    assert upward_imports(graph) == [
        "granflow.analysis.engine -> granflow.plotting.paper",
        "granflow.model.run -> granflow.io.reader",
    ]


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_each_layer_has_a_rule(layer):
    assert layer in {_layer(module) for module in MODULES}


def _all_imports(module):
    """Every granflow module ``module`` imports anywhere: at module level and inside its
    functions (a lazy import is still an edge of the design's graph)."""
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            source = _resolve(module, node)
            names.add(source)
            names.update(
                f"{source}.{alias.name}"
                for alias in node.names
                if f"{source}.{alias.name}" in MODULES
            )
    return {name for name in names if name in MODULES}


def test_the_report_modules_import_no_circle_even_inside_functions():
    report = {m for m in MODULES if m.startswith("granflow.analysis.report")}
    assert len(report) >= 4
    graph = {module: _all_imports(module) & report for module in report}
    assert find_cycles(graph) == []
    # the report reads the typed result; it does not reach back into the engine
    for module in report:
        assert "granflow.analysis.engine" not in _all_imports(module), module


def _private_names_imported(path):
    """``(line, module, name)`` of every ``from granflow... import _name`` in a file, at any
    depth (inside functions too): a private name taken from another module."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("granflow"):
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    target = f"{node.module}.{alias.name}"
                    if target not in MODULES:  # a private module is a file, not a name
                        found.append((node.lineno, node.module, alias.name))
    return found


def test_no_module_imports_another_modules_private_names():
    """Where two modules need a helper, it is public inside the package (issue 27)."""
    crossing = {
        _module_name(path): found
        for path in MODULES.values()
        if (found := _private_names_imported(path))
    }
    assert crossing == {}


def test_the_private_name_rule_finds_one(tmp_path):
    path = tmp_path / "module.py"
    path.write_text("def f():\n    from granflow.forecast.failure import _helper\n")
    assert _private_names_imported(path) == [(2, "granflow.forecast.failure", "_helper")]
