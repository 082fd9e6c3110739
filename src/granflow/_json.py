"""Turning results into JSON-safe values: one rule for every ``to_dict()``."""

import math
from collections.abc import Mapping

import numpy as np

_PLAIN = (bool, int, str, type(None))


def json_safe(value):
    """``value`` with mappings as dicts, sequences and arrays as lists, NumPy scalars as Python
    numbers, NaN and infinities as None, and anything else unknown as its ``str``."""
    kind = type(value)
    if kind is float:  # the common cases first, by exact type (results hold many floats)
        return value if value - value == 0.0 else None
    if kind is dict:
        return {key if type(key) is str else str(key): _item(item) for key, item in value.items()}
    if kind is list or kind is tuple:
        return [_item(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, _PLAIN):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(key): json_safe(item) for key, item in value.items()}
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "biu":
            return value.tolist()
        if value.dtype.kind == "f" and value.ndim == 1 and np.isfinite(value).all():
            return value.tolist()
        return [json_safe(item) for item in value]
    if isinstance(value, list | tuple):
        return [json_safe(item) for item in value]
    return str(value)


def _item(item):
    """:func:`json_safe` of one member, a finite float or a str without the call."""
    kind = type(item)
    if (kind is float and item - item == 0.0) or kind is str:
        return item
    return json_safe(item)
