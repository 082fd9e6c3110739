"""The demo campaign: it reads back through the manifest with no problems, its files agree with
its truth file (the model, the noise, the failures), fits recover the constants it was made
with, one seed gives byte-identical files, and it never writes over a user's folder."""

import json
import math
from collections import Counter

import numpy as np
import pytest
import yaml
from scipy.optimize import brentq

import granflow
from granflow.analysis.demo import TRUTH_FILE, make_demo_campaign

VELOCITY = 0.86e-6  # m/s, the paper's


def files_of(directory):
    """{relative path: bytes} of every file under ``directory``."""
    return {
        str(path.relative_to(directory)): path.read_bytes()
        for path in sorted(directory.rglob("*"))
        if path.is_file()
    }


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    directory = tmp_path_factory.mktemp("demo")
    manifest = make_demo_campaign(directory, seed=0)
    truth = json.loads((directory / TRUTH_FILE).read_text(encoding="utf-8"))
    campaign = granflow.Campaign.from_manifest(manifest, errors="collect")
    return directory, manifest, truth, campaign


def runs_of(demo, test):
    _, _, truth, campaign = demo
    pairs = zip(campaign, truth["runs"], strict=True)
    return [(run, entry) for run, entry in pairs if entry["test"] == test]


def params_of(entry):
    return granflow.Params(a=entry["a"], alpha=entry["alpha"], Fd=entry["Fd"], x0=entry["x0"])


def test_the_campaign_reads_back_with_the_expected_runs(demo):
    directory, manifest, truth, campaign = demo
    assert manifest == directory / "exports" / "manifest.yaml"
    assert campaign.problems == ()
    assert len(campaign) == len(truth["runs"]) == 52
    assert Counter(run.meta["test"] for run in campaign) == {
        "startup": 48,
        "ramp": 1,
        "creep": 2,
        "switch": 1,
    }
    startups = campaign.select(test="startup")
    loads = Counter(round(run.normal_load * 1e3, 6) for run in startups)
    assert loads == {20.0: 8, 45.0: 8, 55.0: 8, 70.0: 8, 95.0: 8, 120.0: 8}
    for load in (20.0, 45.0, 70.0, 95.0, 120.0):  # the Amontons series: 8 repeats at 0.86 um/s
        series = startups.select(normal_load=load * 1e-3)
        assert [run.nominal_velocity for run in series] == pytest.approx([VELOCITY] * 8)
        assert len({run.meta["preparation"] for run in series}) == 8
    series = startups.select(preparation="fig2b")  # one preparation, five velocities
    velocities = sorted(run.nominal_velocity for run in series)
    assert len(velocities) == 5 and velocities[-1] / velocities[0] >= 10
    assert all(run.meta["rest_time"] == 60.0 for run in series)
    assert len(startups.select(preparation=lambda p: p.startswith("fig2a"))) == 3
    for run in campaign:
        assert run.control == ("rate" if run.meta["test"] == "startup" else "stress")
        assert run.meta["notes"].startswith("synthetic")
        assert "synthetic" in run.meta["sample"]
    # the files mix formats, languages, encodings and decimal marks
    formats = {granflow.read(directory / "exports" / f["file"]).format for f in truth["files"]}
    assert formats == {"rheocompass", "trios"}
    assert {f["language"] for f in truth["files"]} == {"en", "fr", "de"}
    assert {f["decimal"] for f in truth["files"]} == {".", ","}
    assert len({f["encoding"] for f in truth["files"]}) >= 4


def test_the_truth_file_describes_every_run(demo):
    _, manifest, truth, campaign = demo
    assert truth["synthetic"] is True and truth["seed"] == 0
    assert (truth["mu_a"], truth["mu_d"]) == (0.06, 0.2)
    assert 4.19e4 <= truth["alpha"] <= 6.74e4  # between the paper's values (SPEC §4)
    assert 0.02e-3 <= truth["noise"] <= 0.05e-3
    entries = yaml.safe_load(manifest.read_text(encoding="utf-8"))["runs"]
    for run, entry, listed in zip(campaign, truth["runs"], entries, strict=True):
        assert (entry["file"], entry["interval"]) == (listed["file"], listed["interval"])
        assert run.meta["interval"] == entry["interval"] and run.meta["test"] == entry["test"]
        assert run.normal_load == pytest.approx(entry["normal_load"], rel=1e-12)
        assert entry["a"] == pytest.approx(truth["mu_a"] * entry["normal_load"], rel=1e-12)
        assert entry["Fd"] == pytest.approx(truth["mu_d"] * entry["normal_load"], rel=1e-12)
        assert entry["alpha"] == truth["alpha"]
        if entry["velocity"] is not None:
            assert run.nominal_velocity == pytest.approx(entry["velocity"], rel=1e-12)
    x0 = [entry["x0"] for entry in truth["runs"]]
    assert min(x0) >= 0.19e-6 and max(x0) <= 0.5e-6 and len(set(x0)) >= 40  # varies per repeat
    fig2a = [entry["t0"] for entry in truth["runs"] if entry["preparation"].startswith("fig2a")]
    assert fig2a == pytest.approx([0.23, 0.39, 0.55])


