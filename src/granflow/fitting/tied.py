"""Joint fits of Eq. 3 over many runs with parameters tied by name (:func:`fit_joint`).

Runs share some parameters (``alpha``), keep others per run (``x0_3``) or per group
(``alpha_v1``). Every run is fitted alone first (no initial guess needed); those fits start
the joint fit, which the engine solves with a factor per tie (the Amontons fit of
:mod:`granflow.fitting.joint` uses the normal load as the factor of a and Fd).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import ConvergenceWarning, GranflowError, InvalidParameterError
from granflow.fitting.curves import prepare
from granflow.fitting.engine import EQ3, Curve, GlobalParameter, Problem
from granflow.fitting.parameters import require_positive, split, unit_of
from granflow.fitting.results import FrozenMap, decode, encode, matrix, numbers
from granflow.fitting.single import FitResult, fit, parameter_names
from granflow.fitting.statistics import (
    FitOutcome,
    decoded,
    estimates,
    fit_report,
    fit_statistics,
    not_a_fit,
    statistics,
)
from granflow.model.run import Run

if TYPE_CHECKING:
    from granflow.fitting.parameters import Parameter, Parameters

__all__ = [
    "JointFitResult",
    "JointSpec",
    "fit_joint",
    "individual_fits",
    "run_names",
    "solve_joint",
]

_LOG_SLOTS = EQ3.log  # alpha and x0 (k and t0) are searched in log coordinates
_TIME_ALIASES = {"alpha": "k", "x0": "t0"}


@dataclass(frozen=True, eq=False)
class JointFitResult(FitOutcome):
    """The outcome of :func:`fit_joint` (or of :func:`fit_amontons`).

    Attributes
    ----------
    domain : {"slip", "time"}
    names : tuple of str
        Global parameter names: shared ones as is (``alpha``), per run with the run index
        (``x0_3``), per group with the group label (``alpha_v1``).
    params, stderr : mapping of str to float
        Values and standard errors [SI].
    ci95 : mapping of str to (float, float)
        95 % Wald intervals.
    covar, correl : mapping of str to mapping of str to float
        Covariance and correlation of the free parameters, by name.
    units : mapping of str to str
        The SI unit of each parameter (a property; ``x0_3`` has the unit of x0).
    run_params : tuple of mapping
        The four model parameters of each run as the joint fit sets them.
    run_names : tuple of str
    individual : tuple of FitResult
        The separate fit of each run that started the joint fit (whose ``x`` and ``data``
        hold the points each run contributed).
    success, message, nfev, ndata, nfree, chisqr, redchi, aic, bic, sigma_known
        As in :class:`granflow.FitResult`.
    """

    domain: str
    names: tuple
    correl: FrozenMap
    fixed: tuple
    run_params: tuple
    run_names: tuple
    individual: tuple
    nfev: int

    def __repr__(self):
        return (
            f"JointFitResult({len(self.run_names)} runs, {self.nfree} free parameters, "
            f"success={self.success}, redchi={self.redchi:.3g})"
        )

    @property
    def units(self) -> FrozenMap:
        """Mapping of parameter name to its SI unit (``x0_3`` has the unit of x0)."""
        return FrozenMap({name: unit_of(name) for name in self.names})

    def report(self) -> str:
        """A text report in the manner of lmfit's ``fit_report``."""
        return fit_report(
            self,
            title="Joint Fit Statistics",
            extra=(("domain", self.domain), ("runs", len(self.run_names))),
        )

    def _repr_html_(self) -> str:
        """The report as HTML tables (Jupyter), in the manner of lmfit's."""
        from granflow._html import fit_html

        return fit_html(
            self,
            title=f"JointFitResult: Eq. 3 in {self.domain} over {len(self.run_names)} runs",
            extra=(("domain", self.domain), ("runs", ", ".join(self.run_names))),
        )

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping of the result (with the separate fits); :meth:`from_dict` inverts
        it.

        Parameters
        ----------
        include_arrays : bool
            Include the points and curves of the separate fits (False: a compact summary, the
            separate fits without their arrays, which :meth:`from_dict` rebuilds empty).
        """
        return encode(
            {
                "domain": self.domain,
                "names": list(self.names),
                **estimates(self),
                "correl": {n: dict(row) for n, row in self.correl.items()},
                "fixed": list(self.fixed),
                "run_params": [dict(p) for p in self.run_params],
                "run_names": list(self.run_names),
                "nfev": self.nfev,
                **statistics(self),
                "individual": [
                    result.to_dict(include_arrays=include_arrays) for result in self.individual
                ],
            }
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> JointFitResult:
        """The result a :meth:`to_dict` output (or its JSON) describes."""
        d = decode(d, cls)
        return cls(
            **decoded(d),
            domain=d["domain"],
            names=tuple(d["names"]),
            correl=matrix(d["correl"]),
            fixed=tuple(d["fixed"]),
            run_params=tuple(numbers(p) for p in d["run_params"]),
            run_names=tuple(d["run_names"]),
            individual=tuple(FitResult.from_dict(r) for r in d.get("individual", [])),
            nfev=d["nfev"],
        )


@dataclass
class JointSpec:
    """Global parameters: name -> (slot, start), and per run the (name, factor) of each slot."""

    globals: dict
    links: list


def individual_fits(datasets, domain, sigma, window):
    """(prepared curves, separate fits) of every run; an error names the run."""
    prepared, fits = [], []
    for index, data in enumerate(datasets):
        try:
            prepared.append(prepare(data, domain, None, window, None, sigma))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                fits.append(fit(data, domain=domain, sigma=sigma, window=window, profile=False))
        except GranflowError as exc:
            raise type(exc)(f"run {index}: {exc}") from exc
    return prepared, fits


def run_names(datasets, fits):
    """The name of each run: the Run's, the fit's, or ``run <index>``."""
    names = []
    for index, (data, result) in enumerate(zip(datasets, fits, strict=True)):
        names.append(data.name if isinstance(data, Run) else (result.name or f"run {index}"))
    return tuple(names)


def solve_joint(spec, prepared, fits, domain, fixed, sigma_known, names_order, ranges=None):
    """Solve the joint problem ``spec``; the fields of its :class:`JointFitResult`.

    ``ranges``: (min, max) search ranges by global name [SI]; an infinite min keeps the
    default lower bound 0.
    """
    parameters, index_of = [], {}
    ranges = ranges or {}
    for name in names_order:
        slot, start = spec.globals[name]
        lower, upper = ranges.get(name, (0.0, math.inf))
        parameters.append(
            GlobalParameter(
                name=name,
                value=fixed.get(name, start),
                log=_LOG_SLOTS[slot],
                fixed=name in fixed,
                lower=lower if math.isfinite(lower) else 0.0,
                upper=upper,
            )
        )
        index_of[name] = len(parameters) - 1
    curves = [
        Curve(data.z, data.y, data.w, tuple((index_of[g], factor) for g, factor in links))
        for data, links in zip(prepared, spec.links, strict=True)
    ]
    problem = Problem(curves, parameters)
    solution = problem.solve_from(problem.internal(), max_iter=300, max_nfev=400)
    values = problem.values(solution.x)
    stats = fit_statistics(problem, values, names_order, sigma_known=sigma_known)
    params = stats.params
    model_names = parameter_names(domain)
    run_params = tuple(
        FrozenMap({model_names[slot]: factor * params[g] for slot, (g, factor) in enumerate(links)})
        for links in spec.links
    )
    messages = [solution.message]
    if not stats.invertible:
        messages.append("the parameters are not all determined by the data (singular J^T J)")
    success = bool(solution.status > 0 and stats.invertible)
    verdict = not_a_fit(stats, stats.ci95, [], names_order, fixed)
    if verdict:
        success = False
        messages.append(verdict)
    return dict(
        **stats.fit_fields(),
        success=success,
        message="; ".join(messages),
        sigma_known=sigma_known,
        domain=domain,
        names=tuple(names_order),
        correl=stats.correl,
        fixed=tuple(n_ for n_ in names_order if n_ in fixed),
        run_params=run_params,
        individual=tuple(fits),
        nfev=int(solution.nfev),
    )


def fit_joint(
    datasets: Sequence[Any],
    *,
    domain: str = "slip",
    shared: Sequence[str] = ("a", "alpha", "Fd"),
    per_run: Sequence[str] = ("x0",),
    groups: Sequence[Any] | None = None,
    per_group: Sequence[str] = (),
    fixed: Mapping[str, float] | None = None,
    sigma: float | None = None,
    window: tuple[float, float] | None = None,
    params: Parameters | Iterable[Parameter] | None = None,
) -> JointFitResult:
    """Fit Eq. 3 to several runs at once, with parameters tied by name.

    Parameters
    ----------
    datasets : sequence
        Runs or ``(x, force)`` pairs, as :func:`granflow.fit` takes them.
    domain : {"slip", "time"}
        Parameter names ``a, alpha, Fd, x0`` or ``a, k, Fd, t0``.
    shared : sequence of str
        Parameters common to every run (named as is: ``alpha``). In the time domain ``alpha``
        and ``x0`` may be written for ``k`` and ``t0``.
    per_run : sequence of str
        Parameters of each run (named with the run's index: ``x0_0``, ``x0_1``, ...).
    groups : sequence, optional
        A label per run (e.g. the velocity); with ``per_group``.
    per_group : sequence of str
        Parameters common to the runs of a group (named ``alpha_<label>``).
    fixed : mapping of str to float, optional
        Global parameters held fixed, by their global name.
    sigma : float, optional
        Known noise [N] (unscaled covariance); default: the residual variance.
    window : (float, float), optional
        Fit window, the same for every run (see :func:`granflow.fit`).
    params : Parameters or sequence of Parameter, optional
        Instead of ``fixed``: :class:`granflow.fitting.Parameter` s by global name. One with
        ``vary=False`` is held at its value; the others start from their value (instead of
        the median of the separate fits) and are searched in ``[min, max]`` (default
        ``[0, inf)``).

    Returns
    -------
    JointFitResult

    Examples
    --------
    >>> import numpy as np, granflow
    >>> x = np.linspace(2e-7, 4e-4, 400)
    >>> runs = [(x, granflow.friction_slip(x, granflow.Params(3e-3, 4e4, 10e-3, x0)))
    ...         for x0 in (1e-7, 1.5e-7)]
    >>> joint = granflow.fit_joint(runs)
    >>> round(joint.params["alpha"]), round(joint.params["x0_1"] * 1e7, 3)
    (40000, 1.5)
    """
    model_names = parameter_names(domain)
    datasets = list(datasets)
    if not datasets:
        raise InvalidParameterError("fit_joint needs at least one run")
    roles = _roles(model_names, domain, shared, per_run, per_group)
    if per_group and (groups is None or len(groups) != len(datasets)):
        raise InvalidParameterError("per_group needs groups: one label per run")
    prepared, fits = individual_fits(datasets, domain, sigma, window)
    labels = [str(g) for g in groups] if groups is not None else [""] * len(datasets)
    spec, order = _tied_spec(fits, model_names, roles, labels)
    fixed, ranges = _held_and_ranges(spec, order, fixed, params)
    fields = solve_joint(spec, prepared, fits, domain, fixed, sigma is not None, order, ranges)
    return JointFitResult(run_names=run_names(datasets, fits), **fields)


def _roles(model_names, domain, shared, per_run, per_group):
    """The role (``shared``, ``per_run`` or ``per_group``) of each model parameter; an
    error names an unknown parameter, one given two roles, or one given none. In the time
    domain the slip names (the defaults) stand for their time-domain twins."""
    if domain == "time":
        shared, per_run, per_group = (
            tuple(_TIME_ALIASES.get(name, name) for name in names)
            for names in (shared, per_run, per_group)
        )
    roles = {}
    for role, names in (("shared", shared), ("per_run", per_run), ("per_group", per_group)):
        for name in names:
            if name not in model_names:
                raise InvalidParameterError(
                    f"{role}: unknown parameter {name!r}; the parameters are "
                    f"{', '.join(model_names)}"
                )
            if name in roles:
                raise InvalidParameterError(f"{name!r} is both {roles[name]} and {role}")
            roles[name] = role
    missing = [n for n in model_names if n not in roles]
    if missing:
        raise InvalidParameterError(
            f"every parameter must be shared, per_run or per_group; missing: {', '.join(missing)}"
        )
    return roles


def _tied_spec(fits, model_names, roles, labels):
    """``(spec, order)``: the joint problem's global parameters, each started at the median
    of its members' separate fits, and each run's links to them; ``order`` the global names
    in the order they first appear."""
    spec = JointSpec(globals={}, links=[])
    order = []
    for index in range(len(fits)):
        links = []
        for slot, name in enumerate(model_names):
            key, members = _global_name(name, roles[name], index, labels)
            if key not in spec.globals:
                start = float(np.median([fits[i].params[name] for i in members]))
                spec.globals[key] = (slot, start)
                order.append(key)
            links.append((key, 1.0))
        spec.links.append(tuple(links))
    return spec, order


def _global_name(name, role, index, labels):
    """``(key, members)``: the global name of parameter ``name`` of run ``index`` (``alpha``,
    ``x0_3``, ``alpha_v1``) and the indices of the runs that share it."""
    if role == "shared":
        return name, range(len(labels))
    if role == "per_run":
        return f"{name}_{index}", [index]
    group = labels[index]
    return f"{name}_{group}", [i for i, label in enumerate(labels) if label == group]


def _held_and_ranges(spec, order, fixed, params):
    """``(fixed, ranges)``: the global parameters held fixed, by name, and the search ranges
    of the others, from ``fixed`` or from ``params`` (whose starts replace the separate
    fits' medians in ``spec``); an error names an unknown one."""
    ranges = {}
    if params is not None:
        if fixed is not None:
            raise InvalidParameterError("give params or fixed, not both")
        requested = split(params, order, "this joint fit")
        require_positive(requested, [k for k in order if _LOG_SLOTS[spec.globals[k][0]]])
        fixed, ranges = requested.held, requested.ranges
        for key, value in requested.starts.items():
            spec.globals[key] = (spec.globals[key][0], value)
    fixed = dict(fixed or {})
    for key in fixed:
        if key not in spec.globals:
            raise InvalidParameterError(
                f"fixed: unknown parameter {key!r}; the parameters are {', '.join(order)}"
            )
    return fixed, ranges
