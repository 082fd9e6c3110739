"""What every fit result shares: read-only mappings, equality by value, and the JSON codec.

Results are frozen dataclasses whose fields are numbers, strings, tuples, read-only
:class:`FrozenMap` mappings, NumPy arrays and other results. :class:`ValueEquality` gives them
an ``__eq__`` that compares arrays by value (NaN equal to NaN); :func:`encode` turns the mapping
a ``to_dict()`` builds into JSON-safe values and records where it held an infinity (JSON has
none), and the ``decode_*`` helpers turn the pieces back for ``from_dict``. Floats survive
``json.dumps``/``json.loads`` exactly (Python writes the shortest repr that reads back).
These pieces, and :class:`Codec` (``to_dict``/``from_dict`` derived from the fields), live in
:mod:`granflow._codec`, where every layer reaches them; they are re-exported here.

Every ``to_dict`` takes ``include_arrays``: True (the default) gives the complete result, which
``from_dict`` turns back into an equal one; False gives the compact form, without the per-point
arrays a result type names in its ``ARRAYS`` (nor those of the results it holds), which
``from_dict`` rebuilds with empty arrays. :func:`arrays` and :func:`read_arrays` are that codec.
"""

from granflow._codec import (
    NONFINITE,
    Codec,
    FrozenMap,
    ValueEquality,
    decode,
    encode,
    number,
    read_only,
    same,
)

__all__ = [
    "NONFINITE",
    "Codec",
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


def numbers(mapping):
    """A FrozenMap of floats (null as NaN)."""
    return FrozenMap({key: number(value) for key, value in mapping.items()})


def intervals(mapping):
    """A FrozenMap of (low, high) float pairs."""
    return FrozenMap({key: tuple(number(v) for v in pair) for key, pair in mapping.items()})


def matrix(mapping):
    """A FrozenMap of FrozenMaps of floats (covariance, correlation by name)."""
    return FrozenMap({key: numbers(row) for key, row in mapping.items()})


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
