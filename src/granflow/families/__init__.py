"""The model families granflow knows, and the seam through which they plug in.

This package is the one place that names the model families. Each module here (not
starting with ``_``) is one family and defines a module-level ``FAMILY``, a
:class:`Family`; :func:`families` finds them with :func:`pkgutil.iter_modules`, so adding a
family is adding one module here, and no generic module is edited. A family module holds
names and ``"module:attribute"`` strings only (resolved on first use by :func:`resolve`), so
it imports nothing heavy and closes no import circle; this package imports nothing of
granflow but :mod:`granflow.errors`.

**What a family declares** (:class:`Family`): its ``name``, its fit ``result_types``, the
comparison rows it adds to :func:`granflow.compare_models` (``compare``), and, for a family
with records of its own in a campaign, the manifest's ``test_kind``, how to find those
entries (``entries``), how to analyse them (``analyse``, run on a worker), the class that
holds the analysis (``results``) and the report section that shows it (``section``).

**What its fit result implements** (:class:`FamilyFit`, a runtime-checkable protocol):

``log_likelihood()``
    A :class:`Likelihood`: the free parameters' names, least-squares values, standard
    errors and default priors, and the log-likelihood at their natural values, rebuilt from
    the result's own stored data and options (not from a model kept in the session), so a
    result read back with ``from_dict(to_dict())`` can be sampled.
    :func:`granflow.sample_posterior` samples any such result with one emcee path.
``comparison_row()``
    Its row of a model comparison: ``model``, ``formula``, ``nfree``, ``chisqr``, ``aic``,
    ``bic``, ``success``, ``message``.
``plot()``
    Its figure, drawn by :mod:`granflow.plotting`.
``to_dict()``
    JSON-safe, with ``"family"`` (its family's name, :func:`family_of`), from which
    :meth:`granflow.ModelComparison.from_dict` finds the class (:func:`result_type`).

The generic modules (``fitting/compare``, ``fitting/mcmc``, ``analysis/engine``, the report)
name no family: they go through the functions below.

Examples
--------
>>> from granflow import families
>>> sorted(f.name for f in families.families())[:3]
['creep', 'eq3', 'rate_state']
>>> families.result_type("eq3").__name__
'FitResult'
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from typing import Any

from granflow.errors import InvalidParameterError
from granflow.families._seam import Family, FamilyFit, Likelihood

__all__ = [
    "Family",
    "FamilyFit",
    "Likelihood",
    "families",
    "family",
    "family_of",
    "record_families",
    "resolve",
    "result_type",
    "result_type_of_model",
]


def families() -> tuple[Family, ...]:
    """Every family: the ``FAMILY`` of each module of this package, sorted by name.

    Raises
    ------
    granflow.InvalidParameterError
        A family module without a :class:`Family` named ``FAMILY``, or two families of one name.
    """
    found: dict[str, Family] = {}
    for info in pkgutil.iter_modules(__path__):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        declared = getattr(module, "FAMILY", None)
        if not isinstance(declared, Family):
            raise InvalidParameterError(
                f"family module {module.__name__} must define FAMILY, a granflow.families.Family"
            )
        if declared.name in found:
            raise InvalidParameterError(f"two families are named {declared.name!r}")
        found[declared.name] = declared
    return tuple(found[name] for name in sorted(found))


def family(name: str) -> Family:
    """The family called ``name``."""
    for candidate in families():
        if candidate.name == name:
            return candidate
    known = ", ".join(f.name for f in families())
    raise InvalidParameterError(f"no model family is called {name!r}; known: {known}")


def record_families() -> tuple[Family, ...]:
    """The families with records of their own in a campaign (a manifest ``test_kind``)."""
    return tuple(f for f in families() if f.test_kind is not None)


def resolve(reference: str) -> Any:
    """The object a ``"module:attribute"`` reference names (the module imported now)."""
    module, _, attribute = reference.partition(":")
    if not module or not attribute:
        raise InvalidParameterError(f"a reference reads 'module:attribute', got {reference!r}")
    target: Any = importlib.import_module(module)
    for part in attribute.split("."):
        target = getattr(target, part)
    return target


def result_type(name: str) -> type:
    """The result class a stored ``"family"`` key names: the family's first result type,
    or, for ``"family/ClassName"``, that one of its result types."""
    family_name, _, class_name = name.partition("/")
    references = family(family_name).result_types
    for reference in references:
        if not class_name or reference.rpartition(":")[2].rpartition(".")[2] == class_name:
            return resolve(reference)
    raise InvalidParameterError(f"family {family_name!r} has no result type {class_name!r}")


def result_type_of_model(model: str) -> type | None:
    """The result class of a comparison's model name, from the families' ``models`` (for
    comparisons written before results stored their family); None when no family has it."""
    for candidate in families():
        if model in candidate.models:
            return resolve(candidate.result_types[0])
    return None


@functools.cache
def _type_index(state: tuple[str, ...]) -> dict[str, str]:
    """``"module:Class"`` -> family name, for the family modules named in ``state``."""
    return {reference: f.name for f in families() for reference in f.result_types}


def family_of(result: Any) -> str:
    """The name of the family whose result types hold ``type(result)``."""
    kind = type(result)
    reference = f"{kind.__module__}:{kind.__qualname__}"
    state = tuple(info.name for info in pkgutil.iter_modules(__path__))
    index = _type_index(state)
    if reference not in index:
        raise InvalidParameterError(f"{kind.__name__} belongs to no model family")
    return index[reference]
