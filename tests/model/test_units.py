"""Quantities with units from the command line and from file headers."""

import pytest

import granflow as gf
from granflow.model.units import parse_quantity, to_si


@pytest.mark.parametrize(
    ("text", "unit", "expected"),
    [
        ("3.31mN", "N", 3.31e-3),
        ("0.036/s", "1/s", 0.036),
        ("0.23s", "s", 0.23),
        ("0.86um/s", "m/s", 0.86e-6),
        ("0.86µm/s", "m/s", 0.86e-6),
        ("0.86 μm/s", "m/s", 0.86e-6),
        ("2 min", "s", 120.0),
        ("1e-5", "m/s", 1e-5),
        (0.5, "N", 0.5),
        ("4.19e4/m", "1/m", 4.19e4),
    ],
)
def test_parse_quantity(text, unit, expected):
    assert parse_quantity(text, unit) == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize(
    ("text", "match"),
    [("3 kg", "cannot read '3 kg'"), ("abc", "cannot read 'abc'"), ("nan", "must be finite")],
)
def test_parse_quantity_errors(text, match):
    with pytest.raises(gf.InvalidParameterError, match=match):
        parse_quantity(text, "N", "--a")


@pytest.mark.parametrize(
    ("value", "unit", "expected"),
    [
        (1.0, "mN·m", 1e-3),
        (1.0, "µN·m", 1e-6),
        (1.0, "uN*m", 1e-6),
        (60.0, "1/min", 1.0),
        (1.0, "mrad", 1e-3),
        (180.0, "deg", 3.141592653589793),
    ],
)
def test_to_si(value, unit, expected):
    assert to_si(value, unit) == pytest.approx(expected, rel=1e-14)


def test_unknown_unit_is_named():
    with pytest.raises(gf.InvalidParameterError, match="'bogons'"):
        to_si(1.0, "bogons", "torque")


def test_the_unit_table_scales_agree_with_pint():
    """Every display scale of the one unit table is pint's conversion from the SI unit."""
    from granflow.model.units import QUANTITIES, unit_registry

    registry = unit_registry()
    for name, entry in QUANTITIES.items():
        if entry.si in ("", "1"):
            assert entry.scale == 1.0, name
            continue
        si = entry.si.replace("rev", "turn")
        display = entry.display.replace("rev", "turn").replace("µ", "u")
        factor = registry.Quantity(1.0, si).to(display).magnitude
        assert abs(factor / entry.scale - 1) < 1e-12, name


def test_unknown_quantity_is_named():
    from granflow.model.units import si_unit

    with pytest.raises(gf.InvalidParameterError, match="unknown quantity 'bogus'"):
        si_unit("bogus")
