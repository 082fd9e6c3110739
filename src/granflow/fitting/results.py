"""What every fit result shares: read-only mappings, equality by value, and the JSON codec.

Results are frozen dataclasses whose fields are numbers, strings, tuples, read-only
:class:`FrozenMap` mappings, NumPy arrays and other results. :class:`ValueEquality` gives them
an ``__eq__`` that compares arrays by value (NaN equal to NaN); :func:`encode` turns the mapping
a ``to_dict()`` builds into JSON-safe values and records where it held an infinity (JSON has
none), and the ``decode_*`` helpers turn the pieces back for ``from_dict``. Floats survive
``json.dumps``/``json.loads`` exactly (Python writes the shortest repr that reads back).

Every ``to_dict`` takes ``include_arrays``: True (the default) gives the complete result, which
``from_dict`` turns back into an equal one; False gives the compact form, without the per-point
arrays a result type names in its ``ARRAYS`` (nor those of the results it holds), which
``from_dict`` rebuilds with empty arrays. :func:`arrays` and :func:`read_arrays` are that codec.
"""

import copy
import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from granflow._json import json_safe
from granflow.errors import InvalidParameterError

__all__ = [
    "FrozenMap",
    "ValueEquality",
    "arrays",
    "decode",
    "encode",
    "intervals",
    "matrix",
    "number",
    "numbers",
    "read_arrays",
    "read_only",
    "same",
]

#: Key of a ``to_dict()`` that lists the infinite values JSON wrote as null.
NONFINITE = "nonfinite"


class FrozenMap(Mapping):
    """A read-only mapping that, unlike ``types.MappingProxyType``, can be pickled (results
    travel between processes in batch fits)."""

    __slots__ = ("_data",)

    def __init__(self, data=()):
        object.__setattr__(self, "_data", dict(data))

    def __getitem__(self, key):
        return self._data[key]

    def __iter__(self):
        return iter(self._data)

    def __len__(self):
        return len(self._data)

    def __repr__(self):
        return f"FrozenMap({self._data!r})"

    def __reduce__(self):
        return (FrozenMap, (self._data,))


def same(first, second):
    """Whether two result values are equal by value: arrays element-wise, NaN equal to NaN,
    mappings key by key (in any order), sequences item by item, results field by field."""
    if isinstance(first, np.ndarray) or isinstance(second, np.ndarray):
        first, second = np.asarray(first), np.asarray(second)
        return first.shape == second.shape and bool(np.array_equal(first, second, equal_nan=True))
    if isinstance(first, Mapping) and isinstance(second, Mapping):
        return first.keys() == second.keys() and all(same(first[k], second[k]) for k in first)
    if isinstance(first, tuple | list) and isinstance(second, tuple | list):
        return len(first) == len(second) and all(
            same(a, b) for a, b in zip(first, second, strict=True)
        )
    if isinstance(first, float) and isinstance(second, float):
        return first == second or (math.isnan(first) and math.isnan(second))
    return bool(first == second)


class ValueEquality:
    """Mixin for frozen result dataclasses: ``==`` compares every field with :func:`same`."""

    __hash__ = None  # type: ignore[assignment]  # mutable by value: unhashable

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        return all(
            same(getattr(self, f.name), getattr(other, f.name)) for f in dataclasses.fields(self)
        )


def _infinities(value, path):
    """(path, "inf" or "-inf") for every infinite float inside ``value``."""
    if isinstance(value, float | np.floating):
        if math.isinf(value):
            yield path, "inf" if value > 0 else "-inf"
    elif isinstance(value, np.ndarray):
        if value.dtype.kind == "f":
            for index in zip(*np.nonzero(np.isinf(value)), strict=True):
                yield [*path, *(int(i) for i in index)], "inf" if value[index] > 0 else "-inf"
    elif isinstance(value, Mapping):
        for key, item in value.items():
            yield from _infinities(item, [*path, str(key)])
    elif isinstance(value, list | tuple):
        for index, item in enumerate(value):
            yield from _infinities(item, [*path, index])


def encode(mapping):
    """``mapping`` made JSON-safe (:func:`granflow._json.json_safe`: NaN and infinities become
    null); where it held infinities, the key ``"nonfinite"`` lists ``[path, "inf"|"-inf"]`` so
    that :func:`decode` restores them."""
    found = [[path, sign] for path, sign in _infinities(mapping, [])]
    out = json_safe(mapping)
    if found:
        out[NONFINITE] = found
    return out


def decode(d, cls):
    """A copy of ``to_dict()`` output ``d`` with its infinities put back (nulls elsewhere stay
    null; the ``decode_*`` helpers read them as NaN)."""
    if not isinstance(d, Mapping):
        raise InvalidParameterError(
            f"{cls.__name__}.from_dict needs a mapping (a to_dict() output), got {type(d).__name__}"
        )
    found = d.get(NONFINITE)
    if not found:
        return d
    d = copy.deepcopy(dict(d))
    for path, sign in found:
        target = d
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = float(sign)
    return d


def number(value):
    """A float from JSON: null is NaN."""
    return math.nan if value is None else float(value)


def numbers(mapping):
    """A FrozenMap of floats (null as NaN)."""
    return FrozenMap({key: number(value) for key, value in mapping.items()})


def intervals(mapping):
    """A FrozenMap of (low, high) float pairs."""
    return FrozenMap({key: tuple(number(v) for v in pair) for key, pair in mapping.items()})


def matrix(mapping):
    """A FrozenMap of FrozenMaps of floats (covariance, correlation by name)."""
    return FrozenMap({key: numbers(row) for key, row in mapping.items()})


def read_only(values):
    """A read-only float array (from a list with nulls as NaN, or an array)."""
    array = np.array(values, dtype=np.float64)
    array.flags.writeable = False
    return array


def arrays(result, include_arrays):
    """The per-point arrays of ``result`` by name (those its type lists in ``ARRAYS``) for a
    complete ``to_dict()``; none for the compact form (``include_arrays=False``)."""
    if not include_arrays:
        return {}
    return {key: getattr(result, key) for key in type(result).ARRAYS}


def read_arrays(cls, d):
    """The per-point arrays of a ``cls`` from its ``to_dict()`` output ``d``: read-only float
    arrays, empty where the compact form left them out."""
    return {key: read_only(d.get(key, [])) for key in cls.ARRAYS}
