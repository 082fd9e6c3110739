"""Slide-hold-slide: the reader, the healing rate, the paper's prediction, the fits over holds.

The records come from an independent solver (scipy Radau, :mod:`shs_radau` beside this file);
the references are computed here from those arrays (numpy, scipy.stats), never by granflow.
"""

import itertools
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import shared_data
from scipy import stats
from scipy.integrate import solve_ivp

from granflow import rsf
from granflow.errors import FileFormatError, InvalidParameterError

sys.path.insert(0, str(Path(__file__).parent))
import shs_radau


def _record(law="aging", noise=0.0, seed=0):
    t, x, mu, starts = shs_radau.record(law)
    if noise:
        mu = mu + np.random.default_rng(seed).normal(0.0, noise, mu.size)
    return rsf.parse_slide_hold_slide(shs_radau.table(t, x, mu), "shs.txt"), starts


def test_the_reader_finds_the_holds_in_the_load_point_displacement():
    record, starts = _record()
    assert np.allclose(record.hold_starts, starts, atol=1e-6)
    assert np.allclose(record.hold_times, shs_radau.HOLDS, atol=1e-6)
    assert np.allclose(record.velocities, shs_radau.TRUTH["v0"], rtol=1e-6)
    kinds = [segment.type_name for segment in record.protocol]
    assert kinds == ["velocity", "hold"] * len(shs_radau.HOLDS) + ["velocity"]
    assert record.protocol.duration == pytest.approx(record.t[-1])
    # one window per hold: from steady sliding before it, disjoint, to the record's end
    windows = record.windows
    assert len(windows) == len(shs_radau.HOLDS)
    for (lo, hi), start, end in zip(windows, record.hold_starts, record.hold_ends, strict=True):
        assert lo < start < end < hi
    assert all(a[1] == b[0] for a, b in itertools.pairwise(windows))
    assert windows[-1][1] == pytest.approx(record.t[-1])


def test_the_readers_protocol_runs_the_independent_record_again():
    # granflow's own solver on the protocol the reader found gives the Radau friction back
    record, _ = _record("aging")
    p = shs_radau.TRUTH
    model = rsf.RateState(p["mu0"], p["a"], p["v0"], p["k"], [rsf.State(p["b"], p["Dc"], "aging")])
    run = rsf.simulate(model, record.protocol, t_eval=record.t, initial_velocity=p["v0"])
    assert np.max(np.abs(run.friction - record.friction)) < 2e-6


def test_a_written_file_reads_back_and_step_times_override(tmp_path):
    t, x, mu, starts = shs_radau.record("aging")
    path = tmp_path / "shs.txt"
    path.write_text(shs_radau.table(t, x, mu), encoding="utf-8")
    record = rsf.read_slide_hold_slide(path)
    assert record.time_offset == 500.0
    assert record.meta["source"] == str(path)
    given = [v for s, h in zip(starts, shs_radau.HOLDS, strict=True) for v in (s, s + h)]
    same = rsf.read_slide_hold_slide(path, step_times=given)
    assert same.hold_starts == tuple(given[::2])
    assert np.allclose(same.hold_times, record.hold_times, atol=1e-6)


def test_bad_records_are_refused_naming_the_file_and_the_reason(tmp_path):
    rows = "".join(f"{t}\t{t}\t0.6\n" for t in range(30))
    with pytest.raises(FileFormatError, match=r"flat\.txt.*no hold found"):
        rsf.parse_slide_hold_slide("Time(s)\tDispl(microns)\tFriction\n" + rows, "flat.txt")
    held = "".join(f"{t}\t{max(t - 10, 0)}\t0.6\n" for t in range(30))
    with pytest.raises(FileFormatError, match="starts in a hold"):
        rsf.parse_slide_hold_slide("Time(s)\tDispl(microns)\tFriction\n" + held, "held.txt")
    with pytest.raises(FileFormatError, match=r"bad\.txt: line 3"):
        rsf.parse_slide_hold_slide(
            "Time(s)\tDispl(microns)\tFriction\n0\t0\t0.6\n1\tabc\t0.6\n" + rows, "bad.txt"
        )
    with pytest.raises(InvalidParameterError, match="step_times"):
        rsf.parse_slide_hold_slide("Time(s)\tDispl(microns)\tFriction\n" + rows, step_times=[5])
    with pytest.raises(InvalidParameterError, match="strictly increasing"):
        rsf.parse_slide_hold_slide(
            "Time(s)\tDispl(microns)\tFriction\n" + rows, step_times=[5, 5, 8, 9]
        )


def _peaks_by_hand(t, mu, starts, holds):
    """Δμ_peak straight from the arrays: the highest friction of each re-slide minus the
    friction at the hold's start (steady sliding)."""
    out = []
    for index, (start, hold) in enumerate(zip(starts, holds, strict=True)):
        stop = starts[index + 1] if index + 1 < len(starts) else t[-1]
        after = (t > start + hold) & (t <= stop)
        out.append(mu[after].max() - np.interp(start, t, mu))
    return np.array(out)


def test_healing_measures_each_peak_and_fits_beta_by_least_squares():
    record, starts = _record()
    t, _, mu, _ = shs_radau.record("aging")
    h = rsf.healing(record)
    expected = _peaks_by_hand(t, mu, starts, shs_radau.HOLDS)
    assert np.allclose(h.delta_mu_peak, expected, rtol=1e-2, atol=2e-5)
    assert np.allclose(h.hold_times, shs_radau.HOLDS, atol=1e-6)
    # the regression, done independently
    line = stats.linregress(np.log10(h.hold_times), h.delta_mu_peak)
    half = stats.t.ppf(0.975, len(h.hold_times) - 2) * line.stderr
    assert h.beta == pytest.approx(line.slope, rel=1e-10)
    assert h.beta_ci95 == pytest.approx((line.slope - half, line.slope + half), rel=1e-8)
    # aging-law healing: a rate of order b ln 10 per decade, well above zero
    assert (
        0.3 * shs_radau.TRUTH["b"] * math.log(10)
        < h.beta
        < 1.2 * shs_radau.TRUTH["b"] * math.log(10)
    )


