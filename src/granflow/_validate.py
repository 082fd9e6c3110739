"""Checks at the door: every public function validates its input here and names the culprit.

Every check given a ``unit`` also accepts a string with a unit ("0.86 um/s") or a pint
quantity and converts it to that SI unit (:func:`granflow.model.units.as_si`); a bare number
is taken as already in SI units. A pure number (no unit) must be given as a number.
"""

from __future__ import annotations

import math
import numbers
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidParameterError

if TYPE_CHECKING:
    from granflow._typing import FloatArray


def _fmt_unit(unit):
    return f" {unit}" if unit else ""


def _si(value, name, unit):
    """``value`` converted by :func:`granflow.model.units.as_si` (pint loads on first use)."""
    from granflow.model.units import as_si

    return as_si(value, unit, name)


def _typed(value, unit):
    """Whether ``value`` is text or a pint quantity for a quantity with a ``unit`` (what
    :func:`_si` converts); a pure number (no unit) must be a number."""
    return bool(unit) and (
        isinstance(value, str) or type(value).__module__.partition(".")[0] == "pint"
    )


def real_scalar(value: Any, name: str, unit: str = "") -> float:
    """Return ``value`` as a finite float or raise InvalidParameterError naming ``name``.

    ``value`` may be a number in ``unit``, a string with a unit or a pint quantity.
    """
    if type(value) is float and math.isfinite(value):  # the common case, checked first
        return value
    if _typed(value, unit):
        value = _si(value, name, unit)
        if np.ndim(value) != 0:
            raise InvalidParameterError(f"{name} must be a single quantity, got an array")
    if isinstance(value, bool) or not isinstance(value, numbers.Real | np.floating | np.integer):
        if isinstance(value, np.ndarray) and value.ndim == 0:
            return real_scalar(value.item(), name, unit)
        in_unit = f" in {unit}" if unit else ""
        raise InvalidParameterError(f"{name} must be a real number{in_unit}, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise InvalidParameterError(f"{name} must be finite, got {number}{_fmt_unit(unit)}")
    return number


def positive(value: Any, name: str, unit: str = "") -> float:
    number = real_scalar(value, name, unit)
    if number <= 0:
        raise InvalidParameterError(f"{name} must be positive, got {number:g}{_fmt_unit(unit)}")
    return number


def non_negative(value: Any, name: str, unit: str = "") -> float:
    number = real_scalar(value, name, unit)
    if number < 0:
        raise InvalidParameterError(f"{name} must be non-negative, got {number:g}{_fmt_unit(unit)}")
    return number


def _converted_array(value, name, unit):
    """An array of strings or quantities (or one array quantity) converted to ``unit``."""
    if _typed(value, unit) or (unit and isinstance(value, list | tuple)):
        return _si(value, name, unit)
    return value


def float_array(value: Any, name: str, unit: str = "") -> FloatArray:
    """``value`` as a float64 array (no copy when it already is one; never modified here).

    ``value`` may also be a pint array quantity or a list of strings with units.
    """
    if not isinstance(value, np.ndarray):
        value = _converted_array(value, name, unit)
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(f"{name} must be an array of real numbers: {exc}") from None


def finite_at(number, index, shape, name, unit=""):
    """Raise InvalidParameterError if ``number`` (flat ``index`` of an array) is not finite."""
    if not np.isfinite(number):
        where = f" at index {index_text(np.unravel_index(index, shape))}" if len(shape) else ""
        raise InvalidParameterError(f"{name} must be finite, got {number}{_fmt_unit(unit)}{where}")


def index_text(index):
    """A numpy index tuple as plain ints: (3,) -> '3', (1, 2) -> '(1, 2)'."""
    index = tuple(int(i) for i in index)
    return str(index[0]) if len(index) == 1 else str(index)


def real_array(value: Any, name: str, unit: str = "") -> FloatArray:
    """Return ``value`` as a float64 array of finite numbers (a new array, never a view).

    ``value`` may also be a pint array quantity or a list of strings with units.
    """
    if not isinstance(value, np.ndarray):
        value = _converted_array(value, name, unit)
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(f"{name} must be an array of real numbers: {exc}") from None
    bad = ~np.isfinite(array)
    if bad.any():
        index = np.argwhere(bad)[0]
        where = f" at index {index_text(index)}" if array.ndim else ""
        raise InvalidParameterError(
            f"{name} must be finite, got {array[tuple(index)]}{_fmt_unit(unit)}{where}"
        )
    return array
