"""The one builder of fit statistics, the fields every fit result shares, and the one report.

:func:`fit_statistics` turns a solved :class:`granflow.fitting.engine.Problem` into the
numbers every result carries (lmfit's names): params, stderr, covariance and correlation by
name, Wald intervals, chisqr, redchi, AIC, BIC and R-squared. :class:`FitSummary` declares the
fields that the statistics and every result share, :class:`FitOutcome` those of every result
(with success, message and sigma_known); :func:`estimates`, :func:`statistics` and
:func:`decoded` are their JSON codec, :func:`comparison_row` a result's row of a model
comparison, and :func:`fit_report` is the lmfit-style report of every single, joint and
curve fit.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from granflow.fitting.profile import covariance
from granflow.fitting.results import (
    FrozenMap,
    ValueEquality,
    intervals,
    matrix,
    number,
    numbers,
)

STATISTICS = ("success", "message", "ndata", "nfree", "chisqr", "redchi", "aic", "bic")
WALD_Z = 1.959963984540054  # the 97.5 % quantile of the standard normal distribution
_CORRELATION_SHOWN = 0.1  # the report lists correlations at least this large


@dataclass(frozen=True, eq=False)
class FitSummary:
    """The numbers every fit reports, with lmfit's names and meanings.

    Attributes
    ----------
    params, stderr : mapping of str to float
        Values and standard errors by name [SI].
    ci95 : mapping of str to (float, float)
        95 % intervals [SI].
    covar : mapping of str to mapping of str to float
        Covariance of the free parameters, by name.
    ndata, nfree : int
        Points fitted, free parameters.
    chisqr, redchi, aic, bic : float
        Weighted sum of squared residuals, its value per degree of freedom, Akaike and
        Bayesian information criteria.
    """

    params: FrozenMap
    stderr: FrozenMap
    ci95: FrozenMap
    covar: FrozenMap
    ndata: int
    nfree: int
    chisqr: float
    redchi: float
    aic: float
    bic: float

    def fit_fields(self, **changes):
        """The :class:`FitSummary` fields as keyword arguments of a result (``changes``
        replace some of them)."""
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(FitSummary)}
        return {**fields, **changes}


@dataclass(frozen=True, eq=False)
class FitStatistics(FitSummary):
    """What :func:`fit_statistics` finds, beside the :class:`FitSummary` fields.

    ``best_fit`` and ``residuals`` (data - model) run over every curve's points in order;
    ``invertible`` tells whether J^T J could be inverted (else the covariance is a
    pseudo-inverse).
    """

    correl: FrozenMap
    rsquared: float
    best_fit: np.ndarray
    residuals: np.ndarray
    invertible: bool


@dataclass(frozen=True, eq=False)
class FitOutcome(FitSummary, ValueEquality):
    """The fields every fit result shares: :class:`FitSummary`, and

    Attributes
    ----------
    success : bool
        Whether the optimiser converged and the uncertainties could be computed.
    message : str
        Why it stopped, and any caveat.
    sigma_known : bool
        Whether the covariance uses a known noise (True) or the residual variance (False).
    """

    success: bool
    message: str
    sigma_known: bool


def fit_statistics(problem, values, names, *, sigma_known, hessian=None):
    """Standard errors, covariance, Wald intervals and goodness of fit of a solved problem.

    Parameters
    ----------
    problem : granflow.fitting.engine.Problem
        The solved problem.
    values : numpy.ndarray
        The best global parameter values [SI].
    names : sequence of str
        The global parameter names, in the problem's order.
    sigma_known : bool
        Whether the weights are 1/sigma of a known noise (unscaled covariance) or relative
        weights (covariance scaled by the reduced chi-square).
    hessian : numpy.ndarray, optional
        J^T J in the optimiser's coordinates at ``values`` (saves a pass over the data).

    Returns
    -------
    FitStatistics
        AIC and BIC follow lmfit: ``n ln(chisqr / n) + 2 k`` and ``n ln(chisqr / n) + k ln n``.
    """
    y = np.concatenate([curve.y for curve in problem.curves])
    w = np.concatenate([curve.w for curve in problem.curves])
    best_fit = np.concatenate(problem.best_fit(values))
    residuals = y - best_fit
    chisqr = float(np.sum((w * residuals) ** 2))
    n, nfree = problem.ndata, len(problem.free)
    redchi = chisqr / max(n - nfree, 1)
    covar_free, invertible = covariance(problem, values, 1.0 if sigma_known else redchi, hessian)
    free_names = [names[i] for i in problem.free]
    stderr = dict.fromkeys(names, 0.0)
    for k, name in enumerate(free_names):
        stderr[name] = float(math.sqrt(max(covar_free[k, k], 0.0)))
    covar = {
        p: {q: float(covar_free[i, j]) for j, q in enumerate(free_names)}
        for i, p in enumerate(free_names)
    }
    correl = {
        p: {
            q: float(covar[p][q] / (stderr[p] * stderr[q])) if stderr[p] * stderr[q] > 0 else 0.0
            for q in free_names
        }
        for p in free_names
    }
    params = {name: float(values[i]) for i, name in enumerate(names)}
    ci95 = {
        name: (params[name] - WALD_Z * stderr[name], params[name] + WALD_Z * stderr[name])
        for name in names
    }
    total = float(np.sum((y - np.mean(y)) ** 2))
    rsquared = 1.0 - float(residuals @ residuals) / total if total > 0 else math.nan
    log_term = n * math.log(chisqr / n) if chisqr > 0 else -math.inf
    return FitStatistics(
        params=FrozenMap(params),
        stderr=FrozenMap(stderr),
        covar=FrozenMap({k: FrozenMap(v) for k, v in covar.items()}),
        correl=FrozenMap({k: FrozenMap(v) for k, v in correl.items()}),
        ci95=FrozenMap(ci95),
        ndata=n,
        nfree=nfree,
        chisqr=chisqr,
        redchi=redchi,
        aic=log_term + 2 * nfree,
        bic=log_term + math.log(n) * nfree,
        rsquared=rsquared,
        best_fit=best_fit,
        residuals=residuals,
        invertible=invertible,
    )


def comparison_row(result, model, formula):
    """The row of a model comparison (:func:`granflow.compare_models`) of a fit ``result``:
    ``model``, ``formula``, ``nfree``, ``chisqr``, ``aic``, ``bic``, ``success``,
    ``message``."""
    return {
        "model": model,
        "formula": formula,
        "nfree": result.nfree,
        "chisqr": result.chisqr,
        "aic": result.aic,
        "bic": result.bic,
        "success": result.success,
        "message": result.message,
    }


def estimates(result):
    """The parameter estimates of a fit result as plain mappings: params, stderr, ci95, covar."""
    return {
        "params": dict(result.params),
        "stderr": dict(result.stderr),
        "ci95": {name: list(interval) for name, interval in result.ci95.items()},
        "covar": {name: dict(row) for name, row in result.covar.items()},
    }


def statistics(result):
    """Goodness of fit of a result: success, message, counts, chi-square, AIC, BIC and
    whether the noise was known."""
    return {
        **{key: getattr(result, key) for key in STATISTICS},
        "sigma_known": result.sigma_known,
    }


def decoded(d):
    """The :class:`FitOutcome` fields of a result from what :func:`estimates` and
    :func:`statistics` wrote (the inverse of both)."""
    return {
        "params": numbers(d["params"]),
        "stderr": numbers(d["stderr"]),
        "ci95": intervals(d["ci95"]),
        "covar": matrix(d["covar"]),
        "success": d["success"],
        "message": d["message"],
        "ndata": d["ndata"],
        "nfree": d["nfree"],
        **{key: number(d[key]) for key in ("chisqr", "redchi", "aic", "bic")},
        "sigma_known": d["sigma_known"],
    }


def fit_report(
    result: Any,
    *,
    title: str,
    extra: Sequence[tuple[str, object]] = (),
    after: Sequence[tuple[str, object]] = (),
) -> str:
    """The report of a fit result in the manner of lmfit's ``fit_report``.

    Parameters
    ----------
    result : FitOutcome
        A single, joint or curve fit. Besides the :class:`FitOutcome` fields it needs
        ``names`` and ``units`` (mapping of name to SI unit); where the result has them it
        reports ``rsquared``, ``fixed`` (held parameters), ``ci_method`` and ``at_bound``
        (per parameter) and ``correl`` (correlations of the free parameters).
    title : str
        The heading of the statistics block.
    extra : sequence of (str, object)
        Rows shown after the message (e.g. the domain).
    after : sequence of (str, object)
        Rows shown after the goodness of fit (e.g. the window).

    Returns
    -------
    str
        ``[[title]]`` and one aligned line per statistic, ``[[Variables]]`` with one line per
        parameter (value, standard error, relative error, unit, 95 % interval), and
        ``[[Correlations]]`` with those of at least 0.1 in magnitude, largest first.
    """
    rows = [("success", result.success), ("message", result.message), *extra]
    rows += [
        ("# data points", result.ndata),
        ("# variables", result.nfree),
        ("chi-square", f"{result.chisqr:.6g}"),
        ("reduced chi-square", f"{result.redchi:.6g}"),
        ("Akaike info crit", f"{result.aic:.6g}"),
        ("Bayesian info crit", f"{result.bic:.6g}"),
    ]
    if hasattr(result, "rsquared"):
        rows.append(("R-squared", f"{result.rsquared:.8f}"))
    rows += after
    lines = [f"[[{title}]]", *(f"    {label:<18} = {value}" for label, value in rows)]
    lines.append("[[Variables]]")
    lines += [_variable_line(result, name) for name in result.names]
    correl = getattr(result, "correl", None)
    if correl is not None:
        lines.append(f"[[Correlations]] (unreported correlations are < {_CORRELATION_SHOWN:.3f})")
        free = [name for name in result.names if name in correl]
        pairs = [(correl[p][q], p, q) for i, p in enumerate(free) for q in free[i + 1 :]]
        for value, p, q in sorted(pairs, key=lambda item: -abs(item[0])):
            if abs(value) >= _CORRELATION_SHOWN:
                lines.append(f"    C({p}, {q}) = {value:+.4f}")
    return "\n".join(lines)


def _variable_line(result, name):
    """One ``[[Variables]]`` line: ``name = value +/- stderr unit (rel)  95%: [low, high]``,
    in the display unit of the parameter's SI unit (mN for N, µm for m: see
    :func:`granflow.model.units.display_of_si`), the value with the digits its error
    justifies, with the interval's method and ``at bound`` where the result knows them."""
    from granflow._format import format_interval, format_number, format_value_error
    from granflow.model.units import display_of_si

    width = max(5, *(len(n) for n in result.names))
    value = result.params[name]
    scale, unit = display_of_si(result.units[name])
    unit = f" {unit}" if unit else ""
    if name in getattr(result, "fixed", ()):
        return f"    {name:<{width}} = {format_number(value, scale, 8)}{unit} (fixed)"
    err = result.stderr[name]
    rel = f" ({100 * err / abs(value):.2g} %)" if value and math.isfinite(err) else ""
    interval = format_interval(result.ci95[name], scale).replace("—", "nan")
    method = getattr(result, "ci_method", None)
    method = f" ({method[name]})" if method is not None else ""
    at_bound = getattr(result, "at_bound", None)
    flag = " at bound" if at_bound is not None and at_bound[name] else ""
    shown = format_value_error(value, err, scale).replace(" ± ", " +/- ")
    if not math.isfinite(err):
        shown += " +/- nan"
    return f"    {name:<{width}} = {shown}{unit}{rel}  95%: {interval}{method}{flag}"


