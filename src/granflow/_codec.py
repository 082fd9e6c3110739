"""One codec for the frozen results: JSON from a dataclass's fields and back, and one rule of
equality by value.

A result whose JSON is its fields and nothing else inherits :class:`Codec`: ``to_dict()``
writes each field under its name, in the order of the fields, and ``from_dict()`` reads each
back by the field's annotated type:

==========================  ==================================================================
annotation                  JSON
==========================  ==================================================================
``float``                   a number; NaN as null (read back as NaN); an infinity as null,
                            its place listed under ``"nonfinite"`` (:func:`encode`)
``int``, ``bool``, ``str``  themselves
``X | None``                null for None, else as ``X``
``tuple[X, ...]``           a list of ``X`` (a bare ``tuple``: a list, its items as they are)
``Mapping[str, X]``         an object of ``X`` (read back as a :class:`FrozenMap`; a bare
                            ``FrozenMap``: its values as they are)
``numpy.ndarray``           a list of numbers (read back read-only); the per-point arrays a
                            type names in ``ARRAYS`` are left out of the compact form
                            (``include_arrays=False``) and read back empty
a result type               its own ``to_dict()`` (read back with its ``from_dict``)
==========================  ==================================================================

A type adds constant keys after its fields with ``JSON_EXTRA`` (a run's ``"status": "ok"``),
picks the default of ``include_arrays`` with ``INCLUDE_ARRAYS``, and with ``KEEP_INFINITIES =
False`` writes infinities as plain nulls (the rule of :func:`granflow._json.json_safe`).
A result that stores something other than its fields (a flattened mapping, keys left out
when empty, a legacy name) keeps a hand-written ``to_dict``/``from_dict`` built from the same
pieces (:func:`encode`, :func:`decode`, :func:`number`, :func:`read_only`).

:class:`ValueEquality` is the one ``==`` of the results: field by field with :func:`same`
(arrays by value, NaN equal to NaN), or by their ``to_dict()`` for a type whose JSON is what
it is (``EQUAL_BY_JSON``: the analysis results, equal when their compact JSON is).
"""

import copy
import dataclasses
import functools
import inspect
import math
import sys
import types
import typing
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from granflow._json import json_safe
from granflow.errors import InvalidParameterError

__all__ = [
    "NONFINITE",
    "Codec",
    "FrozenMap",
    "ValueEquality",
    "decode",
    "encode",
    "from_fields",
    "number",
    "read_only",
    "same",
    "to_fields",
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
    """Mixin for frozen result dataclasses (declared with ``eq=False``): ``==`` compares every
    field with :func:`same`, or, where the type sets ``EQUAL_BY_JSON``, the two ``to_dict()``.
    Results are equal by value, so unhashable."""

    __slots__ = ()
    __hash__ = None  # type: ignore[assignment]  # mutable by value: unhashable

    #: Compare ``to_dict()`` rather than the fields (a result whose JSON is what it is).
    EQUAL_BY_JSON: ClassVar[bool] = False

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        if self.EQUAL_BY_JSON:
            return same(self.to_dict(), other.to_dict())
        return all(
            same(getattr(self, f.name), getattr(other, f.name))
            for f in dataclasses.fields(self)
            if f.compare
        )


# --------------------------------------------------------------------------- the pieces


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
    null; :func:`number` reads them as NaN)."""
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


def read_only(values):
    """A read-only float array (from a list with nulls as NaN, or an array)."""
    array = np.array(values, dtype=np.float64)
    array.flags.writeable = False
    return array


# --------------------------------------------------------------------------- fields to JSON


@functools.cache
def _takes_arrays(cls):
    """Whether ``cls.to_dict`` takes ``include_arrays``."""
    return "include_arrays" in inspect.signature(cls.to_dict).parameters


def _plain(value, include_arrays):
    """A field's value with its results as their ``to_dict()``, its mappings as dicts and its
    tuples as lists (numbers, strings and arrays are left to :func:`encode`)."""
    if hasattr(value, "to_dict") and not isinstance(value, type):
        if _takes_arrays(type(value)):
            return value.to_dict(include_arrays=include_arrays)
        return value.to_dict()
    if isinstance(value, Mapping):
        return {key: _plain(item, include_arrays) for key, item in value.items()}
    if isinstance(value, tuple | list):
        return [_plain(item, include_arrays) for item in value]
    return value


def to_fields(result, include_arrays=None):
    """The JSON-safe mapping of a dataclass ``result``: each field under its name (the table
    of :mod:`granflow._codec`), then the type's ``JSON_EXTRA``."""
    cls = type(result)
    if include_arrays is None:
        include_arrays = getattr(cls, "INCLUDE_ARRAYS", True)
    left_out = () if include_arrays else getattr(cls, "ARRAYS", ())
    out = {
        item.name: _plain(getattr(result, item.name), include_arrays)
        for item in dataclasses.fields(result)
        if item.name not in left_out
    }
    out.update(getattr(cls, "JSON_EXTRA", {}))
    return encode(out) if getattr(cls, "KEEP_INFINITIES", True) else json_safe(out)


