"""granflow.rsf.fit: the contract, recovery of known parameters, coverage over seeds, results.

Synthetic records come from :func:`granflow.rsf.simulate` (the simulator, landing its steps on
every output time at rtol 1e-10), not from the fit's own forward model; that forward model is
checked against scipy's Radau on the same equations written out by hand.
"""

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import granflow as gf
from granflow import rsf
from granflow.errors import InvalidDataError, InvalidParameterError
from granflow.fitting.rsf_forward import Window

V1, V2 = 1e-6, 10e-6
#: (mu0, a, b, Dc [m], k [1/m], pre [s], post [s], noise): the sets of the benchmark
SETS = {
    "weakening": (0.6, 0.008, 0.012, 20e-6, 2000.0, 40.0, 40.0, 3e-4),
    "strengthening": (0.6, 0.012, 0.007, 50e-6, 1000.0, 40.0, 60.0, 3e-4),
}


def synthetic(name, seed, law="aging", noise=None):
    mu0, a, b, Dc, k, pre, post, sigma = SETS[name]
    model = rsf.RateState(mu0, a, V1, k, [rsf.State(b, Dc, law)])
    protocol = gf.Protocol([gf.Velocity(V1, pre), gf.Velocity(V2, post)])
    t = np.arange(0.0, pre + post + 1e-9, 0.1)
    mu = rsf.simulate(model, protocol, t_eval=t).friction
    sigma = sigma if noise is None else noise
    if sigma:
        mu = mu + np.random.default_rng(seed).normal(0.0, sigma, t.size)
    return t, mu, protocol


def test_the_contract_of_the_issue():
    t, mu, protocol = synthetic("weakening", 0)
    fit = rsf.fit(t, mu, protocol, law="aging")
    assert fit.success
    for name in ("a", "b", "Dc"):
        low, high = fit.ci95[name]
        assert low < fit.params[name] < high
    assert fit.best_fit.shape == mu.shape
    assert fit.params["a"] == pytest.approx(0.008, rel=0.05)
    assert fit.params["b"] == pytest.approx(0.012, rel=0.05)
    assert fit.params["Dc"] == pytest.approx(20e-6, rel=0.05)
    # a Run in place of the arrays (friction = force / normal load), parameters fixed by name
    run = gf.Run(t, np.zeros_like(t), np.zeros_like(t), 5.0 * mu, meta={"normal_load": 5.0})
    held = rsf.fit(run, protocol, law="aging", fixed={"stiffness": 2000.0, "mu0": 0.6})
    assert held.params["stiffness"] == 2000.0 and held.params["mu0"] == 0.6
    assert held.ci_method["stiffness"] == "fixed"
    assert held.params["b"] == pytest.approx(0.012, rel=0.05)


@pytest.mark.parametrize("law", ["aging", "slip", "prz"])
def test_noise_free_data_give_the_truth(law):
    t, mu, protocol = synthetic("strengthening", 0, law=law, noise=0.0)
    fit = rsf.fit(t, mu, protocol, law=law, profile=False)
    assert fit.success
    assert fit.params["a"] == pytest.approx(0.012, rel=1e-4)
    assert fit.params["b"] == pytest.approx(0.007, rel=1e-4)
    assert fit.params["Dc"] == pytest.approx(50e-6, rel=1e-4)
    assert fit.params["stiffness"] == pytest.approx(1000.0, rel=1e-4)
    assert fit.residual_rms < 1e-7


def test_the_forward_model_against_scipy():
    """The fit's compiled model (dense output, rtol 1e-8) against Radau at rtol 1e-11."""
    mu0, a, b, Dc, k = 0.6, 0.008, 0.012, 20e-6, 2000.0
    t = np.arange(0.0, 80.0, 0.1)
    pieces = np.array([[0.0, 40.0, V1, 0.0], [40.0, 80.0, V2, 0.0]])
    ours = Window(t, pieces, ["aging"]).friction(mu0, a, k, [(b, Dc)])

    def rhs(time, y):
        mu, theta = y
        v = V1 * math.exp((mu - b * math.log(V1 * theta / Dc)) / a)
        load_point = V1 if time < 40.0 else V2
        return [k * (load_point - v), 1.0 - v * theta / Dc]

    reference = np.empty_like(t)
    y = [0.0, Dc / V1]
    for lo, hi in ((0.0, 40.0), (40.0, 80.0)):
        inside = (t >= lo) & (t < hi)
        times = np.append(t[inside], hi)
        solution = solve_ivp(rhs, (lo, hi), y, method="Radau", t_eval=times, rtol=1e-11, atol=1e-14)
        reference[inside] = solution.y[0, :-1] + mu0
        y = solution.y[:, -1]
    np.testing.assert_allclose(ours, reference, atol=1e-8)


