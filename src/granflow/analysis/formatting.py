"""Numbers and units for display: the filters of the HTML report and the summary.

Every quantity granflow computes is in SI units; these functions show it in display units,
looked up in :data:`granflow.model.units.QUANTITIES` by the quantity's name (through
:data:`QUANTITY_OF` for the names of ``results.json`` that are not quantities themselves).
"""

import math
import numbers
from collections.abc import Mapping

__all__ = [
    "DASH",
    "QUANTITY_OF",
    "display_unit",
    "format_interval",
    "format_number",
    "format_p_value",
    "format_percent",
    "format_value_error",
    "header_label",
    "quantity_text",
    "real_number",
]

_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
#: What a missing value shows.
DASH = "—"

# --------------------------------------------------------------------------- numbers


def real_number(value):
    """``value`` as a finite float, or None (bools, text and non-finite numbers give None)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _exponent(value, significant):
    """Decimal exponent of ``value`` once rounded to ``significant`` digits."""
    return int(f"{abs(value):.{significant - 1}e}".split("e")[1])


def _times_ten(exponent):
    return "×10" + str(exponent).translate(_SUPERSCRIPT)


def _fixed(value, place):
    """``value`` rounded at the decimal ``place`` (10**place is the last digit kept)."""
    if place >= 0:
        text = f"{round(value / 10**place) * 10**place:.0f}"
    else:
        text = f"{value:.{-place}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def format_number(value, scale=1.0, significant=4):
    """A number for display: ``significant`` digits, plain between 1e-3 and 1e5, else with a
    power of ten (``1.968×10⁻⁷``).

    Parameters
    ----------
    value : float or None
        The number [SI]; None, NaN, infinities and non-numbers give "—".
    scale : float
        Factor to display units (1e3 for N -> mN).
    significant : int
        Significant digits.

    Returns
    -------
    str

    Examples
    --------
    >>> format_number(0.0123456, 1e3)
    '12.35'
    >>> format_number(1.9675e-07)
    '1.968×10⁻⁷'
    """
    value = real_number(value)
    if value is None:
        return DASH
    value *= scale
    if value == 0:
        return "0"
    exponent = _exponent(value, significant)
    if -3 <= exponent < 5:
        return _fixed(value, min(exponent - significant + 1, 0))
    mantissa = value / 10**exponent
    return f"{mantissa:.{significant - 1}f}{_times_ten(exponent)}"


def format_value_error(value, error, scale=1.0, digits=2):
    """``value ± error`` with the value rounded at the last digit of the error.

    Parameters
    ----------
    value, error : float or None
        The value and its standard error [SI]. Without a finite positive error the value is
        shown alone (4 significant digits); without a value, "—".
    scale : float
        Factor to display units.
    digits : int
        Significant digits kept in the error.

    Returns
    -------
    str

    Examples
    --------
    >>> format_value_error(49251.89, 433.72)
    '49250 ± 430'
    >>> format_value_error(0.0017915, 7.58e-06, 1e3)
    '1.7915 ± 0.0076'
    >>> format_value_error(1.9612e-07, 3.3e-09, 1e6)
    '0.1961 ± 0.0033'
    >>> format_value_error(2.1e-9, 3.0e-11)
    '(2.100 ± 0.030)×10⁻⁹'
    """
    value, error = real_number(value), real_number(error)
    if value is None:
        return DASH
    if error is None or error <= 0:
        return format_number(value, scale)
    value, error = value * scale, abs(error * scale)
    place = _exponent(error, digits) - digits + 1
    exponent = _exponent(value, digits) if value != 0 else place
    exponent = max(exponent, _exponent(error, digits))
    if -3 <= exponent < 5:
        return f"{_fixed(value, place)} ± {_fixed(error, place)}"
    shift = 10**exponent
    local = place - exponent
    return (
        f"({_fixed(value / shift, local)} ± {_fixed(error / shift, local)}){_times_ten(exponent)}"
    )


def format_interval(bounds, scale=1.0, significant=4):
    """A 95 % interval ``[low, high]`` for display ("—" when it is missing)."""
    if not isinstance(bounds, list | tuple) or len(bounds) != 2:
        return DASH
    low, high = (real_number(b) for b in bounds)
    if low is None and high is None:
        return DASH
    if low is not None and high is not None and high > low:
        # enough digits that the two ends differ: two in the width
        width, top = (high - low) * abs(scale), max(abs(low), abs(high)) * abs(scale)
        if top > 0:
            significant = max(significant, _exponent(top, 2) - _exponent(width, 2) + 2)
    return f"[{format_number(low, scale, significant)}, {format_number(high, scale, significant)}]"


def format_p_value(p):
    """A p-value: two significant digits, with a power of ten below 1e-4."""
    p = real_number(p)
    if p is None:
        return DASH
    if p == 0:
        return "< 10⁻³⁰⁰"
    if p < 1e-4:
        return format_number(p, significant=2)
    return f"{p:.2g}"


def format_percent(value):
    """A fraction as a percentage with three significant digits ("—" when missing)."""
    value = real_number(value)
    return DASH if value is None else f"{100 * value:.3g} %"


#: Names in ``results.json`` that are not themselves quantities of
#: :data:`granflow.model.units.QUANTITIES`, and the quantity each one is.
QUANTITY_OF = {
    "F_d": "Fd",
    "stress": "force",
    "imposed_force": "force",
    "switch_force": "force",
    "failure_force": "force",
    "F_peak": "force",
    "F_peak_stderr": "force",
    "F_peak_spread": "force",
    "x_peak": "slip",
    "stop_slip": "slip",
    "failure_slip": "slip",
    "switch_slip": "slip",
    "creep_slip": "slip",
    "t_peak": "time",
    "failure_time": "time",
    "switch_time": "time",
    "runaway_time": "time",
    "hold_time": "time",
    "rest_time": "time",
    "elapsed_s": "time",
    "alpha_v": "k",
    "reference_velocity": "velocity",
}


def display_unit(name):
    """The display scale and unit of a quantity named ``name`` (SI -> display).

    Looked up in :data:`granflow.model.units.QUANTITIES`, through :data:`QUANTITY_OF` for
    the names of ``results.json`` that are not quantities themselves.

    Returns
    -------
    (float, str)
        Factor from SI and the unit ("" when dimensionless or unknown).

    Examples
    --------
    >>> display_unit("failure_force")
    (1000.0, 'mN')
    >>> display_unit("x_peak")
    (1000000.0, 'µm')
    """
    from granflow.model.units import QUANTITIES

    known = QUANTITIES.get(QUANTITY_OF.get(str(name), str(name)))
    return (1.0, "") if known is None else (known.scale, known.display)


def quantity_text(name, value, *, unit=True):
    """A display string for a named value of unknown kind (number, text, list, bool); the
    unit follows the number unless ``unit`` is false (when a header carries it)."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    scale, symbol = display_unit(name)
    if isinstance(value, numbers.Integral) and scale == 1.0:
        text = str(int(value))
    elif real_number(value) is not None:
        text = format_number(value, scale)
    elif value is None:
        return DASH
    elif isinstance(value, list | tuple):
        return ", ".join(quantity_text(name, item, unit=unit) for item in value) or DASH
    elif isinstance(value, Mapping):
        return "; ".join(f"{key}: {quantity_text(key, item)}" for key, item in value.items())
    else:
        return str(value)
    return f"{text} {symbol}" if unit and symbol else text


def header_label(name):
    """``name [unit]`` for a column or row header."""
    unit = display_unit(name)[1]
    return f"{name} [{unit}]" if unit else str(name)
