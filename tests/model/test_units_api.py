"""Units where a person types a number in Python: a float is SI, a string or a pint quantity
is converted, a wrong dimension is an error naming the argument and both units."""

import numpy as np
import pint
import pytest

import granflow as gf
from granflow.model.units import as_si

UREG = pint.UnitRegistry()  # a registry of the user's own, not granflow's
V = 0.86e-6


def test_the_issue_examples_work():
    p = gf.Params.from_time_domain(
        a="3.31 mN", k="0.036 1/s", t0="0.23 s", Fd="10 mN", velocity="0.86 um/s"
    )
    expected = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=V)
    for name in ("a", "alpha", "Fd", "x0"):
        assert getattr(p, name) == pytest.approx(getattr(expected, name), rel=1e-15)
    segment = gf.Velocity("0.86 um/s", "10 s")
    assert segment.velocity == 0.86e-6 and segment.duration == 10.0


@pytest.mark.parametrize(
    ("value", "unit", "expected"),
    [
        (0.5, "N", 0.5),  # a bare number stays SI
        ("3.31 mN", "N", 3.31e-3),
        ("0.86 µm/s", "m/s", 0.86e-6),
        ("0.036/s", "1/s", 0.036),
        ("2 min", "s", 120.0),
        ("1.01", "", 1.01),  # a pure number may be written as text
        (UREG.Quantity(3.31, "mN"), "N", 3.31e-3),
        (UREG.Quantity(0.86, "um/s"), "m/s", 0.86e-6),
        (UREG.Quantity(1.0, "mN/s"), "N/s", 1e-3),
    ],
)
def test_as_si_converts_text_and_quantities(value, unit, expected):
    assert as_si(value, unit, "x") == pytest.approx(expected, rel=1e-15)


def test_as_si_converts_arrays_of_quantities():
    np.testing.assert_allclose(
        as_si(UREG.Quantity(np.array([1.0, 2.5]), "mN"), "N", "x"), [1e-3, 2.5e-3], rtol=1e-15
    )
    assert as_si(["1 um/s", 2e-6, UREG.Quantity(3, "um/s")], "m/s", "v") == pytest.approx(
        [1e-6, 2e-6, 3e-6], rel=1e-15
    )


@pytest.mark.parametrize(
    ("value", "match"),
    [
        ("3 kg", r"a must be a quantity in N, got '3 kg' \(in kg, which does not convert to N"),
        (UREG.Quantity(3, "s"), r"a must be a quantity in N, got 3 s \(in s, which"),
        ("3", r"a must be a real number in N or a string with a unit, got '3' \(no unit"),
        ("abc", r"a: cannot read 'abc' as a quantity in N"),
    ],
)
def test_as_si_refuses_wrong_dimensions_naming_both_units(value, match):
    with pytest.raises(gf.InvalidParameterError, match=match):
        as_si(value, "N", "a")


def test_params_take_quantities_and_name_the_wrong_one():
    p = gf.Params(a=UREG.Quantity(3.31, "mN"), alpha="41860 1/m", Fd="10 mN", x0="0.1978 um")
    assert (p.a, p.alpha, p.Fd, p.x0) == pytest.approx((3.31e-3, 41860.0, 10e-3, 0.1978e-6))
    with pytest.raises(gf.InvalidParameterError, match=r"x0 must be a quantity in m, got '1 s'"):
        gf.Params(a=1e-3, alpha=1e4, Fd=1e-3, x0="1 s")
    with pytest.raises(gf.InvalidParameterError, match="velocity must be a quantity in m/s"):
        gf.Params.from_time_domain(a=1e-3, k=0.03, t0=0.2, Fd=1e-2, velocity="1 mN")
    with pytest.raises(gf.InvalidParameterError, match="x0 must be positive"):
        gf.Params(a=1e-3, alpha=1e4, Fd=1e-3, x0="-1 um")


