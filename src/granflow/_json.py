"""Turning results into JSON-safe values: one rule for every ``to_dict()``."""

import math
from collections.abc import Mapping

import numpy as np


def json_safe(value):
    """``value`` with mappings as dicts, sequences and arrays as lists, NumPy scalars as Python
    numbers, NaN and infinities as None, and anything else unknown as its ``str``."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool | int | str) or value is None:
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(key): json_safe(item) for key, item in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [json_safe(item) for item in value]
    return str(value)
