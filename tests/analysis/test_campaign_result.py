"""The typed hand-offs of the main job: per-run results, the campaign result, the joint stage."""

import ast
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest
from conftest import write_small_campaign

import granflow as gf
from granflow.analysis import AnalysisResult, analyze
from granflow.analysis.files import RUN_RECORD_MARKER, RUNS_DIR
from granflow.analysis.inputs import ANALYSIS_VERSION
from granflow.analysis.joint_results import Analyses, Estimate, Material
from granflow.analysis.prediction_results import Predictions
from granflow.analysis.run_results import (
    CreepResult,
    FailedRun,
    RampResult,
    StartupResult,
    SwitchResult,
    run_result_from_dict,
)
from granflow.analysis.stage import joint_stage

SOURCE = pathlib.Path(__file__).resolve().parents[2] / "src"


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    campaign = write_small_campaign(tmp_path_factory.mktemp("campaign"))
    return analyze(campaign, tmp_path_factory.mktemp("out"), jobs=1, quiet=True)


def test_results_json_is_the_result_to_dict_plus_timing(analysed):
    written = json.loads((analysed.output / "results.json").read_text(encoding="utf-8"))
    timing = written.pop("timing")
    assert analysed.to_dict() == written
    assert timing["fitted_now"] == analysed.fitted_now == len(analysed.runs)
    assert analysed.results == {**written, "timing": timing}


#: Keys of the per-point arrays of the fit results (and of a posterior's chain).
ARRAY_KEYS = {"x", "data", "best_fit", "residuals", "weights", "chain"}


def _keys_and_lists(value):
    """Every mapping key inside ``value`` and the length of every list."""
    keys, lengths = set(), []
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            keys.update(item)
            stack.extend(item.values())
        elif isinstance(item, list):
            lengths.append(len(item))
            stack.extend(item)
    return keys, lengths


def test_results_json_holds_no_per_point_arrays(analysed):
    written = json.loads((analysed.output / "results.json").read_text(encoding="utf-8"))
    keys, lengths = _keys_and_lists(written)
    assert keys & ARRAY_KEYS == set()
    # lists as long as the campaign, or as the stability map's axes: none per point of a run
    from granflow.analysis.predictions import MAP_POINTS

    assert max(lengths) <= max(2 * len(written["runs"]), MAP_POINTS)
    # the joint fits, the comparison and the creep fits are there, in their compact form
    analyses = written["analyses"]
    joint = analyses["amontons"]["joint"]
    assert len(joint["individual"]) == len(joint["run_names"]) > 0
    assert set(analyses["model_comparison"]["fits"]) == {"eq3", "log_aging", "exponential"}
    assert analyses["creep"][0]["fit"]["ndata"] > 0


def test_campaign_result_round_trips(analysed):
    rebuilt = AnalysisResult.from_dict(analysed.to_dict())
    assert rebuilt == analysed
    assert rebuilt.to_dict() == analysed.to_dict()
    # through JSON text too (what reading results.json gives)
    text = json.dumps(analysed.results)
    assert AnalysisResult.from_dict(json.loads(text)) == analysed
    assert type(rebuilt.material) is Material and type(rebuilt.analyses) is Analyses
    assert type(rebuilt.predictions) is Predictions


def test_run_results_are_typed_and_hold_the_fits(analysed):
    kinds = {entry.test: type(entry.result) for entry in analysed.runs}
    assert kinds == {
        "startup": StartupResult,
        "ramp": RampResult,
        "creep": CreepResult,
        "switch": SwitchResult,
    }
    for entry in analysed.runs:
        result = entry.result
        if entry.test in ("startup", "switch"):
            assert isinstance(result.fit, gf.FitResult)
            assert result.fit.x.size == result.fit.ndata > 0
        if entry.test == "creep":
            assert isinstance(result.fit, gf.CurveFitResult)


@pytest.mark.parametrize("arrays", [True, False])
def test_each_run_result_round_trips(analysed, arrays):
    for entry in analysed.runs:
        result = entry.result
        saved = json.loads(json.dumps(result.to_dict(include_arrays=arrays)))
        rebuilt = type(result).from_dict(saved)
        assert rebuilt == result, entry.name
        assert rebuilt.to_dict(include_arrays=arrays) == saved
        if arrays and entry.test == "startup":
            for name in ("x", "data", "best_fit", "residuals", "weights"):
                assert np.array_equal(getattr(rebuilt.fit, name), getattr(result.fit, name))


