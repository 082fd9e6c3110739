"""Quantities with units from text ("3.31mN", "0.86 um/s", "0.036/s") to SI floats, via pint.

The registry is created on first use (pint takes a fraction of a second to load it).
"""

import functools
import math

from granflow.errors import InvalidParameterError

__all__ = ["parse_quantity", "to_si", "unit_registry"]


@functools.cache
def unit_registry():
    """The shared pint UnitRegistry (created once)."""
    import pint

    return pint.UnitRegistry()


def _clean(text):
    # Instruments and users write micro as "µ" (micro sign) or "μ" (Greek mu); "·" as a product.
    return text.strip().replace("μ", "u").replace("µ", "u").replace("·", "*").replace("⋅", "*")


def to_si(magnitude, unit, name="value"):
    """Convert ``magnitude`` in ``unit`` (a pint unit expression) to the SI base-unit value.

    Parameters
    ----------
    magnitude : float or numpy.ndarray
        Value(s) in ``unit``.
    unit : str
        A unit pint understands ("mN", "uN*m", "1/min", "mrad", "deg", ...).
    name : str
        What the value is, for error messages.

    Returns
    -------
    float or numpy.ndarray
        The value(s) in SI base units.
    """
    registry = unit_registry()
    try:
        quantity = registry.Quantity(magnitude, _clean(unit))
        return quantity.to_base_units().magnitude
    except Exception as exc:  # pint raises several unrelated types for bad units
        raise InvalidParameterError(f"{name}: unknown or invalid unit {unit!r} ({exc})") from None


def parse_quantity(text, unit, name="value"):
    """Parse a number with an optional unit into a float in the SI unit ``unit``.

    Parameters
    ----------
    text : str or float
        "3.31mN", "0.86 um/s", "0.036/s", "1e-5" (a plain number is taken as already in
        ``unit``).
    unit : str
        The SI unit expected, e.g. "N", "m/s", "1/s", "m", "s"; the text's unit must have
        the same dimension.
    name : str
        The argument's name, for error messages.

    Returns
    -------
    float
        The value in ``unit``.

    Examples
    --------
    >>> from granflow.units import parse_quantity
    >>> parse_quantity("3.31mN", "N", "a")
    0.00331
    >>> round(parse_quantity("0.86um/s", "m/s", "velocity"), 15)
    8.6e-07
    """
    if isinstance(text, int | float):
        value = float(text)
    else:
        cleaned = _clean(str(text))
        try:
            value = float(cleaned)
        except ValueError:
            registry = unit_registry()
            if cleaned.startswith("/"):
                cleaned = "1" + cleaned
            try:
                quantity = registry.Quantity(cleaned)
                if quantity.dimensionless and not registry.Quantity(1, _clean(unit)).dimensionless:
                    raise ValueError("no unit given")
                value = float(quantity.to(_clean(unit)).magnitude)
            except Exception as exc:
                raise InvalidParameterError(
                    f"{name}: cannot read {text!r} as a quantity in {unit} ({exc})"
                ) from None
    if not math.isfinite(value):
        raise InvalidParameterError(f"{name} must be finite, got {text!r}")
    return value
