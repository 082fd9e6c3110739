"""Data quality, strictness, bad manifest entries and the geometry in a whole analysis."""

import json

import numpy as np
import pytest
import yaml
from conftest import SMALL_TRUTH, _startup_run

import granflow as gf
from granflow.analysis import AnalysisResult, analyze
from granflow.io import write_rheocompass

LOADS = (0.03, 0.06, 0.09)
TRUNCATED = "truncated block: 79 of the 401 points declared"


def _startups(seed, points=200):
    """Two start-ups at each load (0.86 µm/s), with the load in their metadata."""
    rng = np.random.default_rng(seed)
    return [
        _startup_run(load, 0.86e-6, x0, rng, points=points)
        for load in LOADS
        for x0 in (2.2e-7, 3.4e-7)
    ]


def _names(results, where):
    return [run["name"] for run in results["runs"] if where(run)]


@pytest.fixture(scope="module")
def damaged(tmp_path_factory):
    """One clean campaign analysed loosely, then strictly (reusing the saved runs): run 1 has
    NaN force cells, run 4 a reader's problem."""
    runs = _startups(seed=3)
    force = np.array(runs[1].force)
    force[[40, 41, 120]] = np.nan
    runs[1] = gf.Run(runs[1].t, runs[1].slip, runs[1].velocity, force, meta=dict(runs[1].meta))
    runs[4] = gf.Run(
        runs[4].t,
        runs[4].slip,
        runs[4].velocity,
        runs[4].force,
        meta=dict(runs[4].meta),
        problems=(TRUNCATED,),
    )
    output = tmp_path_factory.mktemp("damaged")
    loose = analyze(gf.Campaign(runs), output, jobs=1, quiet=True)
    loose_results = json.loads((output / "results.json").read_text(encoding="utf-8"))
    loose_report = (output / "report.html").read_text(encoding="utf-8")
    strict = analyze(gf.Campaign(runs), output, jobs=1, quiet=True, resume=True, strict=True)
    return loose, loose_results, loose_report, strict


def test_problems_reach_results_json_and_the_report(damaged):
    loose, results, report, _ = damaged
    assert loose.exit_code == 0
    problems = [run["problems"] for run in results["runs"]]
    assert problems[1] == [
        "3 points with a NaN or infinite time, slip or force left out of the fit"
    ]
    assert problems[4] == [TRUNCATED]
    assert [p for i, p in enumerate(problems) if i not in (1, 4)] == [[]] * 4
    assert results["runs"][1]["window"]["non_finite"] == 3
    assert results["campaign"]["counts"]["with_problems"] == 2
    section = report[report.index('id="data-quality"') : report.index('id="warnings"')]
    assert "2 runs with data-quality problems" in section
    assert TRUNCATED in section and "left out of the fit" in section
    run_table = report[report.index('id="run-table"') :]
    run_table = run_table[: run_table.index("</table>")]
    assert run_table.count('">data quality</span>') == 2
    assert "data quality: 2 runs with problems" in loose.summary()
    again = AnalysisResult.from_dict(loose.to_dict())
    assert again == loose and again.runs[4].problems == (TRUNCATED,)


def test_strict_fails_the_runs_with_problems_and_analyses_the_rest(damaged):
    loose, _, _, strict = damaged
    assert strict.exit_code == 1 and strict.reused == len(strict.runs)
    failed = strict.failed_runs
    assert [entry["name"] for entry in failed] == [loose.runs[1].name, loose.runs[4].name]
    assert all(entry["stage"] == "quality" for entry in failed)
    assert TRUNCATED in failed[1]["reason"] and failed[1]["reason"].startswith("strict: ")
    assert sum(entry.ok for entry in strict.runs) == 4
    assert strict.material.determined and strict.material.runs == 4
    assert strict.provenance["options"]["strict"] is True