def test_protocol_segments_take_quantities():
    assert gf.Force("5 mN", UREG.Quantity(1, "min")) == gf.Force(5e-3, 60.0)
    assert gf.ForceRamp("0.05 mN/s", "400 s", start="1 mN") == gf.ForceRamp(5e-5, 400.0, 1e-3)
    assert gf.Hold("5 s", reset=True) == gf.Hold(5.0, reset=True)
    assert gf.VelocitySteps(["1 um/s", "2 um/s"], "10 s") == gf.VelocitySteps([1e-6, 2e-6], 10.0)
    assert gf.VelocityTable(UREG.Quantity([0, 5], "s"), ["0 um/s", "1 um/s"]) == (
        gf.VelocityTable([0.0, 5.0], [0.0, 1e-6])
    )
    assert gf.ForceSteps(["1 mN", "2 mN"], "3 s") == gf.ForceSteps([1e-3, 2e-3], 3.0)
    assert gf.ForceTable([0, "2 s"], ["0 N", "1 mN"]) == gf.ForceTable([0.0, 2.0], [0.0, 1e-3])
    assert gf.SwitchToForce("60 s", level="12 mN", ramp="1 s") == gf.SwitchToForce(
        60.0, level=12e-3, ramp=1.0
    )


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: gf.Velocity("0.86 mN", 10.0), r"Velocity: velocity must be a quantity in m/s"),
        (lambda: gf.Force(1e-3, "1 m"), r"Force: duration must be a quantity in s, got '1 m'"),
        (lambda: gf.ForceRamp("1 mN", 10.0), r"ForceRamp: rate must be a quantity in N/s"),
        (lambda: gf.VelocitySteps(["1 um/s", "1 s"], 1.0), r"velocities\[1\] must be a quantity"),
    ],
)
def test_segments_name_the_field_of_a_wrong_dimension(make, match):
    with pytest.raises(gf.InvalidProtocolError, match=match):
        make()


def test_simulate_keywords_take_quantities():
    p = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=V)
    protocol = [gf.Velocity(V, 30.0), gf.SwitchToForce(5.0, factor=1.01)]
    typed = gf.simulate(
        p,
        protocol,
        method="dynamic",
        mass="53.3 g",
        damping=UREG.Quantity(0.5, "N*s/m"),
        stiffness="5 kN/m",
        v_fail="1 mm/s",
        rtol=1e-7,
    )
    plain = gf.simulate(
        p,
        protocol,
        method="dynamic",
        mass=0.0533,
        damping=0.5,
        stiffness=5e3,
        v_fail=1e-3,
        rtol=1e-7,
    )
    assert typed.options["mass"] == pytest.approx(0.0533, rel=1e-15)
    assert typed.options["stiffness"] == 5e3 and typed.options["v_fail"] == 1e-3
    np.testing.assert_array_equal(typed.force, plain.force)
    creep = gf.simulate(p, [gf.Force("12 mN", "10 s")], direct_effect="0.2 mN")
    assert creep.options["direct_effect"].amplitude == pytest.approx(0.2e-3, rel=1e-15)
    with pytest.raises(gf.InvalidParameterError, match="mass must be a quantity in kg"):
        gf.simulate(p, protocol, method="dynamic", mass="1 m")


def test_peak_and_the_closed_form_take_a_velocity_with_a_unit():
    p = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=V)
    assert gf.peak(p, velocity="0.86 um/s").time == gf.peak(p, velocity=V).time
    t = np.array([1.0, 20.0, 300.0])
    np.testing.assert_array_equal(
        gf.friction_time(UREG.Quantity(t, "s"), p, UREG.Quantity(0.86, "um/s")),
        gf.friction_time(t, p, V),
    )
    assert gf.friction_slip("20 um", p) == gf.friction_slip(20e-6, p)
    with pytest.raises(gf.InvalidParameterError, match="velocity must be a quantity in m/s"):
        gf.peak(p, velocity="1 s")
    with pytest.raises(gf.InvalidParameterError, match="t must be a quantity in s"):
        gf.friction_time(UREG.Quantity(t, "m"), p, V)