def test_saved_records_rebuild_the_same_objects(analysed):
    for entry in analysed.runs:
        saved = json.loads((analysed.output / RUNS_DIR / f"{entry.key}.json").read_text("utf-8"))
        assert (
            saved.pop(RUN_RECORD_MARKER) == ANALYSIS_VERSION == 3 and saved.pop("key") == entry.key
        )
        rebuilt = run_result_from_dict(entry.test, saved)
        assert rebuilt == entry.result
        if entry.test == "startup":  # the weights survive (they used to be lost)
            assert np.array_equal(rebuilt.fit.weights, entry.result.fit.weights)
            assert rebuilt.fit.report() == entry.result.fit.report()
        if entry.test in ("startup", "creep"):  # the records are complete: the fitted points
            assert rebuilt.fit.x.size == rebuilt.fit.ndata > 0
            assert rebuilt.fit == entry.result.fit


def test_failed_run_round_trips():
    failed = FailedRun(reason="no torque column", found={"window": {"points": 3}})
    saved = failed.to_dict()
    assert saved == {
        "window": {"points": 3},
        "warnings": [],
        "status": "failed",
        "reason": failed.reason,
    }
    assert run_result_from_dict("startup", saved) == failed


def test_material_is_typed_and_reads_as_the_mapping(analysed):
    material = analysed.material
    assert isinstance(material.alpha, Estimate)
    assert material.alpha.value == material["alpha"]["value"]
    low, high = material.mu_a.ci95
    assert low < material.mu_a.value < high
    assert material["source"] == material.source == "amontons joint fit"
    assert Material().to_dict()["mu_a"] == {"value": None, "stderr": None, "ci95": [None, None]}


def test_joint_stage_is_a_pure_function_of_the_runs(analysed):
    from granflow._parallel import Executor

    before = [entry.to_dict() for entry in analysed.runs]
    with Executor(1, None) as executor:
        first = joint_stage(analysed.runs, executor, mcmc=False, seed=0)
        second = joint_stage(analysed.runs, executor, mcmc=False, seed=0)
    assert first.analyses == second.analyses == analysed.analyses
    assert first.predictions == analysed.predictions and first.material == analysed.material
    assert [entry.to_dict() for entry in analysed.runs] == before


def test_engine_imports_neither_the_demo_nor_the_report():
    code = (
        "import sys, granflow.analysis.engine\n"
        "print(sorted(m for m in sys.modules if m in ('granflow.analysis.demo', "
        "'granflow.analysis.report', 'jinja2', 'matplotlib')))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={"PYTHONPATH": str(SOURCE)},
    ).stdout
    assert out.strip() == "[]"


def test_no_private_names_imported_between_modules():
    package = SOURCE / "granflow" / "analysis"
    found = []
    for path in sorted(package.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("granflow"):
                found += [
                    f"{path.name}: {node.module}.{alias.name}"
                    for alias in node.names
                    if alias.name.startswith("_") and not alias.name.endswith("__")
                ]
    assert found == []


def test_no_module_over_600_lines():
    package = SOURCE / "granflow" / "analysis"
    lengths = {
        p.name: len(p.read_text(encoding="utf-8").splitlines()) for p in package.glob("*.py")
    }
    assert {name: n for name, n in lengths.items() if n > 600} == {}


def test_rebuilt_campaign_holds_the_real_fit_objects(analysed):
    rebuilt = AnalysisResult.from_dict(json.loads(json.dumps(analysed.to_dict())))
    analyses = rebuilt.analyses
    assert isinstance(analyses.velocity_collapse.result, gf.CollapseResult)
    assert isinstance(analyses.amontons.result, gf.AmontonsResult)
    # results.json holds the compact form: everything but the per-point arrays, left empty
    amontons = analysed.analyses.amontons.result
    compact = gf.AmontonsResult.from_dict(amontons.to_dict(include_arrays=False))
    assert analyses.amontons.result == compact
    assert analyses.amontons.result.report() == amontons.report()
    assert isinstance(analyses.model_comparison.result, gf.ModelComparison)
    assert all(isinstance(row.result, gf.PreparationSpread) for row in analyses.preparation_spread)
    assert isinstance(analyses.creep[0].fit, gf.CurveFitResult)
    startup = next(entry for entry in rebuilt.runs if entry.test == "startup")
    assert isinstance(startup.result.fit, gf.FitResult)


def test_analysis_modules_import_in_one_direction():
    """No module of granflow.analysis imports (at module level) one that imports it back."""
    package = SOURCE / "granflow" / "analysis"
    imports = {}
    for path in package.glob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        imports[path.stem] = {
            node.module.rsplit(".", 1)[1]
            for node in tree.body
            if isinstance(node, ast.ImportFrom)
            and (node.module or "").startswith("granflow.analysis.")
        }

    def reaches(start, target, seen=()):
        return any(
            name == target or (name not in seen and reaches(name, target, (*seen, name)))
            for name in imports.get(start, ())
        )

    assert [name for name in imports if reaches(name, name)] == []
    assert not reaches("engine", "report") and not reaches("engine", "demo")
