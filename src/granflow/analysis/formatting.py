"""Numbers and units for display: the filters of the HTML report and the summary.

Every quantity granflow computes is in SI units; these functions show it in display units,
looked up in :data:`granflow.model.units.QUANTITIES` by the quantity's name (through
:data:`QUANTITY_OF` for the names of ``results.json`` that are not quantities themselves).
:func:`display_scale` gives ``(factor, unit)``; it is not
:func:`granflow.model.units.display_unit`, which gives the unit alone (two functions of one
name with two return types once put "F_N = 55 N" into a caption).
"""

import numbers
from collections.abc import Mapping

from granflow._format import (
    DASH,
    format_interval,
    format_number,
    format_value_error,
    real_number,
)

__all__ = [
    "DASH",
    "QUANTITY_OF",
    "display_scale",
    "format_interval",
    "format_number",
    "format_p_value",
    "format_percent",
    "format_value_error",
    "header_label",
    "quantity_text",
    "real_number",
]


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
    "alpha_v": "k",
    "reference_velocity": "velocity",
}


def display_scale(name):
    """The display scale and unit of a quantity named ``name`` (SI -> display).

    Looked up in :data:`granflow.model.units.QUANTITIES`, through :data:`QUANTITY_OF` for
    the names of ``results.json`` that are not quantities themselves.

    Returns
    -------
    (float, str)
        Factor from SI and the unit ("" when dimensionless or unknown).

    Examples
    --------
    >>> display_scale("failure_force")
    (1000.0, 'mN')
    >>> display_scale("x_peak")
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
    scale, symbol = display_scale(name)
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
    unit = display_scale(name)[1]
    return f"{name} [{unit}]" if unit else str(name)
