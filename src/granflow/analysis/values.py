"""What the frozen result types of :mod:`granflow.analysis` share.

:class:`Value` gives them equality by content (their ``to_dict()``), :class:`FieldValue` the
one codec of :mod:`granflow._codec` too; :func:`as_json` and
:func:`frozen_json` move between fitting results, their JSON and read-only JSON.
"""

from collections.abc import Mapping

from granflow._codec import Codec, FrozenMap, ValueEquality

__all__ = ["FieldValue", "Value", "as_json", "frozen_json"]


class Value(ValueEquality):
    """Base of the frozen results: two are equal when they are of one type and their
    ``to_dict()`` are equal (so a result rebuilt by ``from_dict`` equals the original).
    The one equality of :mod:`granflow._codec`."""

    __slots__ = ()

    EQUAL_BY_JSON = True


class FieldValue(Value, Codec):
    """A :class:`Value` whose JSON is its fields: ``to_dict``/``from_dict`` by the one codec
    of :mod:`granflow._codec`, with the analysis's JSON rule: the compact form by default
    (``results.json`` holds the fits without their arrays), NaN and infinities as null."""

    __slots__ = ()

    INCLUDE_ARRAYS = False
    KEEP_INFINITIES = False


def as_json(result, **options):
    """The JSON of a result: ``result.to_dict(**options)``, or ``result`` itself as a dict when
    it is already a mapping (a result rebuilt from JSON).

    ``include_arrays=False`` in ``options`` gives a fitting result's compact form (without its
    per-point arrays), the form ``results.json`` holds.
    """
    return dict(result.to_dict(**options)) if hasattr(result, "to_dict") else dict(result)


def frozen_json(value, sequence=list):
    """JSON with its mappings as :class:`FrozenMap` and its lists as ``sequence``."""
    if isinstance(value, Mapping):
        return FrozenMap({key: frozen_json(item, sequence) for key, item in value.items()})
    if isinstance(value, list | tuple):
        return sequence(frozen_json(item, sequence) for item in value)
    return value
