"""What the joint stage of :func:`granflow.analyze` finds: frozen values with ``to_dict`` and
``from_dict``.

:class:`Material` (the constants μ_a, μ_d, α as :class:`Estimate` values) and
:class:`Analyses` (the joint analyses, each a :class:`JointAnalysis` holding the fitting
result, and the comparisons of the stress-controlled runs with the model, from
:mod:`granflow.analysis.prediction_results`). ``to_dict()`` gives the ``material`` and
``analyses`` entries of ``results.json``; ``from_dict`` inverts it, the fitting results
through their own ``from_dict``; equality compares ``to_dict()``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from granflow._json import json_safe
from granflow.analysis.prediction_results import (
    CreepComparison,
    RampComparison,
    SwitchComparison,
)
from granflow.analysis.values import FieldValue, Value, as_json, frozen_json
from granflow.fitting.compare import ModelComparison
from granflow.fitting.joint import (
    AmontonsResult,
    CollapseResult,
    JointFitResult,
    PreparationSpread,
)
from granflow.fitting.mcmc import PosteriorResult
from granflow.fitting.results import FrozenMap

if TYPE_CHECKING:
    from granflow.model.params import MaterialConstants

__all__ = [
    "MATERIAL_CONSTANTS",
    "RESULT_TYPES",
    "Analyses",
    "Estimate",
    "FitJudgement",
    "GoodnessOfFit",
    "JointAnalysis",
    "Material",
]

#: The material constants, in the order they are listed.
MATERIAL_CONSTANTS = ("mu_a", "mu_d", "alpha")


# --------------------------------------------------------------------------- material


@dataclass(frozen=True, eq=False)
class Estimate(FieldValue):
    """A value with its standard error and 95 % interval (None where not determined).

    Attributes
    ----------
    value, stderr : float or None
        [SI]
    ci95 : (float or None, float or None)
    """

    value: float | None = None
    stderr: float | None = None
    ci95: tuple[float | None, float | None] = (None, None)

    def __str__(self) -> str:
        """``value ± stderr`` with the digits the error justifies."""
        from granflow._format import format_value_error

        return format_value_error(self.value, self.stderr)


@dataclass(frozen=True, eq=False)
class Material(Value, Mapping):
    """The material constants of Amontons' law: a = μ_a F_N, F_d = μ_d F_N, α.

    Also reads as the mapping ``results.json`` holds (``material["alpha"]["value"]``).

    Attributes
    ----------
    mu_a, mu_d : Estimate
        Dimensionless.
    alpha : Estimate
        [1/m]
    source : str or None
        The analysis they come from (None when not determined).
    reason : str or None
        Why they were not determined.
    runs : int or None
        Start-up runs fitted (None when not determined).
    normal_loads : tuple of float or None
        Their loads [N].
    velocity : float or None
        Their velocity [m/s].
    """

    mu_a: Estimate = field(default_factory=Estimate)
    mu_d: Estimate = field(default_factory=Estimate)
    alpha: Estimate = field(default_factory=Estimate)
    source: str | None = None
    reason: str | None = None
    runs: int | None = None
    normal_loads: tuple | None = None
    velocity: float | None = None

    @property
    def determined(self) -> bool:
        """Whether the constants have values."""
        return self.mu_a.value is not None

    @property
    def constants(self) -> MaterialConstants | None:
        """The best values as a :class:`granflow.MaterialConstants` (None when not
        determined): ``material.constants.params_at(normal_load, x0)`` gives the model at a
        load."""
        from granflow.model.params import MaterialConstants

        if not self.determined:
            return None
        return MaterialConstants(**{name: getattr(self, name).value for name in MATERIAL_CONSTANTS})

    def _repr_html_(self) -> str:
        """The constants with their errors and intervals as an HTML table (Jupyter)."""
        from granflow._format import format_interval
        from granflow._html import result_html, table
        from granflow.model.units import display_unit

        if not self.determined:
            return result_html("Material constants: not determined", [str(self.reason)])
        rows = [
            (
                name,
                str(getattr(self, name)),
                format_interval(getattr(self, name).ci95),
                display_unit(name) or "—",
            )
            for name in MATERIAL_CONSTANTS
        ]
        header = ("constant", "value ± standard error", "95 % interval", "unit")
        return result_html(f"Material constants ({self.source})", [table(rows, header=header)])

    def to_dict(self) -> dict[str, Any]:
        """The ``material`` entry of ``results.json``."""
        out = {name: getattr(self, name).to_dict() for name in MATERIAL_CONSTANTS}
        out.update(source=self.source, reason=self.reason)
        if self.runs is not None:
            out.update(
                runs=self.runs, normal_loads=list(self.normal_loads or ()), velocity=self.velocity
            )
        return json_safe(out)

    @classmethod
    def from_dict(cls, saved: Mapping[str, Any]) -> Material:
        """The constants of :meth:`to_dict`."""
        loads = saved.get("normal_loads")
        return cls(
            **{name: Estimate.from_dict(saved[name]) for name in MATERIAL_CONSTANTS},
            source=saved.get("source"),
            reason=saved.get("reason"),
            runs=saved.get("runs"),
            normal_loads=None if loads is None else tuple(loads),
            velocity=saved.get("velocity"),
        )

    def __getitem__(self, key):
        return self.to_dict()[key]

    def __iter__(self):
        return iter(self.to_dict())

    def __len__(self):
        return len(self.to_dict())


# --------------------------------------------------------------------------- joint analyses


#: Keys of a joint analysis' entry that say where it applies (the rest is the fit result).
_CONDITIONS = ("normal_load", "velocity", "preparation", "run", "runs", "held")


@dataclass(frozen=True, eq=False)
class JointAnalysis(Value):
    """One analysis across runs: where it applies, which runs, and the fitting result.

    Attributes
    ----------
    conditions : mapping
        ``normal_load`` [N], ``velocity`` [m/s], ``preparation`` (the preparation state),
        and ``runs`` (names) or ``run`` (one name), as far as they apply; a preparation
        spread adds ``held``: the joint fit of its repeats with a, α and F_d held common
        (``a``, ``alpha``, ``Fd`` as [value, stderr]; ``x0`` and ``x0_stderr`` per repeat [m];
        ``x0_spread``: mean, std, relative, min, max; ``redchi``, ``success``).
    result : object
        The fitting result (:class:`granflow.CollapseResult`, :class:`granflow.AmontonsResult`,
        :class:`granflow.JointFitResult`, :class:`granflow.PreparationSpread`,
        :class:`granflow.ModelComparison`, :class:`granflow.PosteriorResult`), or its
        ``to_dict()`` mapping when rebuilt without its type.
    """

    conditions: FrozenMap
    result: object

    def to_dict(self):
        """``{**conditions, **result.to_dict(include_arrays=False)}``: the result's compact
        form, without per-point arrays or chains."""
        return json_safe({**self.conditions, **as_json(self.result, include_arrays=False)})

    @classmethod
    def from_dict(cls, saved, result_type=None):
        """The analysis of :meth:`to_dict`; its result rebuilt by ``result_type.from_dict``
        (kept as a mapping without a type)."""
        conditions = {k: saved[k] for k in _CONDITIONS if k in saved}
        result = {k: v for k, v in saved.items() if k not in _CONDITIONS}
        result = frozen_json(result) if result_type is None else result_type.from_dict(result)
        return cls(conditions=FrozenMap(conditions), result=result)


# --------------------------------------------------------------------------- goodness of fit


@dataclass(frozen=True, eq=False)
class FitJudgement(FieldValue):
    """One Eq. 3 fit against the noise of its own plateau.

    Attributes
    ----------
    noise : float
        The force noise σ of the plateau [N] (NaN where the fit's sigma was known).
    chi2 : float
        The normalised χ²: the fit's χ² per degree of freedom over σ² [-].
    """

    noise: float
    chi2: float


@dataclass(frozen=True, eq=False)
class GoodnessOfFit(FieldValue):
    """Every Eq. 3 fit of the campaign (start-ups and the rate-controlled part of switches)
    against the noise of its own plateau (:func:`granflow.analysis.joint.goodness_of_fit`).

    Attributes
    ----------
    runs : mapping of str to FitJudgement
        By run name.
    median, min, max : float
        Of the normalised χ² [-].
    limit : float
        Above it a fit misses its curve [-].
    poor : tuple of str
        The runs above the limit.
    method : str
        How the noise and the χ² were found.
    """

    runs: Mapping[str, FitJudgement]
    median: float
    min: float
    max: float
    limit: float
    poor: tuple[str, ...] = ()
    method: str = ""


# --------------------------------------------------------------------------- the analyses


#: The fitting result type of each joint analysis.
RESULT_TYPES = {
    "velocity_collapse": CollapseResult,
    "amontons": AmontonsResult,
    "joint_fit": JointFitResult,
    "preparation_spread": PreparationSpread,
    "model_comparison": ModelComparison,
    "mcmc": PosteriorResult,
}
_ROWS = {"stress_ramp": RampComparison, "creep": CreepComparison, "switch": SwitchComparison}
#: The order of the entries of ``analyses`` in ``results.json``.
_ORDER = (
    "velocity_collapse",
    "amontons",
    "joint_fit",
    "preparation_spread",
    "model_comparison",
    "mcmc",
    "stress_ramp",
    "creep",
    "switch",
    "stability_map",
    "goodness_of_fit",
)


@dataclass(frozen=True, eq=False)
class Analyses(Value):
    """The joint analyses of a campaign and the comparisons of its stress-controlled runs.

    Attributes
    ----------
    velocity_collapse, amontons, joint_fit, model_comparison, mcmc : JointAnalysis or None
        None where the campaign does not allow it (or it failed: see ``errors``).
    preparation_spread : tuple of JointAnalysis
        One per group of repeats.
    stress_ramp : tuple of RampComparison
    creep : tuple of CreepComparison
    switch : tuple of SwitchComparison
    goodness_of_fit : GoodnessOfFit or None
        Each Eq. 3 fit against the noise of its plateau
        (:func:`granflow.analysis.joint.goodness_of_fit`).
    errors : mapping of str to str
        Analyses that failed, and why.
    """

    velocity_collapse: JointAnalysis | None = None
    amontons: JointAnalysis | None = None
    joint_fit: JointAnalysis | None = None
    preparation_spread: tuple = ()
    model_comparison: JointAnalysis | None = None
    mcmc: JointAnalysis | None = None
    stress_ramp: tuple = ()
    creep: tuple = ()
    switch: tuple = ()
    goodness_of_fit: GoodnessOfFit | None = None
    errors: FrozenMap = field(default_factory=FrozenMap)

    def to_dict(self):
        """The ``analyses`` entry of ``results.json``: what the campaign allowed, a failed
        analysis as ``{"error": reason}``."""
        out = {}
        for name in _ORDER:
            value = getattr(self, name, None)
            if isinstance(value, tuple) and value:
                out[name] = [row.to_dict() for row in value]
            elif value is not None and not isinstance(value, tuple):
                out[name] = value.to_dict()
            elif name in self.errors:
                out[name] = {"error": self.errors[name]}
        return out

    @classmethod
    def from_dict(cls, saved):
        """The analyses of :meth:`to_dict`."""
        values, errors = {}, {}
        for name, entry in saved.items():
            if isinstance(entry, Mapping) and set(entry) == {"error"}:
                errors[name] = entry["error"]
            elif name == "goodness_of_fit":
                values[name] = GoodnessOfFit.from_dict(entry)
            elif name == "preparation_spread":
                values[name] = tuple(
                    JointAnalysis.from_dict(row, PreparationSpread) for row in entry
                )
            elif name in _ROWS:
                values[name] = tuple(_ROWS[name].from_dict(row) for row in entry)
            elif name in RESULT_TYPES:
                values[name] = JointAnalysis.from_dict(entry, RESULT_TYPES[name])
        return cls(**values, errors=FrozenMap(errors))
