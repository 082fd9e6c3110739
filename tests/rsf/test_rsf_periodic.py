"""An apparatus ripple periodic in load-point displacement: its term in rsf.fit, and the check.

Synthetic records come from :func:`granflow.rsf.simulate` plus a ripple written out here
(cosines of the load-point displacement computed by hand from the protocol), plus seeded noise;
the periodogram is checked against a plain least-squares fit of the same harmonics.
"""

import json
import math

import numpy as np
import pytest

import granflow as gf
from granflow import rsf
from granflow.errors import InvalidParameterError
from granflow.fitting.rsf_periodic import (
    displacement_periodogram,
    periodic_terms,
    periodicity_check,
)

V1, V2 = 1e-6, 10e-6
TRUTH = {"a": 0.008, "b": 0.012, "Dc": 20e-6}
WAVELENGTH = 30e-6  # m
RIPPLE = {"cos1": 4e-4, "sin1": -3e-4, "cos2": 1.5e-4, "sin2": 0.0}
NOISE = 2e-4


def _displacement(t):
    return np.where(t < 60.0, V1 * t, V1 * 60.0 + V2 * (t - 60.0))


def _record(seed, ripple=True):
    model = rsf.RateState(0.6, TRUTH["a"], V1, 2000.0, [rsf.State(TRUTH["b"], TRUTH["Dc"])])
    protocol = gf.Protocol([gf.Velocity(V1, 60.0), gf.Velocity(V2, 40.0)])
    t = np.arange(0.0, 100.0 + 1e-9, 0.05)
    mu = rsf.simulate(model, protocol, t_eval=t).friction
    if ripple:
        phase = 2.0 * math.pi * _displacement(t) / WAVELENGTH
        mu = mu + sum(
            RIPPLE[f"{kind}{h}"] * f(h * phase)
            for h in (1, 2)
            for kind, f in (("cos", np.cos), ("sin", np.sin))
        )
    return t, mu + np.random.default_rng(seed).normal(0.0, NOISE, t.size), protocol


def test_the_periodogram_is_a_least_squares_fit_of_the_harmonics():
    rng = np.random.default_rng(0)
    x = np.sort(rng.uniform(0.0, 1e-3, 2000))
    y = 3e-4 * np.cos(2 * np.pi * x / 9e-5 + 0.3) + rng.normal(0.0, 1e-4, x.size)
    trial = np.array([5e-5, 9e-5, 1.3e-4])
    _, fraction = displacement_periodogram(x, y, 2, wavelengths=trial)
    centred = y - y.mean()
    for wavelength, found in zip(trial, fraction, strict=True):
        design = np.column_stack(
            [np.ones_like(x)]
            + [f(2 * np.pi * h * x / wavelength) for h in (1, 2) for f in (np.cos, np.sin)]
        )
        coefficients, *_ = np.linalg.lstsq(design, centred, rcond=None)
        left = centred - design @ coefficients
        assert found == pytest.approx(1.0 - (left @ left) / (centred @ centred), rel=1e-9)


def test_the_term_and_its_wavelength_derivative():
    x = np.linspace(0.0, 2e-4, 50)
    amplitudes = [4e-4, -3e-4, 1.5e-4, 2e-5]
    term, jacobian = periodic_terms(x, 3e-5, amplitudes, with_jacobian=True)
    h = 1e-12
    numeric = periodic_terms(x, 3e-5 + h, amplitudes) - periodic_terms(x, 3e-5 - h, amplitudes)
    np.testing.assert_allclose(jacobian[:, 0], numeric / (2 * h), rtol=1e-5, atol=1e-3)
    np.testing.assert_allclose(term, jacobian[:, 1:] @ amplitudes)


def test_a_known_ripple_is_recovered_and_the_intervals_still_cover():
    """20 seeds: every fit converges with no guess and leaves the noise; the 95 % intervals
    of a, b, Dc, the wavelength and the amplitudes hold the truth in 15 to 20 of them (a
    binomial(20, 0.95) falls below 15 with probability 0.03 %)."""
    truth = {**TRUTH, "wavelength": WAVELENGTH, **RIPPLE}
    covered = dict.fromkeys(truth, 0)
    for seed in range(20):
        fit = rsf.fit(*_record(100 + seed), law="aging", periodic=True)
        assert fit.success, (seed, fit.message)
        assert fit.harmonics == 2 and fit.units["wavelength"] == "m"
        assert fit.stderr["wavelength"] < 0.01 * WAVELENGTH
        # what is left is the noise: no ripple in the residuals, their RMS the noise's
        assert not fit.periodicity["significant"], (seed, dict(fit.periodicity))
        assert fit.residual_rms == pytest.approx(NOISE, rel=0.05)
        for key, value in truth.items():
            low, high = fit.ci95[key]
            covered[key] += bool(low <= value <= high)
    assert all(15 <= count <= 20 for count in covered.values()), covered