def test_bad_manifest_entries_fail_alone_under_their_own_label(tmp_path):
    runs = _startups(seed=4)
    write_rheocompass(tmp_path / "startups.txt", runs)
    entries = [
        {"file": "startups.txt", "interval": i + 1, "normal_load": f"{run.normal_load * 1e3:g} mN"}
        for i, run in enumerate(runs)
    ]
    levels = ['&l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    levels += [f"&l{k} [{', '.join([f'*l{k - 1}'] * 9)}]" for k in range(1, 9)]
    bad = [
        f"- {{file: startups.txt, interval: 1, notes: [{', '.join(levels)}]}}",
        "- {file: startups.txt, interval: 2, normal_load: 30 mN, colour: red}",
        "- {file: startups.txt, interval: 3, normal_load: -1 mN}",
        "- {file: startups.txt, interval: 99, normal_load: 30 mN}",
        "- {file: startups.txt, interval: 5, normal_load: 20}",
    ]
    manifest = tmp_path / "manifest.yaml"
    text = yaml.safe_dump(entries, sort_keys=False) + "\n".join(bad) + "\n"
    manifest.write_text(text, encoding="utf-8")
    result = analyze(manifest, tmp_path / "out", jobs=1, quiet=True)
    results = json.loads((tmp_path / "out" / "results.json").read_text(encoding="utf-8"))
    assert result.exit_code == 1
    names = [run["name"] for run in results["runs"]]
    assert names[6:] == [
        "startups.txt#1",
        "startups.txt#2",
        "startups.txt#3",
        "startups.txt#99",
        "startups.txt#5",
    ]
    line = {k: text.splitlines().index(entry) + 1 for k, entry in enumerate(bad)}
    expected = [
        f"entry 7 (line {line[0]}): YAML anchors and aliases are not allowed",
        f"entry 8 (line {line[1]}): unknown field 'colour'",
        f"entry 9 (line {line[2]}): normal_load must be positive, got '-1 mN'",
        "no interval 99 (the file has 6)",
        f"entry 11 (line {line[4]}): normal_load 20 has no unit",
    ]
    for run, message in zip(results["runs"][6:], expected, strict=True):
        assert run["status"] == "failed" and run["stage"] == "read"
        assert message in run["reason"] and "\n" not in run["reason"]
        assert run["problems"] == [run["reason"]]
    assert [run["status"] for run in results["runs"][:6]] == ["ok"] * 6
    assert result.material.determined
    assert results["campaign"]["geometry"] == "paper (default)"
    report = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert 'id="geometry">paper (default)<' in report


def test_a_declared_geometry_recovers_the_truth(tmp_path):
    tube = gf.Annulus.from_spec("outer_radius=10 mm, inner_radius=7 mm")
    runs = _startups(seed=5, points=300)
    write_rheocompass(tmp_path / "startups.txt", runs, geometry=tube)
    entries = [
        {"file": "startups.txt", "interval": i + 1, "normal_load": f"{run.normal_load * 1e3:g} mN"}
        for i, run in enumerate(runs)
    ]
    document = {"defaults": {"geometry": "outer_radius=10 mm, inner_radius=7 mm"}, "runs": entries}
    manifest = tmp_path / "manifest.yaml"
    manifest.write_text(yaml.safe_dump(document, sort_keys=False), encoding="utf-8")
    result = analyze(manifest, tmp_path / "out", jobs=1, quiet=True)
    assert result.exit_code == 0
    for name, truth in SMALL_TRUTH.items():
        low, high = result.material[name]["ci95"]
        assert low <= truth <= high, name
    label = result.campaign["geometry"]
    assert label.startswith("outer radius 10 mm, inner radius 7 mm")
    assert {entry.geometry for entry in result.runs} == {label}
    report = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert f'id="geometry">{label}<' in report
    # the same files read with the paper's tube: every force off by the ratio of the r_eff
    # the manifest's own geometry wins over the caller's default
    assert gf.Campaign.from_manifest(manifest, geometry="paper")[0].meta["geometry"] == label
    undeclared = tmp_path / "undeclared.yaml"
    undeclared.write_text(yaml.safe_dump({"runs": entries}), encoding="utf-8")
    first = gf.Campaign.from_manifest(undeclared)[0]
    assert first.meta["geometry"] == "paper (default)"
    ratio = gf.Annulus.paper().effective_radius / tube.effective_radius
    np.testing.assert_allclose(first.force * ratio, runs[0].force, rtol=1e-9, atol=1e-12)


def test_the_summary_never_crashes_on_missing_numbers(damaged):
    loose = damaged[0]
    saved = loose.to_dict()
    for name in ("mu_a", "mu_d", "alpha"):
        saved["material"][name].update(stderr=None, ci95=[None, None])
    for row in saved["predictions"]["static_yield"]:
        row.update(F_peak=None, stderr=None)
    text = AnalysisResult.from_dict(saved).summary()
    assert "± n/a" in text and "95%: [n/a, n/a]" in text and "-> n/a mN" in text


def test_failing_fits_still_write_the_report_and_exit_1(tmp_path):
    rng = np.random.default_rng(6)
    runs = []
    for load in LOADS:
        t = np.linspace(0.0, 100.0, 50)
        runs.append(
            gf.Run(
                t=t,
                slip=0.86e-6 * t,
                velocity=np.full(t.size, 0.86e-6),
                force=rng.normal(0.0, 1e-4, t.size),
                meta={"normal_load": load},
            )
        )
    result = analyze(gf.Campaign(runs), tmp_path, jobs=1, quiet=True)
    assert result.exit_code == 1
    assert (tmp_path / "report.html").is_file() and (tmp_path / "results.json").is_file()
    assert "material constants: not determined" in result.summary()
