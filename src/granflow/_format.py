"""Numbers with the digits their errors justify: the one formatter of granflow's text.

Every summary, text report and HTML representation shows a value with its standard error
through :func:`format_value_error` (the error with two significant digits, the value rounded
at the error's last digit: ``11.100 ± 0.069``, never ``11.1 +/- 0.069``), and a value alone
through :func:`format_number`. :mod:`granflow.analysis.formatting` adds the display units of
the report on top. Pure Python: importing it loads nothing heavy.
"""

import math
import numbers
import re

__all__ = [
    "DASH",
    "display_text",
    "format_interval",
    "format_number",
    "format_value_error",
    "real_number",
]

_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
#: What a missing value shows.
DASH = "—"
#: The most significant digits a value is shown with, however small its error.
MAX_DIGITS = 8

# --------------------------------------------------------------------------- numbers


def real_number(value: object) -> float | None:
    """``value`` as a finite float, or None (bools, text and non-finite numbers give None)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _exponent(value: float, significant: int) -> int:
    """Decimal exponent of ``value`` once rounded to ``significant`` digits."""
    return int(f"{abs(value):.{significant - 1}e}".split("e")[1])


def _times_ten(exponent: int) -> str:
    return "×10" + str(exponent).translate(_SUPERSCRIPT)


def _fixed(value: float, place: int) -> str:
    """``value`` rounded at the decimal ``place`` (10**place is the last digit kept)."""
    if place >= 0:
        text = f"{round(value / 10**place) * 10**place:.0f}"
    else:
        text = f"{value:.{-place}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def format_number(value: object, scale: float = 1.0, significant: int = 4) -> str:
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


def format_value_error(value: object, error: object, scale: float = 1.0, digits: int = 2) -> str:
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
        The value is given to at most :data:`MAX_DIGITS` significant digits (an error below
        that, as of a fit to exact data, shows as "< 1e-N" of the value).

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
    >>> format_value_error(3.31e-3, 3.4e-19, 1e3)
    '3.3100000 (± < 10⁻⁷ relative)'
    """
    value, error = real_number(value), real_number(error)
    if value is None:
        return DASH
    if error is None or error <= 0:
        return format_number(value, scale)
    if value != 0 and abs(error / value) < 10.0 ** (1 - MAX_DIGITS):
        return (
            f"{format_number(value, scale, MAX_DIGITS)} (± < 10"
            + str(1 - MAX_DIGITS).translate(_SUPERSCRIPT)
            + " relative)"
        )
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


#: The most significant digits an interval's ends are shown with (a double holds about 16; a
#: model evaluated in double precision is good to about 1e-10 of its value).
MOST_DIGITS = 8


def format_interval(bounds: object, scale: float = 1.0, significant: int = 4) -> str:
    """An interval ``[low, high]`` for display ("—" when it is missing), with digits enough
    that the two ends differ (two in the width), but never more than :data:`MOST_DIGITS`: an
    interval narrower than that (a fit of noise-free data) shows equal ends."""
    if not isinstance(bounds, list | tuple) or len(bounds) != 2:
        return DASH
    low, high = (real_number(b) for b in bounds)
    if low is None and high is None:
        return DASH
    if low is not None and high is not None and high > low:
        width, top = (high - low) * abs(scale), max(abs(low), abs(high)) * abs(scale)
        if top > 0:
            wanted = _exponent(top, 2) - _exponent(width, 2) + 2
            significant = max(significant, min(wanted, MOST_DIGITS))
    return f"[{format_number(low, scale, significant)}, {format_number(high, scale, significant)}]"


_SI_QUANTITY = re.compile(
    r"(?P<value>[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?) (?P<unit>m/s|m|N|s)(?![\w/])"
)
#: The display factor and unit of each SI unit a message may hold.
_MESSAGE_UNITS = {"m": (1e6, "µm"), "N": (1e3, "mN"), "s": (1.0, "s"), "m/s": (1e6, "µm/s")}


def display_text(text: str, significant: int = 4) -> str:
    """A message with SI quantities (``slip = 6.88e-05 m, force = 0.01267863 N``) put into
    display units with ``significant`` digits (``slip = 68.8 µm, force = 12.68 mN``).

    Examples
    --------
    >>> display_text("at t = 275.6589 s, slip = 2.090228e-05 m, force = 0.01378295 N")
    'at t = 275.7 s, slip = 20.90 µm, force = 13.78 mN'
    """

    def replace(match: re.Match[str]) -> str:
        scale, unit = _MESSAGE_UNITS[match["unit"]]
        return f"{format_number(float(match['value']), scale, significant)} {unit}"

    return _SI_QUANTITY.sub(replace, text)
