"""The one builder of fit statistics, and the report lines every fit result shares.

:func:`fit_statistics` turns a solved :class:`granflow.fitting.engine.Problem` into the
numbers every result carries (lmfit's names): params, stderr, covariance and correlation by
name, Wald intervals, chisqr, redchi, AIC, BIC and R-squared. :func:`statistics_lines` and
:func:`variable_line` are the lmfit-style report every result prints.
"""

import math
from dataclasses import dataclass

import numpy as np

from granflow.fitting.engine import covariance
from granflow.fitting.results import FrozenMap

STATISTICS = ("success", "message", "ndata", "nfree", "chisqr", "redchi", "aic", "bic")
WALD_Z = 1.959963984540054  # the 97.5 % quantile of the standard normal distribution


@dataclass(frozen=True)
class FitStatistics:
    """What :func:`fit_statistics` finds; the fields have lmfit's names and meanings.

    ``best_fit`` and ``residuals`` (data - model) run over every curve's points in order;
    ``invertible`` tells whether J^T J could be inverted (else the covariance is a
    pseudo-inverse).
    """

    params: FrozenMap
    stderr: FrozenMap
    covar: FrozenMap
    correl: FrozenMap
    ci95: FrozenMap
    ndata: int
    nfree: int
    chisqr: float
    redchi: float
    aic: float
    bic: float
    rsquared: float
    best_fit: np.ndarray
    residuals: np.ndarray
    invertible: bool


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


def statistics_lines(result, *, title, extra=()):
    """The lmfit-style header block: ``[[title]]`` then one aligned line per statistic
    (``extra``: (label, text) pairs inserted after the message)."""
    rows = [("success", result.success), ("message", result.message), *extra]
    rows += [
        ("# data points", result.ndata),
        ("# variables", result.nfree),
        ("chi-square", f"{result.chisqr:.6g}"),
        ("reduced chi-square", f"{result.redchi:.6g}"),
        ("Akaike info crit", f"{result.aic:.6g}"),
        ("Bayesian info crit", f"{result.bic:.6g}"),
    ]
    return [f"[[{title}]]", *(f"    {label:<18} = {value}" for label, value in rows)]


def variable_line(name, value, stderr, interval, *, unit="", width=6):
    """One ``[[Variables]]`` line: ``name = value +/- stderr unit  95%: [low, high]``."""
    unit = f" {unit}" if unit else ""
    low, high = interval
    return f"    {name:<{width}} = {value:.8g} +/- {stderr:.4g}{unit}  95%: [{low:.6g}, {high:.6g}]"