def test_without_the_term_the_check_finds_the_ripple():
    t, mu, protocol = _record(7)
    fit = rsf.fit(t, mu, protocol, law="aging")
    check = fit.periodicity
    assert check["significant"] and check["false_alarm"] < 1e-6
    assert check["wavelength"] == pytest.approx(WAVELENGTH, rel=0.01)
    assert "consider periodic=True" in fit.report()
    # with no ripple in the data the check stays quiet
    t, mu, protocol = _record(7, ripple=False)
    assert not rsf.fit(t, mu, protocol, law="aging").periodicity["significant"]


def test_a_given_or_held_wavelength():
    t, mu, protocol = _record(3)
    started = rsf.fit(t, mu, protocol, periodic=31e-6, harmonics=1)
    assert started.params["wavelength"] == pytest.approx(WAVELENGTH, rel=0.01)
    assert set(started.ripple_amplitudes()) == {"1"} and "cos2" not in started.params
    held = rsf.fit(t, mu, protocol, periodic=True, fixed={"wavelength": WAVELENGTH})
    assert held.params["wavelength"] == WAVELENGTH and held.ci_method["wavelength"] == "fixed"
    assert held.params["cos1"] == pytest.approx(RIPPLE["cos1"], abs=5e-5)


def test_the_result_shows_the_ripple(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    t, mu, protocol = _record(5)
    fit = rsf.fit(t, mu, protocol, periodic=True)
    again = rsf.RateStateFitResult.from_dict(json.loads(json.dumps(fit.to_dict())))
    assert again == fit and again.harmonics == 2
    np.testing.assert_allclose(again.ripple, fit.ripple)
    text = fit.report()
    assert "ripple" in text and "wavelength" in text
    top, _ = fit.plot()
    # data, fit, the fit without the ripple
    np.testing.assert_allclose(top.lines[2].get_ydata(), fit.best_fit - fit.ripple)
    top.figure.savefig(tmp_path / "ripple.png")


def test_bad_settings_are_named():
    t, mu, protocol = _record(0)
    with pytest.raises(InvalidParameterError, match="periodic must be positive"):
        rsf.fit(t, mu, protocol, periodic=-1e-6)
    with pytest.raises(InvalidParameterError, match="harmonics must be a positive integer"):
        rsf.fit(t, mu, protocol, periodic=True, harmonics=0)
    with pytest.raises(InvalidParameterError, match="unknown parameters"):
        rsf.fit(t, mu, protocol, fixed={"wavelength": 3e-5})
    for outside in (2.0, 1e-10):  # outside the wavelength's search range, named at once
        with pytest.raises(InvalidParameterError, match="periodic must be a wavelength from"):
            rsf.fit(t, mu, protocol, periodic=outside)
        with pytest.raises(InvalidParameterError, match="fixed wavelength must lie from"):
            rsf.fit(t, mu, protocol, periodic=True, fixed={"wavelength": outside})


def test_numpy_booleans_are_booleans():
    t, mu, protocol = _record(2)
    fit = rsf.fit(t, mu, protocol, periodic=np.True_)  # not a wavelength of 1 m
    assert fit.harmonics == 2
    assert fit.params["wavelength"] == pytest.approx(WAVELENGTH, rel=0.01)
    assert rsf.fit(t, mu, protocol, periodic=np.False_).harmonics == 0


def test_the_check_stays_quiet_on_red_noise():
    """A random walk plus white noise (residuals that wander, as a misfit or a drift leaves
    them): its spectrum falls steeply, and at the longest wavelengths a one-sided comparison
    band misses its level. 30 seeds: at most 2 false alarms (at the nominal 1e-3 per record,
    3 or more of 30 has probability 4e-6; before the band had two sides, 8 of these 30
    were flagged)."""
    x = np.linspace(0.0, 1e-3, 4000)
    flagged = []
    for seed in range(30):
        rng = np.random.default_rng(seed)
        y = np.cumsum(rng.normal(0.0, 0.3, x.size)) + rng.normal(0.0, 1.0, x.size)
        if periodicity_check(x, y)["significant"]:
            flagged.append(seed)
    assert len(flagged) <= 2, flagged


def test_the_check_of_a_short_record_is_empty():
    x = np.linspace(0.0, 1e-5, 30)
    assert periodicity_check(x, np.sin(x * 1e5)) == {}


def _write_record(path, seed=11):
    """The rippled step of :func:`_record` in the real files' format (time and displacement
    offset, displacement in µm)."""
    t, mu, _ = _record(seed)
    rows = ["Time(s)\tDispl(microns)\tFriction"]
    rows += [
        f"{1000.0 + ti:.4f}\t{5000.0 + di * 1e6:.5f}\t{mi:.6f}"
        for ti, di, mi in zip(t, _displacement(t), mu, strict=True)
    ]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")


def test_the_fit_command_takes_periodic(tmp_path, capsys):
    from granflow.cli import main

    path = tmp_path / "rippled.txt"
    _write_record(path)
    # the flag before the file does not take the file for a wavelength
    assert main(["fit", "--periodic", str(path), "--model", "rsf", "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["harmonics"] == 2
    assert payload["params"]["wavelength"] == pytest.approx(WAVELENGTH, rel=0.01)
    command = ["fit", str(path), "--model", "rsf", "--wavelength", "31um", "--harmonics", "1"]
    assert main(command) == 0
    assert "ripple" in capsys.readouterr().out
    assert main(["fit", str(path), "--model", "rsf", "--periodic", "--wavelength", "31"]) == 2
    assert "--wavelength" in capsys.readouterr().err


def test_the_manifest_and_the_report_section_take_periodic(tmp_path):
    from granflow.analysis.velocity_steps import campaign_velocity_steps
    from granflow.io.manifest import BadEntry, read_manifest

    # the same record twice, fitted with the ripple and without: two files (a run named
    # twice in one manifest is refused since issue 31)
    _write_record(tmp_path / "rippled.txt")
    _write_record(tmp_path / "rippled-again.txt")
    manifest = tmp_path / "manifest.yaml"
    manifest.write_text(
        "runs:\n"
        "  - {file: rippled.txt, test: velocity_steps, periodic: true}\n"
        "  - {file: rippled-again.txt, test: velocity_steps}\n"
        "  - {file: b.txt, test: velocity_steps, periodic: 30 um}\n"
        "  - {file: c.txt, test: velocity_steps, periodic: 30}\n"
        "  - {file: d.txt, test: velocity_steps, periodic: none}\n"
        "  - {file: e.txt, test: velocity_steps, periodic: null}\n",
        encoding="utf-8",
    )
    entries = read_manifest(manifest, errors="collect")
    assert entries[0]["periodic"] is True and entries[2]["periodic"] == pytest.approx(30e-6)
    assert isinstance(entries[3], BadEntry) and "has no unit" in entries[3].reason
    # none (the documented default) is off, not a wavelength with a bad unit
    assert entries[4]["periodic"] is False and not entries[5].get("periodic")
    entries = entries[:4]
    manifest.write_text(
        "\n".join(manifest.read_text(encoding="utf-8").splitlines()[:5]) + "\n",
        encoding="utf-8",
    )
    section = campaign_velocity_steps(manifest, tmp_path / "out")
    with_ripple, without = section["records"][:2]
    assert with_ripple["fit"]["harmonics"] == 2
    assert "fitted with it" in with_ripple["caption"]
    wavelength = {row["name"]: row for row in with_ripple["fit"]["parameters"]}["wavelength"]
    assert wavelength["value"] == pytest.approx(WAVELENGTH, rel=0.01) and wavelength["unit"] == "m"
    assert without["fit"]["harmonics"] == 0 and "consider periodic: true" in without["caption"]
    # the report's verdict line says which fit carries the ripple
    from granflow.analysis.report_summary import verdicts
    from granflow.analysis.velocity_steps import VelocitySteps
    from granflow.analysis.velocity_steps_report import velocity_steps_section

    part = velocity_steps_section(VelocitySteps.from_dict(section), lambda entries: [])
    assert sum(record["ripple"] for record in part["view"]["records"]) == 1
    [line] = [
        line["text"]
        for line in verdicts(_no_other_analysis(), {**_no_views(), "record_sections": [part]})
    ]
    assert line.count("with the apparatus ripple") == 1


def test_a_window_and_the_protocol_agree_on_the_load_point():
    """The window's displacement since its start and velocity, and the displacement since
    the protocol's start, against the protocol's two velocities by hand."""
    from granflow.fitting.rsf_forward import Window, load_point_displacement
    from granflow.simulation.rsf.pieces import protocol_pieces

    t, _, protocol = _record(0, ripple=False)
    pieces = protocol_pieces(protocol)[0]
    np.testing.assert_allclose(load_point_displacement(pieces, t), _displacement(t), atol=1e-15)
    inside = t >= 30.0
    window = Window(t[inside], pieces, ["aging"])
    np.testing.assert_allclose(window.position, _displacement(t[inside]), atol=1e-15)
    np.testing.assert_allclose(
        window.displacement, _displacement(t[inside]) - _displacement(30.0), atol=1e-15
    )
    np.testing.assert_allclose(window.velocity, np.where(t[inside] <= 60.0, V1, V2))


def _no_other_analysis():
    """A campaign result with nothing but velocity steps, for the verdicts."""
    from types import SimpleNamespace

    from granflow.analysis.joint_results import Analyses, Material
    from granflow.analysis.prediction_results import Predictions

    return SimpleNamespace(
        material=Material(), analyses=Analyses(), predictions=Predictions(), campaign={}
    )


def _no_views():
    return {
        "material": None,
        "runs": [],
        "collapse": None,
        "amontons": None,
        "spread": None,
        "ramp": [],
        "creep": [],
        "switch": [],
        "forecasts": [],
    }
