"""What a model family declares (:class:`Family`), what its fit result implements
(:class:`FamilyFit`) and what that result's log-likelihood is (:class:`Likelihood`).

The reference description of the seam is the docstring of :mod:`granflow.families`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    from granflow._typing import FloatArray

__all__ = ["Family", "FamilyFit", "Likelihood"]


@dataclass(frozen=True)
class Family:
    """A model family as the generic machinery sees it: names and dotted references only.

    Every reference is a ``"module:attribute"`` string, imported when first used
    (:func:`granflow.families.resolve`), so that a family module imports nothing heavy and
    the registry closes no import circle.

    Attributes
    ----------
    name : str
        The family's name (``"eq3"``, ``"creep"``, ``"rate_state"``): the key its results
        store under ``"family"`` in ``to_dict()`` and the key of its campaign results.
    description : str
        One line on what the family models.
    result_types : tuple of str
        Its fit result classes, the first being the one a bare family name decodes to
        (:func:`granflow.families.result_type`).
    models : tuple of str
        The model names of :func:`granflow.compare_models` rows whose fit is this family's
        first result type (read back from files written before results stored their family).
    compare : mapping of str to str
        Rows this family adds to :func:`granflow.compare_models`, by the kind of data:
        ``"record"`` (a record with its load-point protocol: ``rows(t, friction, protocol,
        windows=, detrend=, correlated=) -> (rows, fits, correlation time)``) and
        ``"startup"`` (a start-up curve, with ``rate_and_state=True``: ``rows(z, y, domain=,
        velocity=) -> (rows, fits)``).
    test_kind : str or None
        The manifest's ``test:`` value of the records this family analyses in a campaign
        (``"velocity_steps"``); None for a family without records of its own.
    entries : str or None
        ``entries(manifest, allow_outside) -> list of dict`` (each with ``file``): the
        manifest's records of this family.
    analyse : str or None
        ``analyse(manifest, output, figures_dir, allow_outside) -> dict``: the campaign's
        analysis of those records, JSON-safe, run on a worker; ``{}`` without records,
        otherwise with ``records`` (each may name its ``figure``) and ``failed`` (``name``,
        ``source``, ``interval``, ``stage``, ``reason``).
    results : str or None
        The class that holds the analysis in an :class:`granflow.AnalysisResult`: its
        ``from_dict`` reads ``analyse``'s output (and its own ``to_dict``'s), it is true
        when it holds anything, it has ``failed`` (and ``records`` with ``figure``) and
        ``summary_lines()`` (its lines in :meth:`granflow.AnalysisResult.summary`).
    section : str or None
        ``section(result, figures) -> dict``: the family's part of the campaign report, from
        its ``results`` and ``figures(entries) -> views`` (the report's embedding of figure
        entries: ``name``, ``title``, ``caption``, ``png`` relative to the output folder),
        with ``id`` (the anchor), ``title`` (in the contents), ``template`` (this family's
        own template in ``granflow/analysis/templates``, a new file), ``view`` (what the
        template reads) and ``summary`` (the report summary's verdict, ``(status, text,
        link)``, or None).
    """

    name: str
    description: str
    result_types: tuple[str, ...]
    models: tuple[str, ...] = ()
    compare: Mapping[str, str] = field(default_factory=dict)
    test_kind: str | None = None
    entries: str | None = None
    analyse: str | None = None
    results: str | None = None
    section: str | None = None


@dataclass(frozen=True)
class Likelihood:
    """The log-likelihood of a fit's free parameters, rebuilt from the fit result itself.

    Attributes
    ----------
    names : tuple of str
        The free parameters, in the order ``function`` takes them.
    values, stderr : mapping of str to float
        Their least-squares values and standard errors [SI].
    priors : mapping of str to (str, float, float)
        Their default priors: ``("log-uniform" | "uniform", low, high)`` [SI].
    function : callable
        ``function(natural) -> float``: the log-likelihood (up to a constant) at the free
        parameters' natural values [SI] in the order of ``names``; ``-inf`` where the model
        cannot be evaluated.
    """

    names: tuple[str, ...]
    values: Mapping[str, float]
    stderr: Mapping[str, float]
    priors: Mapping[str, tuple[str, float, float]]
    function: Callable[[FloatArray], float]

    def __call__(self, natural: FloatArray) -> float:
        return self.function(natural)


@runtime_checkable
class FamilyFit(Protocol):
    """What a family's fit result implements to take part in the generic machinery.

    - :meth:`log_likelihood`: for :func:`granflow.sample_posterior` (and any other
      likelihood-based method), rebuilt from the result's stored data and options, so that
      ``type(f).from_dict(f.to_dict())`` can be sampled like ``f``;
    - :meth:`comparison_row`: its row of the :func:`granflow.compare_models` table;
    - :meth:`plot`: its figure, drawn by :mod:`granflow.plotting`;
    - :meth:`to_dict`: JSON-safe, with ``"family"`` (its family's name), so that a
      comparison read back finds its class through :func:`granflow.families.result_type`.
    """

    def log_likelihood(self) -> Likelihood:
        """The :class:`Likelihood` of the free parameters (raises
        :class:`granflow.InvalidParameterError` where the result lacks its data)."""
        ...

    def comparison_row(self) -> dict[str, Any]:
        """``model``, ``formula``, ``nfree``, ``chisqr``, ``aic``, ``bic``, ``success``,
        ``message`` (and whatever else the family reports)."""
        ...

    def plot(self, *args: Any, **kwargs: Any) -> Any:
        """The result's figure (through :mod:`granflow.plotting`)."""
        ...

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping, with ``"family"``."""
        ...