#: A free parameter whose standard error exceeds this many times its value is not
#: determined by the data (a 95 % interval of +-200 times the value).
UNDETERMINED = 100.0


def not_a_fit(stats, ci95, bound_names, names, fixed):
    """The sentence that says why a converged optimisation is no fit of the data, or "".

    A fit is no fit when the model describes the data worse than their mean (R-squared
    below 0), when a free parameter is not determined by the data (a standard error over
    :data:`UNDETERMINED` times its value, or an interval with an infinite end), or when a
    parameter ended on a bound of its search range (the optimum lies outside it).
    """
    reasons = []
    if math.isfinite(stats.rsquared) and stats.rsquared < 0:
        reasons.append(
            f"R-squared is {stats.rsquared:.3g}: the model describes the data worse than their mean"
        )
    loose = []
    for name in names:
        if name in fixed:
            continue
        value, error = stats.params[name], stats.stderr[name]
        low, high = ci95[name]
        if not (math.isfinite(low) and math.isfinite(high)):
            loose.append(f"{name} (95 % interval [{low:.3g}, {high:.3g}])")
        elif not abs(error) <= UNDETERMINED * abs(value):
            share = abs(error / value) * 100 if value else math.inf
            loose.append(f"{name} (+- {share:.3g} %)")
    if loose:
        reasons.append(f"not determined by the data: {', '.join(loose)}")
    if bound_names:
        reasons.append("a parameter on a bound of its search range is no optimum")
    if not reasons:
        return ""
    return "not a fit of these data: " + "; ".join(reasons)