def test_start_ups_are_the_model_plus_the_stated_noise(demo):
    _, _, truth, _ = demo
    noise = truth["noise"]
    for run, entry in runs_of(demo, "startup"):
        np.testing.assert_allclose(run.slip, entry["velocity"] * run.t, rtol=1e-8, atol=1e-15)
        started = run.slip >= entry["x0"]
        residual = run.force[started] - granflow.friction_slip(run.slip[started], params_of(entry))
        assert 0.8 * noise < residual.std() < 1.25 * noise
        assert abs(residual.mean()) < 4 * noise / math.sqrt(residual.size)
        assert run.slip[-1] >= 10 * entry["x_peak"]  # the peak and the approach to Fd


def test_fits_of_the_start_ups_cover_the_truth(demo):
    misses = Counter()
    startups = runs_of(demo, "startup")
    for run, entry in startups:
        result = granflow.fit(run)
        assert result.success, (entry["preparation"], result.message)
        for name in ("a", "alpha", "Fd", "x0"):
            low, high = result.ci95[name]
            misses[name] += not low <= entry[name] <= high
    # 95 % intervals: about 2.4 misses in 48 per parameter; 8 or more would be far off
    assert all(misses[name] <= 7 for name in ("a", "alpha", "Fd", "x0")), misses


def test_amontons_and_the_velocity_collapse_recover_the_constants(demo):
    _, _, truth, campaign = demo
    series = campaign.select(test="startup", preparation=lambda p: p.startswith("load"))
    assert len(series) == 40
    result = granflow.fit_amontons(list(series))
    for name in ("mu_a", "mu_d", "alpha"):
        low, high = result.joint.ci95[name]
        assert low <= truth[name] <= high, (name, low, high)
    assert [row["repeats"] for row in result.per_load] == [8] * 5
    collapse = granflow.velocity_collapse(list(campaign.select(preparation="fig2b")))
    entry = next(e for e in truth["runs"] if e["preparation"] == "fig2b")
    for name in ("a", "alpha", "Fd"):
        low, high = collapse.shared.ci95[name]
        assert low <= entry[name] <= high, (name, low, high)


def test_the_stress_ramp_fails_at_the_peak(demo):
    ((run, entry),) = runs_of(demo, "ramp")
    failure = entry["failure"]
    # quasi-statically the layer fails when the force reaches F_peak: t = F_peak / rate
    assert failure["time"] == pytest.approx(entry["F_peak"] / entry["rate"], rel=1e-9)
    assert failure["slip"] == pytest.approx(entry["x_peak"] - entry["x0"], rel=1e-6)
    before = run.t < failure["time"]
    residual = run.force - entry["rate"] * run.t
    assert np.abs(residual).max() < 5 * 3e-5
    assert run.slip[before].max() < failure["slip"]  # sub-threshold creep up the branch
    assert np.all(run.slip[~before] > failure["slip"] + 50e-6)  # then it flows
    assert (~before).sum() >= 5 and before.sum() >= 100


def stuck_slip(params, stress):
    """The slip [m] where the rising branch F(x) reaches ``stress`` (root finding)."""

    def excess(x):
        return granflow.friction_slip(np.array([x]), params)[0] - stress

    return brentq(excess, params.x0 * (1 + 1e-9), granflow.peak(params).slip)


def test_creep_is_logarithmic_and_larger_above_fd(demo):
    creeps = runs_of(demo, "creep")
    assert len(creeps) == 2
    below, above = sorted(creeps, key=lambda pair: pair[1]["stress"])
    assert below[1]["stress"] < below[1]["Fd"] < above[1]["stress"] < above[1]["F_peak"]
    assert above[0].slip[-1] > 1.5 * below[0].slip[-1]  # Fig. 3b: larger creep above Fd
    for run, entry in creeps:
        assert np.abs(run.force - entry["stress"]).max() < 5 * 3e-5
        # creep along the rising branch of slope F': slip ~ (A / F') ln(1 + t / tau_c)
        params = params_of(entry)
        x_stuck = stuck_slip(params, entry["stress"])
        slope = params.a / x_stuck - params.alpha * (entry["stress"] - params.Fd)
        fitted = granflow.fit_creep(run.t, run.slip)
        expected = entry["direct_effect"]["amplitude"] / slope
        assert fitted.params["B"] == pytest.approx(expected, rel=0.25)
        assert run.slip[-1] < 2e-6  # a small fraction of a bead, as in the paper