# --------------------------------------------------------------------------- JSON to fields


@functools.cache
def _field_types(cls):
    """{field name: its annotation, evaluated} of a dataclass (string annotations evaluated
    in the class's module, as ``typing.get_type_hints`` does, one field at a time so that a
    name imported for type checkers only fails on its own field)."""
    namespace = {**vars(sys.modules[cls.__module__]), "np": np, "FrozenMap": FrozenMap}
    found = {}
    for item in dataclasses.fields(cls):
        annotation = item.type
        if isinstance(annotation, str):
            try:
                annotation = eval(annotation, namespace)  # the class's own annotation
            except NameError as exc:
                raise TypeError(
                    f"{cls.__name__}.{item.name}: the codec cannot resolve its annotation "
                    f"{item.type!r} ({exc}); import the type at module level"
                ) from None
        found[item.name] = annotation
    return found


def _read(annotation, value):
    """``value`` from JSON as a field annotated ``annotation``."""
    origin = typing.get_origin(annotation)
    arguments = typing.get_args(annotation)
    if origin is typing.Union or origin is types.UnionType:
        if value is None and type(None) in arguments:
            return None
        others = [argument for argument in arguments if argument is not type(None)]
        return _read(others[0], value) if len(others) == 1 else value
    if annotation is float:
        return number(value)
    if annotation is int or annotation is bool:
        return annotation(value)
    if annotation is np.ndarray:
        return read_only(value)
    if annotation is tuple or origin is tuple:
        if len(arguments) == 2 and arguments[1] is Ellipsis:
            return tuple(_read(arguments[0], item) for item in value)
        if arguments:
            return tuple(_read(kind, item) for kind, item in zip(arguments, value, strict=True))
        return tuple(value)
    if annotation is FrozenMap:
        return FrozenMap(value)
    if origin is Mapping or origin is dict:
        return FrozenMap({key: _read(arguments[1], item) for key, item in value.items()})
    if isinstance(annotation, type) and hasattr(annotation, "from_dict"):
        return annotation.from_dict(value)
    return value


def from_fields(cls, d):
    """A ``cls`` from its :func:`to_fields` mapping ``d``: each field read by its annotated
    type; a field missing from ``d`` takes its default (a per-point array in ``ARRAYS``: an
    empty one); keys that are not fields are ignored."""
    d = decode(d, cls)
    annotations = _field_types(cls)
    values: dict[str, Any] = {}
    for item in dataclasses.fields(cls):
        if not item.init:
            continue
        if item.name in d:
            values[item.name] = _read(annotations[item.name], d[item.name])
        elif item.name in getattr(cls, "ARRAYS", ()):
            values[item.name] = read_only([])
        elif item.default is dataclasses.MISSING and item.default_factory is dataclasses.MISSING:
            raise InvalidParameterError(
                f"{cls.__name__}.from_dict: the mapping has no {item.name!r} (a to_dict() "
                f"output has every field)"
            )
    return cls(**values)


class Codec(ValueEquality):
    """Mixin for frozen result dataclasses whose JSON is their fields: :meth:`to_dict` and
    :meth:`from_dict` from the fields' annotations (see :mod:`granflow._codec`), ``==`` by
    value (:class:`ValueEquality`)."""

    __slots__ = ()

    #: Per-point arrays, left out of the compact form.
    ARRAYS: ClassVar[tuple[str, ...]] = ()
    #: The default of ``to_dict``'s ``include_arrays``.
    INCLUDE_ARRAYS: ClassVar[bool] = True
    #: Constant keys written after the fields.
    JSON_EXTRA: ClassVar[Mapping[str, Any]] = {}
    #: Whether infinities are restored (listed under ``"nonfinite"``) or written as null.
    KEEP_INFINITIES: ClassVar[bool] = True

    def to_dict(self, include_arrays: bool | None = None) -> dict[str, Any]:
        """JSON-safe mapping of the fields (SI units); ``include_arrays=False``: the compact
        form, without the per-point arrays."""
        return to_fields(self, include_arrays)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Any:
        """The result of :meth:`to_dict`."""
        return from_fields(cls, d)