@pytest.mark.parametrize("name", list(SETS))
def test_coverage_over_seeds(name):
    """40 seeds per set (the benchmark runs 100): every fit converges with no guess, and the
    95 % intervals of a, b and Dc hold the truth in 34 to 40 of them (a binomial(40, 0.95)
    falls below 34 with probability 0.7 %)."""
    truth = dict(zip(("a", "b", "Dc"), SETS[name][1:4], strict=True))
    covered = dict.fromkeys(truth, 0)
    for seed in range(40):
        fit = rsf.fit(*synthetic(name, 1000 + seed), law="aging")
        assert fit.success, (seed, fit.message)
        for key, value in truth.items():
            low, high = fit.ci95[key]
            covered[key] += bool(low <= value <= high)
    assert all(34 <= count <= 40 for count in covered.values()), covered


def test_joint_fit_of_two_steps_shares_a_b_dc():
    model = rsf.RateState(0.6, 0.01, V1, 3000.0, [rsf.State(0.013, 15e-6, "slip")])
    protocol = gf.Protocol(
        [gf.Velocity(V1, 30.0), gf.Velocity(10 * V1, 20.0), gf.Velocity(3 * V1, 40.0)]
    )
    t = np.arange(0.0, 90.0, 0.05)
    mu = rsf.simulate(model, protocol, t_eval=t).friction
    mu = mu + np.random.default_rng(3).normal(0, 2e-4, t.size)
    fit = rsf.fit(t, mu, protocol, law="slip")
    assert len(fit.windows) == 2
    assert {"mu0_1", "mu0_2"} <= set(fit.params)
    for name, value in (("a", 0.01), ("b", 0.013), ("Dc", 15e-6)):
        low, high = fit.ci95[name]
        assert low < value < high, (name, fit.ci95[name])
    # every window's simulation starts at the record's start (steady sliding at 1 µm/s, the
    # second window's start at 35 s is not): each mu0 is the steady friction there
    assert fit.v_ref == (V1, V1)
    assert fit.params["mu0_1"] == pytest.approx(0.6, abs=1e-3)
    assert fit.params["mu0_2"] == pytest.approx(0.6, abs=1e-3)


def test_a_linear_trend_is_fitted():
    t, mu, protocol = synthetic("weakening", 5)
    displacement = np.where(t < 40.0, V1 * t, V1 * 40.0 + V2 * (t - 40.0))
    trend = 30.0 * displacement  # friction rises by 0.013 over the record
    fit = rsf.fit(t, mu + trend, protocol, detrend=True)
    low, high = fit.ci95["slope"]
    assert low < 30.0 < high
    assert fit.params["b"] == pytest.approx(0.012, rel=0.05)


