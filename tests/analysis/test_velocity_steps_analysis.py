"""`granflow analyze` on a campaign holding velocity-step records: the rate-and-state fit and
the model comparison in results.json, the report's section and its summary line, a broken
record failing alone, and the same results with --jobs 2 and --resume."""

import json
import re

import numpy as np
import pytest
import yaml
from conftest import SMALL_NOISE, SMALL_TRUTH, analyze_in_fresh_process, shared_data

import granflow as gf
from granflow import rsf
from granflow.analysis.result import AnalysisResult
from granflow.cli import main

#: The synthetic truth of the velocity-step record (aging law, velocity weakening).
TRUTH = {"a": 0.008, "b": 0.012, "Dc": 20e-6}
V1, V2 = 1e-6, 1e-5


def _write_steps(path, seed=7):
    """A 1 -> 10 µm/s step simulated with the aging law, in the real files' format."""
    model = rsf.RateState(
        0.6, TRUTH["a"], V1, 2000.0, [rsf.State(TRUTH["b"], TRUTH["Dc"], "aging")]
    )
    protocol = gf.Protocol([gf.Velocity(V1, 40.0), gf.Velocity(V2, 40.0)])
    t = np.arange(0.0, 80.0001, 0.1)
    mu = rsf.simulate(model, protocol, t_eval=t).friction
    mu = mu + np.random.default_rng(seed).normal(0.0, 3e-4, t.size)
    displacement = np.where(t <= 40.0, V1 * t, V1 * 40.0 + V2 * (t - 40.0)) * 1e6
    lines = ["Time(s)\tDispl(microns)\tFriction\tEffective_Normal_stress(MPa)"]
    lines += [
        f"{1000.0 + ti:.6f}\t{5000.0 + xi:.6f}\t{mi:.6f}\t30.000000"
        for ti, xi, mi in zip(t, displacement, mu, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _startup(x0, seed, load=0.05, velocity=0.86e-6):
    params = gf.Params(
        SMALL_TRUTH["mu_a"] * load, SMALL_TRUTH["alpha"], SMALL_TRUTH["mu_d"] * load, x0
    )
    t = np.arange(1.0, 301.0)
    slip = velocity * t
    force = gf.friction_slip(slip, params)
    force = force + np.random.default_rng(seed).normal(0.0, SMALL_NOISE, t.size)
    return gf.Run(t, slip, np.full(t.size, velocity), force)


def _campaign(folder, steps):
    """Two start-ups (TRIOS exports, the demo's writer) and the velocity-step ``steps``."""
    folder.mkdir(parents=True, exist_ok=True)
    runs = []
    for index, x0 in enumerate((2.5e-7, 3.5e-7)):
        name = f"startup_{index}.txt"
        gf.io.write_trios(folder / name, _startup(x0, seed=index))
        runs.append({"file": name, "test": "startup"})
    runs += steps
    manifest = {
        "defaults": {"normal_load": "50 mN", "velocity": "0.86 um/s"},
        "runs": runs,
    }
    (folder / "manifest.yaml").write_text(yaml.safe_dump(manifest), encoding="utf-8")
    return folder / "manifest.yaml"


def _without_timing(results):
    return {k: v for k, v in results.items() if k != "timing"}


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    folder = tmp_path_factory.mktemp("vsteps")
    (folder / "campaign").mkdir()
    _write_steps(folder / "campaign" / "steps.txt")
    (folder / "campaign" / "broken_steps.txt").write_text("Time(s)\tFriction\n1\t0.5\n", "utf-8")
    manifest = _campaign(
        folder / "campaign",
        [
            {"file": "steps.txt", "test": "velocity_steps", "law": "aging"},
            {"file": "broken_steps.txt", "test": "velocity_steps"},
        ],
    )
    result = gf.analyze(manifest, folder / "out", jobs=1, quiet=True)
    return manifest, folder / "out", result


def test_results_hold_the_fit_and_the_comparison(analysed):
    _, output, result = analysed
    steps = result.results["velocity_steps"]
    [record] = steps["records"]
    assert record["name"] == "steps.txt" and record["law"] == "aging"
    assert record["fit"]["success"] is True
    table = {row["name"]: row for row in record["fit"]["parameters"]}
    for name, truth in TRUTH.items():
        low, high = table[name]["ci95"]
        assert low <= truth <= high, (name, low, high)
    # a - b against the truth, within its 95 % interval
    half = 1.96 * record["fit"]["a_minus_b_stderr"]
    assert abs(record["fit"]["a_minus_b"] - (TRUTH["a"] - TRUTH["b"])) <= half
    comparison = record["comparison"]
    assert comparison["best_aic"] == "rsf_aging"
    models = {row["model"] for row in comparison["rows"]}
    assert {"rsf_aging", "rsf_slip", "eq2", "eq2_direct"} <= models
    assert (output / record["figure"]).read_bytes().startswith(b"\x89PNG")
    # the velocity-step files were not read as rheometer exports: two runs, both start-ups
    assert [run["test"] for run in result.results["runs"]] == ["startup", "startup"]
    assert "steps.txt" in {item["file"] for item in result.results["provenance"]["inputs"]}


def test_a_broken_record_fails_alone(analysed):
    _, _, result = analysed
    failed = {f["name"]: f for f in result.failed_runs}
    assert set(failed) == {"broken_steps.txt"}
    assert failed["broken_steps.txt"]["stage"] == "velocity_steps"
    assert "displacement" in failed["broken_steps.txt"]["reason"]
    assert result.exit_code == 1
    assert all(run["status"] == "ok" for run in result.results["runs"])


def test_results_round_trip(analysed):
    _, _, result = analysed
    again = AnalysisResult.from_dict(result.to_dict())
    assert again.to_dict() == result.to_dict()
    assert again.velocity_steps.records[0].name == "steps.txt"
    assert again.velocity_steps == result.velocity_steps
    assert "velocity steps steps.txt: a - b = " in result.summary()


def test_report_has_the_section_and_the_summary_line(analysed):
    _, output, _ = analysed
    html = (output / "report.html").read_text(encoding="utf-8")
    section = html[html.index('<section id="velocity-steps">') :]
    section = section[: section.index('<section id="campaign">')]
    assert 'href="#velocity-steps"' in html
    assert "data:image/png;base64," in section
    assert 'class="velocity-step-parameters"' in section
    assert 'class="velocity-step-comparison"' in section
    assert "Best by AIC: <strong>rsf_aging</strong>" in section
    start = html.index('<section id="summary">')
    summary = html[start : html.index("</section>", start)]
    line = re.search(r"Velocity steps \(2 records\):[^<]*", summary)
    assert line is not None
    assert "a − b = " in line.group(0) and "best by AIC rsf_aging" in line.group(0)
    assert "broken_steps.txt failed" in line.group(0)


def test_jobs_and_resume_give_identical_results(analysed, tmp_path):
    manifest, output, result = analysed
    again = gf.analyze(manifest, output, jobs=2, quiet=True, resume=True)
    assert again.reused == 2
    assert _without_timing(again.results) == _without_timing(result.results)


def test_the_real_record_through_the_command(tmp_path, capsys):
    """The sepiolite record analysed by ``granflow analyze``: the slip law is preferred by
    AIC, as compare_models alone finds (tests/rsf/test_rsf_compare.py), and the command's
    summary states it."""
    path = shared_data("rate-state-velocity-steps", "velstep3_TR2_exp013_sepiolite.txt")
    manifest = _campaign(
        tmp_path / "campaign", [{"file": str(path), "test": "velocity_steps", "law": "slip"}]
    )
    # the shared record lies outside the campaign folder: read only when allowed
    command = ["analyze", str(manifest), "-o", str(tmp_path / "out"), "--jobs", "1", "--quiet"]
    assert main(command) == 1
    assert "outside the campaign folder" in capsys.readouterr().out
    code = main([*command, "--allow-outside"])
    assert code == 0
    results = json.loads((tmp_path / "out" / "results.json").read_text(encoding="utf-8"))
    [record] = results["velocity_steps"]["records"]
    assert results["failed_runs"] == []
    assert record["comparison"]["best_aic"] == "rsf_slip"
    assert record["fit"]["success"] is True
    assert f"velocity steps {path}: a - b = " in capsys.readouterr().out


def test_the_manifest_takes_velocity_steps_and_checks_the_law(tmp_path):
    from granflow.io.manifest import BadEntry, read_manifest

    manifest = tmp_path / "manifest.yaml"
    manifest.write_text(
        "runs:\n"
        "  - {file: a.txt, test: velocity_steps, law: Slip}\n"
        "  - {file: b.txt, test: velocity_steps, law: dieterich}\n",
        encoding="utf-8",
    )
    good, bad = read_manifest(manifest, errors="collect")
    assert good["test"] == "velocity_steps" and good["law"] == "slip"
    assert isinstance(bad, BadEntry) and "law must be one of aging, slip" in bad.reason


def test_a_parallel_analysis_fits_the_records_on_a_worker(analysed, tmp_path):
    """With workers, the rate-and-state fits and their figures (matplotlib) run on one of
    them: this process loads neither pandas nor matplotlib, and the results are those of the
    analysis in one process."""
    manifest, output, _ = analysed
    assert analyze_in_fresh_process(manifest, tmp_path / "out") == (False, False)
    here = json.loads((tmp_path / "out" / "results.json").read_text(encoding="utf-8"))
    there = json.loads((output / "results.json").read_text(encoding="utf-8"))
    assert _without_timing(here) == _without_timing(there)
    assert (tmp_path / "out" / here["velocity_steps"]["records"][0]["figure"]).is_file()