def test_the_switch_after_the_peak_fails(demo):
    ((run, entry),) = runs_of(demo, "switch")
    assert run.meta["switch_time"] == 80.0
    switch = entry["switch_time"]
    assert switch == 80.0 and entry["x_peak"] / entry["velocity"] < switch
    rate = run.t <= switch
    params = params_of(entry)
    expected = granflow.friction_slip(run.slip[rate][1:], params)
    assert np.abs(run.force[rate][1:] - expected).max() < 5 * 3e-5
    force_at_switch = granflow.friction_slip(np.array([VELOCITY * switch]), params)[0]
    assert entry["switch_force"] == pytest.approx(1.02 * force_at_switch, rel=1e-9)
    assert np.abs(run.force[~rate] - entry["switch_force"]).max() < 5 * 3e-5
    assert entry["failure"]["time"] == pytest.approx(switch, rel=1e-9)
    assert entry["failure"]["slip"] == pytest.approx(VELOCITY * switch, rel=1e-9)
    assert np.all(np.diff(run.slip[~rate]) > 50e-6)  # flows after the switch


def test_same_seed_same_bytes_other_seed_other_data(tmp_path):
    first, again, other = tmp_path / "first", tmp_path / "again", tmp_path / "other"
    make_demo_campaign(first, seed=7)
    make_demo_campaign(again, seed=7)
    make_demo_campaign(other, seed=8)
    written = files_of(first)
    assert len(written) == 13  # ten exports, the manifest, the truth and the record to watch
    assert written == files_of(again)
    different = files_of(other)
    assert set(different) == set(written)
    assert all(different[name] != written[name] for name in written)
    # a second demo into the same folder replaces the first one's files
    make_demo_campaign(first, seed=8)
    assert files_of(first) == different


def test_refuses_to_write_over_a_users_folder(tmp_path):
    exports = tmp_path / "exports"
    exports.mkdir()
    mine = exports / "my_measurement.csv"
    mine.write_bytes(b"precious data")
    with pytest.raises(granflow.InvalidParameterError, match="refusing to overwrite"):
        make_demo_campaign(tmp_path)
    assert files_of(tmp_path) == {"exports/my_measurement.csv": b"precious data"}

    # a truth file that is not a demo's does not count as one
    (tmp_path / TRUTH_FILE).write_text('{"synthetic": false}', encoding="utf-8")
    with pytest.raises(granflow.InvalidParameterError, match="not empty"):
        make_demo_campaign(tmp_path)
    mine.unlink()
    with pytest.raises(granflow.InvalidParameterError, match=r"synthetic_truth\.json exists"):
        make_demo_campaign(tmp_path)
    assert (tmp_path / TRUTH_FILE).read_text(encoding="utf-8") == '{"synthetic": false}'


def test_a_previous_demo_is_replaced_and_other_files_are_kept(tmp_path):
    make_demo_campaign(tmp_path, seed=1)
    notes = tmp_path / "exports" / "notes.txt"
    notes.write_text("mine", encoding="utf-8")
    manifest = make_demo_campaign(tmp_path, seed=2)
    assert json.loads((tmp_path / TRUTH_FILE).read_text(encoding="utf-8"))["seed"] == 2
    assert notes.read_text(encoding="utf-8") == "mine"
    assert "(seed 2)" in manifest.read_text(encoding="utf-8")


@pytest.mark.parametrize("seed", [-1, 1.5, True, "0"])
def test_bad_seed(tmp_path, seed):
    with pytest.raises(granflow.InvalidParameterError, match="seed"):
        make_demo_campaign(tmp_path, seed=seed)
    assert not any(tmp_path.iterdir())


def test_the_manifest_names_the_preparation_states(demo):
    """Fig. 2a's three preparations are repeats of one state, and so are each load's eight;
    the spread over them is what the analysis reports (granflow.analysis.joint)."""
    _, manifest, _, _ = demo
    manifest = yaml.safe_load(manifest.read_text(encoding="utf-8"))
    entries = manifest["runs"] if isinstance(manifest, dict) else manifest
    states = Counter(
        (entry.get("normal_load"), entry.get("preparation_state"))
        for entry in entries
        if entry.get("test") == "startup" and entry.get("preparation_state")
    )
    fig2a = [entry for entry in entries if str(entry.get("preparation", "")).startswith("fig2a")]
    assert len({entry["preparation_state"] for entry in fig2a}) == 1 and len(fig2a) == 3
    assert sorted(states.values()) == [3, 8, 8, 8, 8, 8]
    fig2b = [entry for entry in entries if entry.get("preparation") == "fig2b"]
    assert fig2b and not any("preparation_state" in entry for entry in fig2b)
