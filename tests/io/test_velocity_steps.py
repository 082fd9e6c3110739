"""Velocity-step records: units to SI, the load-point history recovered from displacement."""

import numpy as np
import pytest
from conftest import shared_data

import granflow as gf
from granflow.errors import FileFormatError, InvalidDataError
from granflow.io.velocity_steps import (
    parse_velocity_steps,
    read_velocity_steps,
    segment_velocity,
)


def _table(t, displacement_um, friction, stress_mpa=None, header=None):
    header = header or "Time(s)\tDispl(microns)\tFriction" + (
        "\tEffective_Normal_stress(MPa)" if stress_mpa is not None else ""
    )
    rows = [header]
    for i in range(t.size):
        cells = [f"{t[i]:.6f}", f"{displacement_um[i]:.6f}", f"{friction[i]:.6f}"]
        if stress_mpa is not None:
            cells.append(f"{stress_mpa[i]:.6f}")
        rows.append("\t".join(cells))
    return "\n".join(rows) + "\n"


def _steps(seed=0, noise_um=0.05):
    """Displacement of a load point at 1, 10, then 3 µm/s, sampled every 0.1 s from t = 500 s."""
    t = 500.0 + np.arange(0.0, 150.0, 0.1)
    local = t - 500.0
    d = np.where(local < 50, local, 50 + 10 * (local - 50))
    d = np.where(local < 100, d, 550 + 3 * (local - 100))
    d = d + np.random.default_rng(seed).normal(0, noise_um, t.size)
    return t, d


def test_units_are_converted_to_si_and_time_starts_at_zero():
    t, d = _steps()
    text = _table(t, 1000 + d, np.full(t.size, 0.6), np.full(t.size, 30.0))
    record = parse_velocity_steps(text)
    assert record.time_offset == pytest.approx(500.0)
    assert record.t[0] == 0.0 and record.t[-1] == pytest.approx(149.9)
    # displacement since the first row, in metres
    assert record.displacement[-1] == pytest.approx((d[-1] - d[0]) * 1e-6, abs=1e-12)
    np.testing.assert_allclose(record.normal_stress, 30e6)
    assert record.meta["columns"]["displacement"] == "Displ(microns)"


def test_steps_are_found_automatically():
    t, d = _steps()
    record = parse_velocity_steps(_table(t, d, np.full(t.size, 0.6)))
    assert len(record.step_times) == 2
    np.testing.assert_allclose(record.step_times, [50.0, 100.0], atol=0.15)
    np.testing.assert_allclose(record.velocities, [1e-6, 10e-6, 3e-6], rtol=2e-3)
    segments = list(record.protocol)
    assert [type(s) for s in segments] == [gf.Velocity] * 3
    assert sum(s.duration for s in segments) == pytest.approx(record.t[-1])


def test_steps_can_be_given_explicitly():
    t, d = _steps()
    breaks, velocities = segment_velocity(t - t[0], d * 1e-6, step_times=[50.0])
    assert breaks == [50.0]
    # one line through 50..150 s (10 then 3 µm/s) has a slope in between
    assert 3e-6 < velocities[1] < 10e-6
    with pytest.raises(InvalidDataError, match="inside the record"):
        segment_velocity(t - t[0], d, step_times=[500.0])


def test_a_constant_velocity_has_no_step():
    t = np.arange(0.0, 100.0, 0.1)
    d = 2.0 * t + np.random.default_rng(1).normal(0, 0.05, t.size)
    breaks, velocities = segment_velocity(t, d * 1e-6)
    assert breaks == [] and velocities[0] == pytest.approx(2e-6, rel=1e-3)


@pytest.mark.parametrize(
    ("header", "match"),
    [
        ("Time(s)\tDispl(furlongs)\tFriction", r"column 2 \('Displ'\): its unit is not one"),
        ("Time(s)\tFriction", "no displacement column"),
    ],
)
def test_bad_headers_are_named(header, match):
    t, d = _steps()
    with pytest.raises(FileFormatError, match=match):
        parse_velocity_steps(_table(t, d, np.full(t.size, 0.6), header=header), "run.txt")


def test_a_bad_cell_names_its_line():
    t, d = _steps()
    lines = _table(t, d, np.full(t.size, 0.6)).splitlines()
    lines[7] = "1.0\tabc\t0.6"
    with pytest.raises(FileFormatError, match="line 8"):
        parse_velocity_steps("\n".join(lines), "run.txt")


@pytest.mark.parametrize(
    ("name", "velocities", "step"),
    [
        ("velstep3_TR2_exp013_sepiolite.txt", (0.2e-6, 2e-6), 1234.7),
        ("velstep4_BRAVA_expb819_basalt.txt", (3e-6, 10e-6), 68.6),
    ],
)
def test_the_real_records(name, velocities, step):
    path = shared_data("rate-state-velocity-steps", name)
    record = read_velocity_steps(path)
    raw = np.loadtxt(path, skiprows=1)
    assert record.t.size == raw.shape[0]
    assert record.time_offset == raw[0, 0]
    assert len(record.step_times) == 1
    assert record.step_times[0] == pytest.approx(step, abs=0.5)
    # the velocities against straight lines fitted by hand well away from the step
    t = raw[:, 0] - raw[0, 0]
    for v, inside in zip(record.velocities, (t < step - 5, t > step + 5), strict=True):
        slope = np.polyfit(t[inside], raw[inside, 1], 1)[0] * 1e-6
        assert v == pytest.approx(slope, rel=0.02)
    np.testing.assert_allclose(record.velocities, velocities, rtol=0.02)
