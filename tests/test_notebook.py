"""granflow in a notebook, run by a real Jupyter kernel (nbclient): results render as HTML,
analyze shows one progress bar, and ``granflow.plotting`` is an attribute."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import write_small_campaign

import granflow

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
if importlib.util.find_spec("ipykernel") is None:  # not imported here: the kernel runs it
    pytest.skip("the notebook test needs ipykernel", allow_module_level=True)

SRC = Path(granflow.__file__).resolve().parent.parent

CELLS = [
    # 0: the granflow under test, whatever the kernel's environment
    f"import sys\nsys.path.insert(0, {str(SRC)!r})\nimport numpy as np\nimport granflow as gf\n"
    "assert gf.__file__.startswith(sys.path[0])",
    # 1: a fit
    "p = gf.Params(a=3e-3, alpha=4e4, Fd=10e-3, x0=2e-7)\n"
    "x = np.linspace(1e-6, 5e-4, 300)\n"
    "y = gf.friction_slip(x, p) + np.random.default_rng(0).normal(0, 3e-5, x.size)\n"
    "gf.fit((x, y))",
    # 2: a simulation
    "gf.simulate(p, [gf.Velocity(1e-6, 100.0), gf.SwitchToForce(60.0, factor=1.01)])",
    # 3: a campaign (the manifest and output paths are set by the test)
    "result = gf.analyze(MANIFEST, OUTPUT, jobs=1)\nresult",
    # 4: the plotting subpackage as an attribute
    "type(gf.plotting.plot_fit).__name__",
]


def _stream(outputs, name):
    return "".join(o["text"] for o in outputs if o["output_type"] == "stream" and o["name"] == name)


def _html(outputs):
    shown = [o for o in outputs if o["output_type"] == "execute_result"]
    assert len(shown) == 1, outputs
    return shown[0]["data"]


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    folder = tmp_path_factory.mktemp("notebook")
    manifest = write_small_campaign(folder / "campaign")
    cells = list(CELLS)
    cells[3] = f"MANIFEST, OUTPUT = {str(manifest)!r}, {str(folder / 'out')!r}\n" + cells[3]
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    client = nbclient.NotebookClient(
        notebook, timeout=300, kernel_name="python3", resources={"metadata": {"path": folder}}
    )
    client.execute()
    return notebook


def test_fit_simulate_and_analyze_render_as_html(executed):
    for index, title in ((1, "FitResult"), (2, "SimulationResult"), (3, "AnalysisResult")):
        data = _html(executed.cells[index]["outputs"])
        assert "text/html" in data, data.keys()
        html = data["text/html"]
        assert html.startswith('<div class="granflow-result">') and f"<h4>{title}" in html
        assert "text/plain" in data and data["text/plain"].startswith(title)
    campaign = _html(executed.cells[3]["outputs"])["text/html"]
    assert "Material constants" in campaign and "mu_a" in campaign and "Runs (14)" in campaign


def test_analyze_shows_one_progress_bar(executed):
    outputs = executed.cells[3]["outputs"]
    widgets = [
        o for o in outputs if "application/vnd.jupyter.widget-view+json" in o.get("data", {})
    ]
    err = _stream(outputs, "stderr")
    # tqdm draws a bar on one line, rewriting it with carriage returns; a new bar (or a line
    # per run) starts a new line. The one bar covers every stage, by its share, to 100 %.
    bars = [line for line in err.split("\n") if "%|" in line]
    assert len(widgets) + len(bars) == 1, err
    if bars:
        states = bars[0].split("\r")
        assert any("14/14 runs" in state for state in states), bars[0]
        assert any(state.strip().startswith("figures:") for state in states), bars[0]
        assert any("100%" in state for state in states), bars[0]
    assert "[100%] report: " in err  # where the report is
    assert "fitted 1/" not in err
    for inner in ("stability map", "sampling", "fitting:"):
        assert inner not in err


def test_plotting_is_an_attribute(executed):
    assert _html(executed.cells[4]["outputs"])["text/plain"] == "'function'"


def test_plotting_attribute_does_not_load_matplotlib_until_used():
    code = (
        "import sys, granflow as gf\n"
        "assert 'plotting' in dir(gf) and 'matplotlib' not in sys.modules\n"
        "gf.plotting.plot_fit\n"
        "print(type(gf.plotting).__name__)"
    )
    env_path = str(SRC)
    done = subprocess.run(
        [sys.executable, "-c", f"import sys; sys.path.insert(0, {env_path!r})\n{code}"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert done.stdout.strip() == "module"
