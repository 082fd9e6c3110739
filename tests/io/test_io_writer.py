"""The writer: every combination reads back to the same SI values and metadata; the French
UTF-16 decimal-comma µN·m / 1/min / mrad start-up reads back to the simulated curves."""

import itertools

import numpy as np
import pytest

import granflow
from granflow.io import write_rheocompass, write_trios

TUBE = granflow.Annulus.paper()
VELOCITY = 0.86e-6
PARAMS = granflow.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=VELOCITY)
META = {
    "normal_load": 0.05,
    "sample": "PMMA 40 µm",
    "preparation": "P3",
    "rest_time": 60.0,
    "velocity": VELOCITY,
}


def simulated_runs(points=12):
    time = np.linspace(0.0, 110.0, points)
    force = granflow.friction_time(time + 0.23, PARAMS, VELOCITY)
    rate = granflow.Run(
        t=time,
        slip=VELOCITY * time,
        velocity=np.full(points, VELOCITY),
        force=force,
        control="rate",
        meta=META,
    )
    stress = granflow.Run(
        t=time,
        slip=2e-6 * time**2,
        velocity=4e-6 * time,
        force=np.full(points, 12e-3),
        control="stress",
        meta={**META, "preparation": "P4", "normal_load": 0.08},
    )
    return [rate, stress]


def assert_same(written, read, rtol):
    for name in ("t", "velocity", "force"):
        np.testing.assert_allclose(getattr(read, name), getattr(written, name), rtol=rtol, atol=0)
    # slip is measured from the first angle of the interval
    np.testing.assert_allclose(read.slip, written.slip - written.slip[0], rtol=rtol, atol=1e-22)
    assert read.control == written.control
    for key, value in written.meta.items():
        assert read.meta[key] == value, key


LANGUAGES = ("en", "fr", "de")
ENCODINGS = ("utf-16", "utf-16-be", "utf-8", "utf-8-sig", "cp1252")
DECIMALS = (".", ",")
TORQUES = ("µN·m", "mN·m", "µNm", "N m", "µN.m")
SPEEDS = ("1/min", "1/s", "rad/s")
ANGLES = ("mrad", "rad", "°")


def test_round_trip_every_combination(tmp_path):
    runs = simulated_runs()
    path = tmp_path / "export.csv"
    combos = list(itertools.product(LANGUAGES, ENCODINGS, DECIMALS, TORQUES, SPEEDS, ANGLES))
    assert len(combos) == 1350
    for language, encoding, decimal, torque, speed, angle in combos:
        units = {"torque": torque, "speed": speed, "angle": angle}
        write_rheocompass(
            path, runs, language=language, encoding=encoding, decimal=decimal, units=units
        )
        back = granflow.read_runs(path)
        assert len(back) == 2
        for written, read in zip(runs, back, strict=True):
            assert_same(written, read, rtol=1e-9)


@pytest.mark.parametrize("time_unit", ["s", "min"])
@pytest.mark.parametrize("decimal", DECIMALS)
def test_round_trip_trios(tmp_path, decimal, time_unit):
    runs = simulated_runs()
    path = write_trios(tmp_path / "trios.txt", runs, decimal=decimal, units={"time": time_unit})
    parsed = granflow.read(path)
    assert parsed.format == "trios"
    assert parsed.tests == ("Peak hold - 1", "Peak hold - 2")
    for written, read in zip(runs, granflow.read_runs(path), strict=True):
        assert_same(written, read, rtol=1e-9)


def test_end_to_end_french_utf16_comma_micro_newton_metre(tmp_path):
    """A simulated start-up, written as RheoCompass in French / UTF-16 / decimal comma with
    torque in µN·m, speed in 1/min and angle in mrad, read with Annulus.paper()."""
    time = np.arange(0.0, 200.0, 1.0)
    slip = VELOCITY * time
    force = granflow.friction_slip(slip + PARAMS.x0, PARAMS)
    run = granflow.Run(
        t=time, slip=slip, velocity=np.full(time.size, VELOCITY), force=force, meta=META
    )
    path = tmp_path / "démarrage.csv"
    write_rheocompass(
        path,
        [run],
        geometry=TUBE,
        language="fr",
        encoding="utf-16",
        decimal=",",
        units={"torque": "µN·m", "speed": "1/min", "angle": "mrad"},
        digits=8,
    )
    raw = path.read_bytes()
    assert raw.startswith(b"\xff\xfe")
    text = raw.decode("utf-16")
    assert "Couple\tAngle de Déflexion" in text and "[µN·m]" in text and "[1/min]" in text
    parsed = granflow.read(path)
    assert (parsed.encoding, parsed.decimal) == ("utf-16", ",")
    (back,) = granflow.read_runs(path, geometry=TUBE)
    # written with 8 significant digits: equal to the simulation to 5e-8 relative
    np.testing.assert_allclose(back.force, force, rtol=5e-8, atol=0)
    np.testing.assert_allclose(back.velocity, VELOCITY, rtol=5e-8)
    np.testing.assert_allclose(back.slip, slip, rtol=5e-8, atol=1e-20)
    assert back.control == "rate" and back.meta["normal_load"] == 0.05


def test_missing_values_written_and_read_as_nan(tmp_path):
    run = granflow.Run(
        t=[1.0, 2.0, 3.0], slip=[0.0, 1e-6, 2e-6], velocity=[1e-6] * 3, force=[0.01, np.nan, 0.012]
    )
    for marker in ("", " ", "******"):
        path = write_rheocompass(tmp_path / "m.txt", run, missing=marker, encoding="utf-8")
        back = granflow.read_runs(path)[0]
        assert np.isnan(back.force[1]) and back.force[2] == pytest.approx(0.012, rel=1e-9)


def test_writer_rejects_bad_choices(tmp_path):
    run = simulated_runs()[0]
    with pytest.raises(granflow.InvalidParameterError, match="language"):
        write_rheocompass(tmp_path / "x", run, language="pt")
    with pytest.raises(granflow.InvalidParameterError, match="furlong"):
        write_rheocompass(tmp_path / "x", run, units={"torque": "furlong"})
    with pytest.raises(granflow.InvalidParameterError, match="runs"):
        write_trios(tmp_path / "x", [])