def test_the_aging_law_heals_more_than_the_slip_law():
    aging = rsf.healing(_record("aging")[0])
    t, x, mu, _ = shs_radau.record("slip", holds=(1.0, 100.0))  # two holds: half the cost
    slip = rsf.healing(rsf.parse_slide_hold_slide(shs_radau.table(t, x, mu)))
    assert slip.hold_times == pytest.approx((1.0, 100.0), abs=1e-6)
    assert aging.delta_mu_peak[-1] > 1.3 * slip.delta_mu_peak[-1] > 0
    assert aging.beta > slip.beta > 0
    assert all(math.isnan(v) for v in slip.beta_ci95)  # no interval from two holds


def test_betas_interval_on_a_noisy_record_covers_the_noise_free_beta():
    truth = rsf.healing(_record()[0]).beta
    h = rsf.healing(_record(noise=3e-4, seed=11)[0])
    low, high = h.beta_ci95
    assert low < truth < high
    assert high - low < truth


def test_a_healing_result_reads_back_from_json_equal():
    h = rsf.healing(_record()[0])
    back = rsf.HealingResult.from_dict(json.loads(json.dumps(h.to_dict())))
    assert back == h
    assert "beta" in h.summary() and "5 holds" in h.summary()


def test_the_papers_time_clock_prediction_against_its_own_equation():
    # the paper's Eq. 2, integrated here through slide, hold, slide under the time clock:
    # dF/dt = a/t - alpha v (F - F_d), v = 0 during the hold; F_d = 10 mN, a = 3 mN
    a, alpha, fd, v, t0 = 3e-3, 4e4, 10e-3, 0.86e-6, 0.3
    slide, hold = 300.0, 500.0

    def rhs(t, f, velocity):
        return [a / t - alpha * velocity * (f[0] - fd)]

    first = solve_ivp(rhs, (t0, slide), [0.0], args=(v,), method="DOP853", rtol=1e-12, atol=1e-16)
    rest = solve_ivp(
        rhs,
        (slide, slide + hold),
        first.y[:, -1],
        args=(0.0,),
        method="DOP853",
        rtol=1e-12,
        atol=1e-16,
    )
    again = solve_ivp(
        rhs,
        (slide + hold, slide + hold + 200),
        rest.y[:, -1],
        args=(v,),
        method="DOP853",
        rtol=1e-12,
        atol=1e-16,
        dense_output=True,
    )
    peak = again.sol(np.linspace(slide + hold, slide + hold + 200, 2001))[0].max()
    normal_load = 50e-3
    predicted = rsf.paper_healing(hold, a / normal_load, slide)
    assert predicted == pytest.approx((peak - first.y[0, -1]) / normal_load, rel=1e-7)


@pytest.mark.parametrize("law", ["aging", "slip"])
def test_contract_fit_over_holds_covers_the_truth(law):
    record, _ = _record(law, noise=3e-4, seed=5)
    f = rsf.fit(record, law=law)  # the record's own windows, one per hold
    assert f.success, f.message  # the convergence checks passed, not only the optimiser
    truth = shs_radau.TRUTH
    for name, value in (("a", truth["a"]), ("b", truth["b"]), ("Dc", truth["Dc"])):
        low, high = f.ci95[name]
        assert low < value < high, name
    # read back from JSON, the fit's likelihood is rebuilt over its holds (what
    # gf.sample_posterior samples): the fit's own chi-square at its optimum
    back = type(f).from_dict(json.loads(json.dumps(f.to_dict())))
    likelihood = back.log_likelihood()
    at_optimum = [likelihood.values[n] for n in likelihood.names]
    assert -2 * likelihood.function(np.array(at_optimum)) * f.redchi == pytest.approx(
        f.chisqr, rel=1e-9
    )


def test_model_healing_of_the_true_slider_matches_the_independent_record():
    # granflow's curve of a (here: the true) slider against the Radau record's own peaks
    from types import SimpleNamespace

    from granflow.fitting.healing import model_healing

    p = shs_radau.TRUTH
    fit = SimpleNamespace(
        params={"a": p["a"], "b": p["b"], "Dc": p["Dc"], "stiffness": p["k"]}, laws=("aging",)
    )
    curve = model_healing(fit, shs_radau.HOLDS, velocity=p["v0"], slide=30 * p["Dc"])
    t, _, mu, starts = shs_radau.record("aging")
    expected = _peaks_by_hand(t, mu, starts, shs_radau.HOLDS)
    assert np.allclose(curve, expected, rtol=1e-2)


@pytest.mark.parametrize(
    "name", ["velstep3_TR2_exp013_sepiolite.txt", "velstep4_BRAVA_expb819_basalt.txt"]
)
def test_real_velocity_step_records_hold_no_hold_and_say_so(name):
    # laboratory records no one here wrote: noisy load points that never stop
    path = shared_data("rate-state-velocity-steps", name)
    with pytest.raises(FileFormatError, match=rf"{name}: line \d+: no hold found"):
        rsf.read_slide_hold_slide(path)


def test_model_healing_refuses_a_fit_it_cannot_simulate():
    from types import SimpleNamespace

    from granflow.fitting.healing import model_healing

    two_states = SimpleNamespace(params={"a": 0.01, "b1": 0.01}, laws=("aging", "aging"))
    with pytest.raises(InvalidParameterError, match="one-state"):
        model_healing(two_states, [1.0], velocity=1e-6)
