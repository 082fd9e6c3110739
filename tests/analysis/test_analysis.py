"""granflow.analyze on a small synthetic campaign written as instrument exports."""

import hashlib
import json
import shutil

import numpy as np
import pytest
from conftest import SMALL_NOISE, SMALL_TRUTH, write_small_campaign

import granflow as gf
from granflow.analysis import analyze, classify, startup_data

#: Runs of the small campaign, in manifest order.
SMALL_RUNS = [
    *(f"startup_{load}mN.txt#{i}" for load in (30, 60, 90) for i in (1, 2, 3)),
    "velocity_2um_s.txt#1",
    "velocity_4um_s.txt#1",
    "ramp.txt#1",
    "creep.txt#1",
    "switch.txt#1",
]


def without_timing(results):
    return {key: value for key, value in results.items() if key != "timing"}


def read_results(folder):
    return json.loads((folder / "results.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    return write_small_campaign(tmp_path_factory.mktemp("campaign"))


@pytest.fixture(scope="module")
def baseline(campaign, tmp_path_factory):
    """The campaign analysed in this process (jobs=1), uninterrupted."""
    return analyze(campaign, tmp_path_factory.mktemp("baseline"), jobs=1, quiet=True)


def test_results_layout_and_order(baseline, campaign):
    results = read_results(baseline.output)
    for key in (
        "granflow_version",
        "synthetic",
        "campaign",
        "runs",
        "failed_runs",
        "material",
        "analyses",
        "predictions",
        "warnings",
        "figures",
        "tables",
        "provenance",
        "timing",
    ):
        assert key in results
    assert results["granflow_version"] == gf.__version__
    assert results["synthetic"] is True  # the manifest's notes say so
    assert [run["name"] for run in results["runs"]] == SMALL_RUNS
    assert [run["index"] for run in results["runs"]] == list(range(len(SMALL_RUNS)))
    assert {run["status"] for run in results["runs"]} == {"ok"}
    assert results["failed_runs"] == []
    assert baseline.exit_code == 0
    tests = [run["test"] for run in results["runs"]]
    assert tests == ["startup"] * 11 + ["ramp", "creep", "switch"]
    counts = results["campaign"]["counts"]
    assert counts["normal_loads"] == [0.03, 0.06, 0.09]
    assert counts["velocities"] == [8.6e-07, 2e-06, 4e-06]
    assert counts["tests"] == {"startup": 11, "creep": 1, "ramp": 1, "switch": 1}
    assert set(results["analyses"]) >= {
        "velocity_collapse",
        "amontons",
        "preparation_spread",
        "model_comparison",
        "stress_ramp",
        "creep",
        "switch",
    }
    assert results["analyses"]["model_comparison"]["best_aic"] == "eq3"
    # the inputs are hashed: check against hashlib on the files themselves
    inputs = {entry["file"]: entry["sha256"] for entry in results["provenance"]["inputs"]}
    for name in ("manifest.yaml", "startup_30mN.txt", "ramp.txt", "switch.txt"):
        assert inputs[name] == hashlib.sha256((campaign.parent / name).read_bytes()).hexdigest()
    assert results["timing"]["fitted_now"] == len(SMALL_RUNS)
    assert results["timing"]["reused"] == 0


def test_tables_and_figures_are_written(baseline):
    import pandas as pd

    results = baseline.results
    for name in ("runs", "loads", "material", "predictions", "stability_map"):
        paths = results["tables"][name]
        csv = pd.read_csv(baseline.output / paths["csv"])
        parquet = pd.read_parquet(baseline.output / paths["parquet"])
        assert len(csv) == len(parquet) > 0
    runs = pd.read_csv(baseline.output / results["tables"]["runs"]["csv"])
    assert runs["name"].tolist() == SMALL_RUNS
    # display units, named in the columns
    assert runs["normal_load_mN"].tolist() == pytest.approx(
        [1e3 * run["normal_load"] for run in results["runs"]], rel=1e-12
    )
    fitted = [run for run in results["runs"] if (run.get("fit") or {}).get("params", {}).get("x0")]
    x0 = dict(zip(runs["name"], runs["x0_um"], strict=True))
    for run in fitted:
        assert x0[run["name"]] == pytest.approx(1e6 * run["fit"]["params"]["x0"], rel=1e-12)
    assert {"velocity_um_per_s", "alpha_per_m", "Fd_stderr_mN"} <= set(runs.columns)
    loads = pd.read_csv(baseline.output / results["tables"]["loads"]["csv"])
    assert {"normal_load_mN", "F_peak_mN", "alpha_v_mean_per_s"} <= set(loads.columns)
    material = pd.read_csv(baseline.output / results["tables"]["material"]["csv"])
    assert material["constant"].tolist() == ["mu_a", "mu_d", "alpha"]
    assert material["value"].tolist() == [
        results["material"][n]["value"] for n in material["constant"]
    ]
    names = [figure["name"] for figure in results["figures"]]
    assert {"startup", "collapse", "amontons", "stability_map"} <= set(names)
    for figure in results["figures"]:  # each drawn once, as PNG only by default
        assert (baseline.output / figure["png"]).stat().st_size > 0
        assert "svg" not in figure and "pdf" not in figure
    assert not list((baseline.output / "figures").glob("*.svg"))
    assert not list(baseline.output.rglob("*.tmp"))


def test_material_constants_contain_the_truth(baseline):
    material = baseline.results["material"]
    assert material["source"] == "amontons joint fit"
    for name, truth in SMALL_TRUTH.items():
        entry = material[name]
        low, high = entry["ci95"]
        assert low < entry["value"] < high
        assert low <= truth <= high, name
        assert 0 < entry["stderr"] < 0.01 * truth


def test_static_yield_prediction_matches_the_truth(baseline):
    rows = baseline.results["predictions"]["static_yield"]
    assert [row["normal_load"] for row in rows] == [0.03, 0.06, 0.09]
    for row in rows:
        load = row["normal_load"]
        truth = gf.Params(
            SMALL_TRUTH["mu_a"] * load, SMALL_TRUTH["alpha"], SMALL_TRUTH["mu_d"] * load, 3.0e-7
        )  # mean x0 of the repeats
        expected = gf.peak(truth).force
        low, high = row["ci95"]
        assert low <= expected <= high
        assert row["repeats"] == 3  # the start-ups at the most common velocity


def test_stress_controlled_runs_against_the_model(baseline):
    analyses = baseline.results["analyses"]
    params = gf.Params(
        SMALL_TRUTH["mu_a"] * 0.06, SMALL_TRUTH["alpha"], SMALL_TRUTH["mu_d"] * 0.06, 3.0e-7
    )
    ramp = analyses["stress_ramp"][0]
    # quasi-statically, the layer fails at the peak of the rate-controlled curve; the last
    # point before the runaway lies just below it
    failure_force = ramp["observed"]["failure_force"]
    assert gf.peak(params).force * (1 - 2e-3) < failure_force <= gf.peak(params).force
    assert ramp["consistent"] is True
    creep = analyses["creep"][0]
    assert creep["stress"] == pytest.approx(0.9 * gf.peak(params).force, rel=1e-9)
    assert creep["stress_over_peak"] == pytest.approx(0.9, rel=0.02)
    switch = analyses["switch"][0]
    # found from the velocity: at the first sample under stress control (the simulated
    # record has one row per instant since issue 31: the one at 80 s is the switch's)
    assert switch["switch_time"] == pytest.approx(80.0)
    # the imposed force over the rate-controlled force carried on to the switch from its
    # last two samples (0.4 s before it)
    assert switch["factor"] == pytest.approx(1.01, rel=1e-4)
    assert switch["observed"]["outcome"] == "failure"  # after the peak: it fails (Fig. 3c)
    assert switch["predicted"]["outcome"] == "failure"
    assert switch["agree"] is True
    stability = baseline.results["predictions"]["stability_map"]
    outcomes = np.array(stability["outcome"])
    ratios = np.array(stability["stress_ratios"])
    assert np.all(outcomes[:, ratios < 1] == "stop")  # below the current force: it stops
    assert np.any(outcomes == "failure")


def test_velocity_collapse_and_preparation_spread(baseline):
    collapse = baseline.results["analyses"]["velocity_collapse"]
    assert collapse["velocities"] == [8.6e-07, 2e-06, 4e-06]
    assert collapse["normal_load"] == 0.06
    assert collapse["collapses"] is True  # one curve in slip, as the data were made
    spreads = baseline.results["analyses"]["preparation_spread"]
    assert [row["normal_load"] for row in spreads] == [0.03, 0.06, 0.09]
    for row in spreads:
        assert row["repeats"] == 3
        # x0 of the repeats: 0.22, 0.30, 0.38 um
        assert row["start"]["mean"] == pytest.approx(3.0e-7, rel=0.1)


def test_jobs_2_gives_identical_results(baseline, campaign, tmp_path):
    result = analyze(campaign, tmp_path, jobs=2, quiet=True)
    assert result.results["timing"]["jobs"] == 2
    assert without_timing(read_results(tmp_path)) == without_timing(read_results(baseline.output))


def test_dask_local_cluster_gives_identical_results(baseline, campaign, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        result = analyze(campaign, tmp_path, scheduler=cluster, quiet=True)
    assert result.results["timing"]["scheduler"].startswith("dask tcp://")
    assert without_timing(read_results(tmp_path)) == without_timing(read_results(baseline.output))


class _Interrupt(KeyboardInterrupt):
    pass


def test_interrupted_analysis_resumes_without_refitting(baseline, campaign, tmp_path):
    def stop_after_five(done, total, name):
        if done == 5:
            raise _Interrupt

    with pytest.raises(_Interrupt):
        analyze(campaign, tmp_path, jobs=2, quiet=True, progress=stop_after_five)
    records = sorted((tmp_path / "runs").glob("*.json"))
    assert 5 <= len(records) < len(SMALL_RUNS)
    for record in records:  # complete JSON, nothing half-written
        assert json.loads(record.read_text(encoding="utf-8"))["status"] == "ok"
    assert not list(tmp_path.rglob("*.tmp"))
    assert not (tmp_path / "results.json").exists()
    result = analyze(campaign, tmp_path, jobs=2, quiet=True, resume=True)
    timing = read_results(tmp_path)["timing"]
    assert timing["reused"] == len(records)
    assert timing["fitted_now"] == len(SMALL_RUNS) - len(records)
    assert result.fitted_now == timing["fitted_now"]
    assert without_timing(read_results(tmp_path)) == without_timing(read_results(baseline.output))


def test_resume_refits_only_the_runs_whose_data_changed(campaign, tmp_path):
    folder = tmp_path / "campaign"
    shutil.copytree(campaign.parent, folder)
    output = tmp_path / "out"
    analyze(folder, output, jobs=1, quiet=True)
    # rewrite one file with other noise: its run must be fitted again, the rest reused
    changed = gf.read_runs(folder / "velocity_2um_s.txt")[0]
    noisy = changed.force + np.random.default_rng(7).normal(0.0, SMALL_NOISE, len(changed))
    gf.io.write_trios(
        folder / "velocity_2um_s.txt",
        gf.Run(changed.t, changed.slip, changed.velocity, noisy, meta=dict(changed.meta)),
    )
    again = analyze(folder / "manifest.yaml", output, jobs=1, quiet=True, resume=True)
    assert (again.fitted_now, again.reused) == (1, len(SMALL_RUNS) - 1)
    assert len(list((output / "runs").glob("*.json"))) == len(SMALL_RUNS)  # stale one removed


def test_a_corrupt_file_is_named_and_the_rest_is_analysed(campaign, tmp_path):
    folder = tmp_path / "campaign"
    shutil.copytree(campaign.parent, folder)
    (folder / "velocity_2um_s.txt").write_bytes(b"\x00\xffnot an export\n\x13\x37" * 20)
    result = analyze(folder, tmp_path / "out", jobs=1, quiet=True)
    assert result.exit_code == 1
    results = read_results(tmp_path / "out")
    [failed] = results["failed_runs"]
    assert failed["source"] == "velocity_2um_s.txt"
    assert "velocity_2um_s.txt" in failed["reason"]
    entry = results["runs"][SMALL_RUNS.index("velocity_2um_s.txt#1")]
    assert (entry["name"], entry["status"]) == ("velocity_2um_s.txt", "failed")
    assert [run["status"] for run in results["runs"]].count("ok") == len(SMALL_RUNS) - 1
    assert any("velocity_2um_s.txt" in warning for warning in results["warnings"])
    assert "velocity_2um_s.txt" in result.summary()
    assert "velocity_2um_s.txt" in (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert results["material"]["mu_a"]["value"] is not None


def test_user_files_survive_a_fresh_start(campaign, tmp_path):
    (tmp_path / "runs").mkdir()
    notes = tmp_path / "notes.txt"
    notes.write_text("mine", encoding="utf-8")
    mine = tmp_path / "runs" / "mine.json"
    mine.write_text('{"status": "mine"}', encoding="utf-8")
    stale = tmp_path / "runs" / "old-run.json"
    stale.write_text('{"granflow_run_record": 1, "key": "old-run"}', encoding="utf-8")
    analyze(campaign, tmp_path, jobs=1, quiet=True)
    assert notes.read_text(encoding="utf-8") == "mine"
    assert mine.read_text(encoding="utf-8") == '{"status": "mine"}'
    assert not stale.exists()


def _startup(load, x0, rng, *, rising_only=False, velocity=0.86e-6):
    params = gf.Params(
        SMALL_TRUTH["mu_a"] * load, SMALL_TRUTH["alpha"], SMALL_TRUTH["mu_d"] * load, x0
    )
    t = np.arange(1.0, 301.0)
    slip = velocity * t
    force = gf.friction_slip(slip, params)
    if rising_only:  # a curve without overshoot: Eq. 3 cannot be fitted
        force = SMALL_TRUTH["mu_d"] * load * (1 - np.exp(-slip / 5e-5))
    force = force + rng.normal(0.0, SMALL_NOISE, t.size)
    meta = {"normal_load": load, "velocity": velocity, "source": f"run{x0:.3g}", "interval": 1}
    return gf.Run(t, slip, np.full(t.size, velocity), force, meta=meta)


def test_campaign_source_single_load_and_a_failed_fit(tmp_path):
    rng = np.random.default_rng(3)
    runs = [_startup(0.05, x0, rng) for x0 in (2.5e-7, 3.5e-7)]
    runs.append(_startup(0.05, 3e-7, rng, rising_only=True))
    result = analyze(gf.Campaign(runs), tmp_path, jobs=1, quiet=True)
    assert result.exit_code == 1
    [failed] = result.failed_runs
    assert failed["name"] == "run3e-07#1"
    assert "overshoot" in failed["reason"]
    material = result.material
    assert "single load" in material["source"]
    for name, truth in SMALL_TRUTH.items():
        low, high = material[name]["ci95"]
        assert low <= truth <= high, name


def test_runs_without_a_load_give_no_material_constants(tmp_path):
    rng = np.random.default_rng(4)
    runs = [_startup(0.05, 3e-7, rng)]
    runs = [gf.Run(r.t, r.slip, r.velocity, r.force, meta={"velocity": 0.86e-6}) for r in runs]
    result = analyze(gf.Campaign(runs), tmp_path, jobs=1, quiet=True)
    assert result.exit_code == 0
    material = result.material
    assert material["mu_a"] == {"value": None, "stderr": None, "ci95": [None, None]}
    assert "no normal load" in material["reason"]
    assert result.results["predictions"]["static_yield"] == []
    assert "not determined" in result.summary()


def test_mcmc_is_seeded(tmp_path):
    pytest.importorskip("emcee")
    rng = np.random.default_rng(5)
    campaign = gf.Campaign([_startup(0.05, 3e-7, rng)])
    first = analyze(campaign, tmp_path / "a", jobs=1, quiet=True, mcmc=True, seed=11)
    second = analyze(campaign, tmp_path / "b", jobs=1, quiet=True, mcmc=True, seed=11)
    posterior = first.results["analyses"]["mcmc"]
    assert posterior["seed"] == 11
    assert "chain" not in posterior and posterior["shape"][0] > 0  # the compact form
    assert posterior == second.results["analyses"]["mcmc"]
    low, high = posterior["ci95"]["alpha"]
    assert low <= SMALL_TRUTH["alpha"] <= high
    assert "corner" in [figure["name"] for figure in first.results["figures"]]


def test_progress_lines_and_quiet(campaign, tmp_path, capsys):
    rng = np.random.default_rng(6)
    campaign = gf.Campaign([_startup(0.05, x0, rng) for x0 in (2.5e-7, 3.5e-7)])
    analyze(campaign, tmp_path / "loud", jobs=1)
    err = capsys.readouterr().err
    assert "fitted 1/2: run2.5e-07#1" in err and "fitted 2/2: run3.5e-07#1" in err
    # a record family the campaign has no records of is no stage of its progress
    assert "velocity steps" not in err and "slide hold slide" not in err
    seen = []
    analyze(campaign, tmp_path / "quiet", jobs=1, quiet=True, progress=lambda *a: seen.append(a))
    assert capsys.readouterr().err == ""
    assert seen == [(1, 2, "run2.5e-07#1"), (2, 2, "run3.5e-07#1")]


@pytest.mark.parametrize(
    ("source", "message"),
    [("missing-folder", "no such manifest"), (".", "holds no manifest")],
)
def test_bad_sources_are_named(tmp_path, monkeypatch, source, message):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(gf.GranflowError, match=message):
        analyze(source, tmp_path / "out")


def test_classify_from_the_data():
    params = gf.Params(3e-3, 5e4, 10e-3, 3e-7)
    velocity = 0.86e-6

    def simulated(segments, **options):
        run = gf.simulate(params, segments, **options).to_run()
        return gf.Run(run.t, run.slip, run.velocity, run.force, control=run.control)

    t = np.arange(1.0, 100.0)
    startup = gf.Run(
        t, velocity * t, np.full(t.size, velocity), gf.friction_slip(velocity * t, params)
    )
    assert classify(startup) == "startup"
    assert classify(simulated([gf.ForceRamp(rate=0.1e-3, duration=300.0)])) == "ramp"
    assert (
        classify(simulated([gf.Force(level=12e-3, duration=300.0)], direct_effect=0.2e-3))
        == "creep"
    )
    switch = simulated([gf.Velocity(velocity, 80.0), gf.SwitchToForce(60.0, factor=1.01)])
    assert classify(switch) == "switch"
    declared = gf.Run(
        startup.t, startup.slip, startup.velocity, startup.force, meta={"test": "creep"}
    )
    assert classify(declared) == "creep"


def _ramp_and_curve(rate, ramp_end, seed):
    """A start-up sampled at ``rate`` points per second, with an elastic ramp (force in a
    straight line from zero) up to ``ramp_end`` seconds (0: none)."""
    params = gf.Params.from_time_domain(3.31e-3, 0.036, 0.23, 10e-3, 0.86e-6)
    t = np.arange(0.0, 300.0, 1.0 / rate)
    slip = 0.86e-6 * t
    force = np.where(
        slip < params.x0,
        gf.initial_force(params),
        gf.friction_slip(np.maximum(slip, params.x0), params),
    )
    if ramp_end:
        end = 0.86e-6 * ramp_end
        force = np.where(slip < end, gf.friction_slip(end, params) * slip / end, force)
    force = force + np.random.default_rng(seed).normal(0.0, 3e-5, t.size)
    return gf.Run(t, slip, np.full(t.size, 0.86e-6), force, meta={"velocity": 0.86e-6})


def test_startup_window_leaves_out_the_elastic_ramp():
    run = _ramp_and_curve(10, 3.0, seed=1)
    data = startup_data(run)
    assert data.abscissa == "slip"
    assert 25 <= data.elastic_points <= 30  # the straight line ends at t = 3 s, point 30
    assert data.slip[0] == run.slip[data.elastic_points]
    x0 = 0.23 * 0.86e-6
    low, high = gf.fit((data.slip, data.force)).ci95["x0"]
    assert low <= x0 <= high
    low, high = gf.fit(run).ci95["x0"]  # every point: the ramp biases x0 (by 76 % here)
    assert not low <= x0 <= high


def test_startup_window_keeps_a_curve_without_ramp():
    data = startup_data(_ramp_and_curve(1, 0.0, seed=2))
    assert data.elastic_points == 0
    assert data.slip.size == 300


def test_startup_window_uses_velocity_times_time_without_a_slip():
    run = _ramp_and_curve(1, 0.0, seed=2)
    run = gf.Run(run.t, np.full(len(run), np.nan), run.velocity, run.force, meta=dict(run.meta))
    data = startup_data(run)
    assert data.abscissa == "velocity*time"
    assert np.array_equal(data.slip, 0.86e-6 * run.t)
