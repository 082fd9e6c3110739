"""The simulation subpackage keeps its shape: small modules, no plotting or cluster imports."""

import pkgutil
import subprocess
import sys
from pathlib import Path

import granflow.simulation

PACKAGE = Path(granflow.simulation.__file__).parent
MODULES = sorted(f"granflow.simulation.{m.name}" for m in pkgutil.iter_modules([str(PACKAGE)]))


def test_no_module_is_over_600_lines():
    lengths = {path.name: len(path.read_text().splitlines()) for path in PACKAGE.glob("*.py")}
    assert max(lengths.values()) <= 600, lengths


def test_importing_every_module_loads_no_leaf_package():
    code = (
        "import sys\n"
        f"for name in {MODULES!r}:\n"
        "    __import__(name)\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & "
        "{'matplotlib', 'jinja2', 'dask', 'distributed', 'emcee', 'pandas', 'pint'}))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "[]"
    assert {"granflow.simulation.driver", "granflow.simulation.results"} <= set(MODULES)
