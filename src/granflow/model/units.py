"""The one unit table of granflow, and quantities from text ("3.31mN", "0.86 um/s") to SI.

:data:`QUANTITIES` names every physical quantity granflow reads, computes or shows, with its
SI unit (the unit of every number inside granflow) and the unit it is displayed in (tables,
reports, figures). Readers, protocols, fits, results and the report look units up here
instead of keeping tables of their own. pint converts text with units; its registry is
created on first use (pint takes a fraction of a second to load it).

:func:`as_si` is the one converter of a number a person types in Python: a bare number is
taken as already in SI units, a string ("0.86 um/s") or a pint quantity is converted; every
check of :mod:`granflow._validate` goes through it, so every public function and value type
that takes a physical number accepts all three.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from granflow.errors import InvalidParameterError

if TYPE_CHECKING:
    from granflow._typing import FloatOrArray

__all__ = [
    "QUANTITIES",
    "Quantity",
    "as_si",
    "column_name",
    "display_of_si",
    "display_unit",
    "is_quantity",
    "parse_quantity",
    "quantity",
    "si_unit",
    "to_display",
    "to_si",
    "unit_registry",
]


@dataclass(frozen=True, slots=True)
class Quantity:
    """A physical quantity: its SI unit and how it is shown.

    Attributes
    ----------
    si : str
        The SI unit of the value inside granflow ("" for a pure number, "1" for a ratio).
    display : str
        The unit it is shown in.
    scale : float
        Display value = SI value * ``scale``.
    label : str
        A short description, for tables and axis labels.
    """

    si: str
    display: str
    scale: float
    label: str


def _q(si, display=None, scale=1.0, label=""):
    return Quantity(si, si if display is None else display, scale, label)


#: Every quantity granflow knows, by the name it has in the code (SI inside, display outside).
QUANTITIES = {
    # the model (Eq. 3), slip and time forms
    "a": _q("N", "mN", 1e3, "aging amplitude"),
    "alpha": _q("1/m", "1/m", 1.0, "rejuvenation constant"),
    "Fd": _q("N", "mN", 1e3, "dynamic friction"),
    "x0": _q("m", "µm", 1e6, "initial-state slip"),
    "k": _q("1/s", "1/s", 1.0, "rejuvenation rate"),
    "t0": _q("s", "s", 1.0, "initial-state time"),
    "F_init": _q("N", "mN", 1e3, "initial force"),
    # material constants (Amontons)
    "mu_a": _q("", "", 1.0, "aging coefficient"),
    "mu_d": _q("", "", 1.0, "dynamic friction coefficient"),
    # creep
    "B": _q("m", "µm", 1e6, "creep amplitude"),
    "tau_c": _q("s", "s", 1.0, "creep time"),
    # records
    "t": _q("s", "s", 1.0, "time"),
    "time": _q("s", "s", 1.0, "time"),
    "interval_time": _q("s", "s", 1.0, "interval time"),
    "slip": _q("m", "µm", 1e6, "slip"),
    "displacement": _q("m", "µm", 1e6, "drive displacement"),
    "velocity": _q("m/s", "µm/s", 1e6, "sliding velocity"),
    "force": _q("N", "mN", 1e3, "friction force"),
    "normal_load": _q("N", "mN", 1e3, "normal load"),
    "normal_force": _q("N", "mN", 1e3, "normal force"),
    "state": _q("N", "mN", 1e3, "friction state"),
    "age": _q("m", "µm", 1e6, "aging coordinate"),
    "rest_time": _q("s", "s", 1.0, "rest time"),
    "switch_time": _q("s", "s", 1.0, "switch time"),
    # the instrument
    "torque": _q("N m", "mN m", 1e3, "torque"),
    "speed": _q("rev/s", "rev/s", 1.0, "rotational speed"),
    "angle": _q("rad", "mrad", 1e3, "deflection angle"),
    "shear_stress": _q("Pa", "Pa", 1.0, "shear stress"),
    "shear_rate": _q("1/s", "1/s", 1.0, "shear rate"),
    "strain": _q("1", "1", 1.0, "strain"),
    "radius": _q("m", "mm", 1e3, "radius"),
    "outer_diameter": _q("m", "mm", 1e3, "outer diameter of the tube"),
    "wall_thickness": _q("m", "mm", 1e3, "wall thickness of the tube"),
    # protocols and the simulator
    "duration": _q("s", "s", 1.0, "duration"),
    "rate": _q("N/s", "mN/s", 1e3, "force rate"),
    "level": _q("N", "mN", 1e3, "force level"),
    "mass": _q("kg", "kg", 1.0, "effective mass"),
    "damping": _q("N s/m", "N s/m", 1.0, "damping"),
    "stiffness": _q("N/m", "N/m", 1.0, "machine stiffness"),
    "v_fail": _q("m/s", "µm/s", 1e6, "failure velocity threshold"),
    "direct_effect": _q("N", "mN", 1e3, "direct-effect amplitude"),
    "hold": _q("s", "s", 1.0, "time under force control"),
    "ramp": _q("s", "s", 1.0, "time to apply the force"),
    "sigma": _q("N", "mN", 1e3, "force noise"),
    "factor": _q("", "", 1.0, "ratio"),
}


def quantity(name):
    """The :class:`Quantity` called ``name`` (a key of :data:`QUANTITIES`).

    Raises
    ------
    granflow.InvalidParameterError
        ``name`` is not a known quantity.
    """
    try:
        return QUANTITIES[name]
    except KeyError:
        raise InvalidParameterError(
            f"unknown quantity {name!r}; known: {', '.join(sorted(QUANTITIES))}"
        ) from None


def column_name(name, quantity_name=None):
    """The name of a column granflow writes: the name, then its SI unit after an underscore
    ("t_s", "slip_m", "velocity_m_s", "force_N"); one name per quantity in every table.

    Parameters
    ----------
    name : str
        The column's name in the code ("t", "slip", ...).
    quantity_name : str, optional
        The quantity it holds, when not ``name`` (a simulation's "age" is a time).

    Examples
    --------
    >>> column_name("velocity"), column_name("age", "time"), column_name("segment", "factor")
    ('velocity_m_s', 'age_s', 'segment')
    """
    unit = si_unit(name if quantity_name is None else quantity_name)
    if unit in ("", "1"):
        return name
    return f"{name}_{unit.replace('/', '_').replace(' ', '')}"


def si_unit(name):
    """The SI unit of the quantity ``name`` ("N", "m", "1/m", ...)."""
    return quantity(name).si


def display_unit(name):
    """The unit the quantity ``name`` is shown in ("mN", "µm", ...)."""
    return quantity(name).display


#: The display unit of an SI unit, where it differs: (factor from SI, display unit).
_DISPLAY_OF_SI = {
    "N": (1e3, "mN"),
    "m": (1e6, "µm"),
    "m/s": (1e6, "µm/s"),
    "N/s": (1e3, "mN/s"),
    "N m": (1e3, "mN m"),
}


def display_of_si(unit):
    """The display factor and unit of a value in the SI unit ``unit``: ``(1e6, "µm")`` for
    "m", ``(1e3, "mN")`` for "N", ``(1.0, unit)`` for the units shown as they are.

    Examples
    --------
    >>> display_of_si("m")
    (1000000.0, 'µm')
    >>> display_of_si("1/m")
    (1.0, '1/m')
    """
    return _DISPLAY_OF_SI.get(unit, (1.0, unit))


def to_display(name, value):
    """``value`` [SI] of the quantity ``name`` in its display unit (arrays too)."""
    return value * quantity(name).scale


@functools.cache
def unit_registry():
    """The shared pint UnitRegistry (created once)."""
    import pint

    return pint.UnitRegistry()


def _clean(text):
    # Instruments and users write micro as "µ" (micro sign) or "μ" (Greek mu); "·" as a product.
    return text.strip().replace("μ", "u").replace("µ", "u").replace("·", "*").replace("⋅", "*")


def to_si(magnitude: FloatOrArray, unit: str, name: str = "value") -> FloatOrArray:
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


def parse_quantity(text: str, unit: str, name: str = "value") -> float:
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
    >>> from granflow.model.units import parse_quantity
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


def is_quantity(value):
    """Whether ``value`` is a pint quantity (of any registry), without importing pint."""
    return type(value).__module__.partition(".")[0] == "pint" and hasattr(value, "magnitude")


def _unit_text(unit):
    return unit if unit else "dimensionless"


def _converted(quantity, unit, name, shown):
    """The magnitude of the pint ``quantity`` in ``unit``, or an error naming both units."""
    target = _unit_text(unit)
    try:
        factor = float((1.0 * quantity.units).to(_clean(target)).magnitude)
    except Exception:  # pint raises DimensionalityError, UndefinedUnitError, ...
        have = f"{quantity.units:~}" or "no unit"
        raise InvalidParameterError(
            f"{name} must be a quantity in {target}, got {shown} (in {have}, which does not "
            f"convert to {target})"
        ) from None
    # divide by an exact power of ten where there is one: "0.86 um/s" -> 8.6e-07, as typed
    inverse = round(1.0 / factor) if factor > 0 else 0
    if inverse > 1 and 1.0 / inverse == factor:
        return quantity.magnitude / inverse
    return quantity.magnitude * factor


def _from_text(text, unit, name):
    """A string with a unit ("0.86 um/s") as a float in ``unit``."""
    registry = unit_registry()
    cleaned = _clean(text)
    if cleaned.startswith("/"):
        cleaned = "1" + cleaned
    try:
        quantity = registry.Quantity(cleaned)
    except Exception as exc:  # pint raises several unrelated types for bad text
        raise InvalidParameterError(
            f"{name}: cannot read {text!r} as a quantity in {_unit_text(unit)} ({exc})"
        ) from None
    if not isinstance(quantity, registry.Quantity):  # a bare number: "3"
        quantity = registry.Quantity(quantity)
    if quantity.dimensionless and unit and not registry.Quantity(1, _clean(unit)).dimensionless:
        raise InvalidParameterError(
            f"{name} must be a real number in {unit} or a string with a unit, got {text!r} "
            f"(no unit; e.g. '{text} {unit}')"
        )
    return float(_converted(quantity, unit, name, repr(text)))


def as_si(value, unit, name="value"):
    """A number a person typed, as a float (or float array) in the SI unit ``unit``.

    Parameters
    ----------
    value : float, str, pint.Quantity or array_like
        A bare number (or array) is taken as already in ``unit`` and returned unchanged;
        a string ("3.31 mN", "0.86 um/s", "0.036 1/s") is parsed with pint and must carry
        a unit of the right dimension (a bare number in a string is refused for a
        dimensional quantity); a pint quantity (scalar or array, any registry) is
        converted; a list or tuple may mix the three.
    unit : str
        The SI unit expected ("N", "m/s", "1/s", ...); "" for a pure number.
    name : str
        The argument's name, for error messages.

    Returns
    -------
    object
        ``value`` itself when it holds no string or quantity, else the converted float
        (or float array). Finiteness and sign are checked by the caller.

    Raises
    ------
    granflow.InvalidParameterError
        Text that is not a quantity, a unit of the wrong dimension (the message names the
        argument and both units), or a string without a unit for a dimensional quantity.

    Examples
    --------
    >>> from granflow.model.units import as_si
    >>> as_si("3.31 mN", "N", "a")
    0.00331
    >>> round(as_si("0.86 um/s", "m/s", "velocity"), 15)
    8.6e-07
    >>> as_si(0.5, "N", "a")
    0.5
    """
    if isinstance(value, str):
        return _from_text(value, unit, name)
    if is_quantity(value):
        return _converted(value, unit, name, f"{value:~}")
    if isinstance(value, list | tuple) and any(
        isinstance(item, str) or is_quantity(item) for item in value
    ):
        return [as_si(item, unit, f"{name}[{index}]") for index, item in enumerate(value)]
    return value
