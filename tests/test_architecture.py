"""The architecture, checked: a light import, no import cycles, imports that flow one way,
optional packages imported where used, public names that resolve, short modules.

The import graph is read statically from the source (``ast``). Two graphs: the module-level
imports (what loading a module runs) and every import, inside functions and methods too (a
lazy import runs when it is called: it still makes the design's graph, STYLE.md). Both must
flow one way and close no circle; the few deliberate lazy imports that would break a rule are
listed by name in :data:`LAZY_IMPORTS`, each with its reason.
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

#: What each layer may not import (model at the bottom; simulation, fitting and io on it, io
#: on the model only; forecast on model, simulation and fitting; analysis on those; cli on top;
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
    "io": ("simulation", "forecast", "analysis", "cli", "plotting"),
    "forecast": ("io", "analysis", "cli", "plotting"),
    "analysis": ("cli", "plotting"),
    "watch": ("analysis", "cli", "plotting"),
}

#: What a layer may import inside functions, though not at module level: the analysis draws
#: a campaign's figures through plotting when asked to (matplotlib loads then, not before).
LAZY_LAYERS = {"analysis": ("plotting",)}

_SEAM = "removed by the family seam (issue 32)"

#: The deliberate lazy imports that would close a circle or go against the layers, by name:
#: (importer, imported module) -> why. Keep it short; each entry must still exist.
LAZY_IMPORTS = {
    ("granflow.fitting.single", "granflow.plotting.fits"): (
        "FitResult.plot(): the result hands itself to plotting.plot_fit, which reads it"
    ),
    ("granflow.fitting.creep", "granflow.plotting.fits"): (
        "CurveFitResult.plot(): the result hands itself to plotting.plot_fit, which reads it"
    ),
    ("granflow.fitting.mcmc", "granflow.plotting.fits"): (
        "PosteriorResult.plot_corner(): the result hands itself to plotting.plot_corner"
    ),
    ("granflow.simulation.rsf.result", "granflow.plotting.rsf"): (
        "RateStateResult.plot(): the result hands itself to plotting.plot_rsf_simulation"
    ),
    ("granflow.fitting.rsf_result", "granflow.plotting.rsf"): (
        "RateStateFitResult.plot(): the result hands itself to plotting.plot_rsf_fit"
    ),
}

#: Modules that may exceed the limit: generated tables.
GENERATED = {"granflow.model._ei_tables"}
MAX_LINES = 600


def _module_name(path, source=SOURCE):
    parts = path.relative_to(source).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def source_modules(source=SOURCE):
    """{module name: path} of every granflow module under ``source`` (a ``src`` folder)."""
    return {
        _module_name(path, source): path for path in sorted((source / "granflow").rglob("*.py"))
    }


MODULES = source_modules()


def _resolve(module, node, modules=None):
    """The absolute name an ``ImportFrom`` node imports from, inside ``module``."""
    if node.level == 0:
        return node.module
    is_package = (modules or MODULES)[module].name == "__init__.py"
    base = module.split(".")
    base = base if is_package else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, node.module] if node.module else base)


def _type_checking(node):
    return isinstance(node, ast.If) and ast.unparse(node.test).endswith("TYPE_CHECKING")


def module_imports(module, modules=None, *, inside_functions=False):
    """Every name ``module`` imports at module level (top-level statements, including those
    under ``if`` and ``try``; never under ``if TYPE_CHECKING:``, which does not run); with
    ``inside_functions``, those in the bodies of its functions, methods and classes too (a
    lazy import runs when it is called, and is still an edge of the design's graph)."""
    modules = modules or MODULES
    tree = ast.parse(modules[module].read_text(encoding="utf-8"))
    names = set()
    pending = list(tree.body)
    while pending:
        node = pending.pop()
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            source = _resolve(module, node, modules)
            names.add(source)
            # "from granflow.io import reader" imports the submodule granflow.io.reader
            names.update(
                f"{source}.{alias.name}"
                for alias in node.names
                if f"{source}.{alias.name}" in modules
            )
        elif _type_checking(node):
            pending.extend(node.orelse)  # imports for type checkers only never run
        elif inside_functions:
            pending.extend(ast.iter_child_nodes(node))
        elif isinstance(node, ast.If | ast.Try | ast.With):
            for field in ("body", "orelse", "finalbody", "handlers"):
                for child in getattr(node, field, []):
                    pending.extend(child.body if isinstance(child, ast.ExceptHandler) else [child])
    return names


def import_graph(modules=None, *, inside_functions=False, allowed=None):
    """{module: granflow modules it imports}: the parent packages of what it imports count too
    (importing granflow.io.reader runs granflow/io/__init__.py), except the module's own
    packages, which Python has initialised before the module.

    Module-level imports only by default; with ``inside_functions``, those inside functions
    too, except the deliberate lazy imports ``allowed`` lists as ``(importer, imported)``
    (default :data:`LAZY_IMPORTS`)."""
    modules = modules or MODULES
    allowed = LAZY_IMPORTS if allowed is None else allowed
    graph = {}
    for module in modules:
        own = {".".join(module.split(".")[:end]) for end in range(1, module.count(".") + 2)}
        names = module_imports(module, modules)
        if inside_functions:
            lazy = module_imports(module, modules, inside_functions=True) - names
            names |= {name for name in lazy if (module, name) not in allowed}
        edges = set()
        for name in names:
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


def test_no_import_cycles_even_inside_functions():
    assert find_cycles(import_graph(inside_functions=True)) == []


def upward_imports(graph, lazy=()):
    """The edges ``module -> target`` of ``graph`` that go against the layers; ``lazy``
    (:data:`LAZY_LAYERS` for the graph of every import) lists per layer what it may import
    inside functions."""
    lazy = dict(lazy)
    wrong = set()
    for module, targets in graph.items():
        layer = _layer(module)
        for target in targets:
            if _layer(target) in lazy.get(layer, ()):
                continue
            if _layer(target) in FORBIDDEN.get(layer, ()) or (
                _layer(target) == "plotting" and layer not in ("plotting", "cli")
            ):
                wrong.add(f"{module} -> {target}")
    return sorted(wrong)


def test_imports_flow_one_way():
    assert upward_imports(import_graph()) == []


def test_imports_flow_one_way_even_inside_functions():
    assert upward_imports(import_graph(inside_functions=True), LAZY_LAYERS) == []


def test_io_does_not_import_the_simulator_at_all():
    wrong = {
        (module, name)
        for module in MODULES
        if _layer(module) == "io"
        for name in module_imports(module, inside_functions=True)
        if _layer(name) == "simulation"
    }
    assert wrong == set()


@pytest.mark.parametrize("edge", sorted(LAZY_IMPORTS))
def test_each_listed_lazy_import_is_real_and_lazy(edge):
    """The list stays honest: a listed import exists inside a function, not at module level
    (an entry whose import has gone is deleted with it)."""
    importer, imported = edge
    assert LAZY_IMPORTS[edge].strip()
    assert imported in module_imports(importer, inside_functions=True)
    assert imported not in module_imports(importer)


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


def test_module_imports_reads_module_level_imports_and_inside_functions(tmp_path):
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
    modules = source_modules(tmp_path)
    assert module_imports("granflow.model.low", modules) == {"numpy", "matplotlib"}
    assert module_imports("granflow.plotting", modules) == {"granflow.model.low"}
    graph = import_graph(modules)
    assert graph["granflow.model"] == {"granflow.model.low"}
    assert graph["granflow.plotting"] == {"granflow.model", "granflow.model.low"}
    assert graph["granflow.model.low"] == set()  # numpy, matplotlib: not granflow
    # inside functions too, still not under TYPE_CHECKING
    assert module_imports("granflow.model.low", modules, inside_functions=True) == {
        "numpy",
        "matplotlib",
        "granflow.plotting",
    }
    every = import_graph(modules, inside_functions=True, allowed={})
    assert every["granflow.model.low"] == {"granflow.plotting"}
    assert upward_imports(every) == ["granflow.model.low -> granflow.plotting"]


def test_a_planted_circle_inside_functions_is_found(tmp_path):
    """Two modules that import each other only inside functions load fine, yet close a
    circle: the graph of every import finds it, unless the import is listed by name."""
    _write_package(
        tmp_path,
        {
            "granflow/__init__.py": "",
            "granflow/fitting/__init__.py": "",
            "granflow/fitting/generic.py": (
                "def compare(result):\n"
                "    from granflow.fitting.family import rows\n"
                "    return rows(result)\n"
            ),
            "granflow/fitting/family.py": (
                "from granflow.fitting import generic\n"
                "class Result:\n"
                "    def rows(self):\n"
                "        from granflow.fitting.generic import compare\n"
                "        return compare(self)\n"
            ),
        },
    )
    modules = source_modules(tmp_path)
    circle = ["granflow.fitting.family", "granflow.fitting.generic"]
    assert find_cycles(import_graph(modules)) == []  # loading them runs no circle
    assert find_cycles(import_graph(modules, inside_functions=True, allowed={})) == [circle]
    allowed = {("granflow.fitting.generic", "granflow.fitting.family"): "planted"}
    assert find_cycles(import_graph(modules, inside_functions=True, allowed=allowed)) == []
    # the checks of the real tree run the same functions over it
    assert find_cycles(import_graph(modules, inside_functions=True)) == [circle]


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


def test_the_report_modules_import_no_circle_even_inside_functions():
    report = {m for m in MODULES if m.startswith("granflow.analysis.report")}
    assert len(report) >= 4
    graph = {module: module_imports(module, inside_functions=True) & report for module in report}
    assert find_cycles(graph) == []
    # the report reads the typed result; it does not reach back into the engine
    for module in report:
        assert "granflow.analysis.engine" not in module_imports(module, inside_functions=True), (
            module
        )


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


#: ``summary`` names kept for another meaning until a file edited in parallel is merged:
#: (module, class) -> why. Delete each with its alias.
OTHER_SUMMARIES: dict = {}


def _summaries(modules=None):
    """{(module, class): the node} of every ``summary`` a class defines or assigns."""
    found = {}
    for module, path in (modules or MODULES).items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                for item in node.body:
                    named = isinstance(item, ast.FunctionDef) and item.name == "summary"
                    assigned = isinstance(item, ast.Assign) and any(
                        isinstance(target, ast.Name) and target.id == "summary"
                        for target in item.targets
                    )
                    if named or assigned:
                        found[(module, node.name)] = item
    return found


def odd_summaries(found):
    """The ``summary`` of ``found`` (:func:`_summaries`) that are not a method of ``self``
    alone returning ``str``, nor listed in :data:`OTHER_SUMMARIES`."""
    return {
        key: ast.unparse(item)[:60]
        for key, item in found.items()
        if key not in OTHER_SUMMARIES
        and not (
            isinstance(item, ast.FunctionDef)
            and [arg.arg for arg in item.args.args] == ["self"]
            and not (item.args.vararg or item.args.kwarg or item.args.kwonlyargs)
            and item.returns is not None
            and ast.unparse(item.returns) == "str"
        )
    }


def test_summary_means_one_thing():
    """``summary()`` is a result's short text (its key numbers with units, for a terminal):
    a method of ``self`` alone that returns ``str``, everywhere."""
    found = _summaries()
    assert len(found) >= 2
    assert odd_summaries(found) == {}
    assert set(OTHER_SUMMARIES) <= set(found)  # an alias that has gone leaves the list


def test_the_summary_rule_finds_another_meaning(tmp_path):
    _write_package(
        tmp_path,
        {
            "granflow/__init__.py": "",
            "granflow/io/__init__.py": (
                "class Table:\n    def summary(self) -> 'DataFrame':\n        return None\n"
                "class Fields:\n    def summary(self, **changes) -> str:\n        return ''\n"
                "class Alias:\n    summary = dict\n"
                "class Text:\n    def summary(self) -> str:\n        return ''\n"
            ),
        },
    )
    odd = odd_summaries(_summaries(source_modules(tmp_path)))
    assert set(odd) == {("granflow.io", name) for name in ("Table", "Fields", "Alias")}