def test_result_round_trip_report_and_plot(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    fit = rsf.fit(*synthetic("weakening", 2))
    again = rsf.RateStateFitResult.from_dict(json.loads(json.dumps(fit.to_dict())))
    assert again == fit
    compact = fit.to_dict(include_arrays=False)
    assert "best_fit" not in compact
    text = fit.report()
    assert "(profile)" in text and "Dc" in text and "a - b" in text
    top, bottom = fit.plot()
    assert len(top.lines) == 2 and len(bottom.lines) >= 1
    # the title gives each value with its error, the symbols in mathtext; axes carry units
    title = top.get_title()
    assert title.startswith("$a$ = ") and r"$D_\mathrm{c}$ = " in title
    assert title.count("±") == 3 and title.endswith(" µm")
    assert top.get_ylabel().endswith("[-]") and bottom.get_ylabel() == "residual [-]"
    top.figure.savefig(tmp_path / "fit.png")
    assert repr(fit).startswith("RateStateFitResult(aging")


def test_bad_input_is_named():
    t, mu, protocol = synthetic("weakening", 0)
    with pytest.raises(InvalidParameterError, match="protocol is missing"):
        rsf.fit(t, mu)
    with pytest.raises(InvalidParameterError, match="unknown parameters"):
        rsf.fit(t, mu, protocol, fixed={"alpha": 1.0})
    with pytest.raises(InvalidParameterError, match="law must be"):
        rsf.fit(t, mu, protocol, law="nagata")
    with pytest.raises(InvalidDataError, match="differ in length"):
        rsf.fit(t, mu[:-1], protocol)
    flat = gf.Protocol([gf.Velocity(V1, 80.0)])
    with pytest.raises(InvalidDataError, match="no velocity step"):
        rsf.fit(t[t <= 80.0], mu[t <= 80.0], flat)


def test_the_fit_command(tmp_path, capsys):
    from granflow.cli import main

    t, mu, _ = synthetic("weakening", 4)
    displacement = np.where(t < 40.0, V1 * t, V1 * 40.0 + V2 * (t - 40.0))
    rows = ["Time(s)\tDispl(microns)\tFriction"]
    rows += [
        f"{1000 + a:.4f}\t{d * 1e6:.5f}\t{m:.6f}"
        for a, d, m in zip(t, displacement, mu, strict=True)
    ]
    path = tmp_path / "step.txt"
    path.write_text("\n".join(rows) + "\n")
    assert main(["fit", str(path), "--model", "rsf", "--law", "aging", "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["record"]["step_times"] == pytest.approx([40.0], abs=0.1)
    assert payload["params"]["b"] == pytest.approx(0.012, rel=0.05)
    assert main(["fit", str(path), "--model", "rsf", "--fix", "k=5"]) == 2
    assert "unknown parameters ['k']" in capsys.readouterr().err


def test_two_state_variables():
    model = rsf.RateState(0.6, 0.01, V1, 3000.0, [rsf.State(0.008, 5e-6), rsf.State(0.006, 80e-6)])
    protocol = gf.Protocol([gf.Velocity(V1, 40.0), gf.Velocity(10 * V1, 60.0)])
    t = np.arange(0.0, 100.0001, 0.1)
    mu = rsf.simulate(model, protocol, t_eval=t).friction
    fit = rsf.fit(t, mu + np.random.default_rng(0).normal(0, 1e-4, t.size), protocol, states=2)
    assert fit.success and "b" not in fit.params
    for name, value in (("b1", 0.008), ("Dc1", 5e-6), ("b2", 0.006), ("Dc2", 80e-6)):
        low, high = fit.ci95[name]
        assert low < value < high, (name, fit.ci95[name])
    assert fit.a_minus_b == pytest.approx(0.01 - 0.014, abs=2e-4)


def test_an_unresolved_stiffness_is_said_and_can_be_fixed():
    """A machine so stiff that the elastic rise after the step (0.2 µm, 0.02 s) falls between
    two samples: a, b and Dc are still found, the stiffness is not, and the fit says so."""
    model = rsf.RateState(0.6, 0.008, V1, 1e5, [rsf.State(0.012, 20e-6)])
    protocol = gf.Protocol([gf.Velocity(V1, 40.0), gf.Velocity(V2, 40.0)])
    t = np.arange(0.0, 80.0001, 0.1)
    mu = rsf.simulate(model, protocol, t_eval=t).friction
    mu = mu + np.random.default_rng(0).normal(0, 3e-4, t.size)
    fit = rsf.fit(t, mu, protocol)
    assert fit.success and "stiffness is poorly determined" in fit.message
    assert fit.ci_method["a"] == "wald"
    held = rsf.fit(t, mu, protocol, fixed={"stiffness": 1e5})
    for name, value in (("a", 0.008), ("b", 0.012), ("Dc", 20e-6)):
        low, high = held.ci95[name]
        assert low < value < high and held.ci_method[name] == "profile"
