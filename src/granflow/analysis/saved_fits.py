"""The fit results of a run as JSON and back: :class:`granflow.FitResult` and
:class:`granflow.CurveFitResult` from their ``to_dict()``, with the fitted points and the
weights when they were saved (``include_arrays``).
"""

import math

import numpy as np

from granflow._json import json_safe
from granflow.fitting.creep import CurveFitResult
from granflow.fitting.engine import FrozenMap
from granflow.fitting.single import FitResult

__all__ = [
    "curve_fit_from_dict",
    "curve_fit_to_dict",
    "fit_from_dict",
    "fit_to_dict",
    "number",
    "optional_number",
]

_FIT_ARRAYS = ("x", "data", "best_fit", "residuals", "weights")
_CURVE_ARRAYS = ("x", "data", "best_fit", "residuals")


def number(value):
    """A saved number as a float (JSON's None is a NaN or an infinity that was not kept)."""
    return math.nan if value is None else float(value)


def optional_number(value):
    """A saved number as a float, None staying None."""
    return None if value is None else float(value)


def _numbers(mapping):
    return FrozenMap({name: number(value) for name, value in mapping.items()})


def _matrix(mapping):
    return FrozenMap({p: _numbers(row) for p, row in mapping.items()})


def _intervals(mapping):
    return FrozenMap({n: tuple(number(b) for b in bounds) for n, bounds in mapping.items()})


def _arrays(saved, names):
    """The saved arrays (read-only), or empty ones where the dict has none."""
    arrays = {}
    for name in names:
        array = np.array([number(v) for v in saved.get(name, ())], dtype=np.float64)
        array.flags.writeable = False
        arrays[name] = array
    return arrays


def fit_to_dict(fit, include_arrays=False):
    """``fit.to_dict()`` of a :class:`granflow.FitResult`, with the fitted points and the
    weights when ``include_arrays``."""
    out = fit.to_dict(include_arrays=include_arrays)
    if include_arrays:
        out["weights"] = json_safe(fit.weights)
    return out


def fit_from_dict(saved):
    """The :class:`granflow.FitResult` of :func:`fit_to_dict` (arrays empty without them)."""
    return FitResult(
        domain=saved["domain"],
        names=tuple(saved["params"]),
        params=_numbers(saved["params"]),
        stderr=_numbers(saved["stderr"]),
        ci95=_intervals(saved["ci95"]),
        ci_method=FrozenMap(saved["ci_method"]),
        covar=_matrix(saved["covar"]),
        correl=_matrix(saved["correl"]),
        fixed=tuple(saved["fixed"]),
        at_bound=FrozenMap(saved["at_bound"]),
        success=bool(saved["success"]),
        message=saved["message"],
        nfev=int(saved["nfev"]),
        ndata=int(saved["ndata"]),
        nfree=int(saved["nfree"]),
        chisqr=number(saved["chisqr"]),
        redchi=number(saved["redchi"]),
        aic=number(saved["aic"]),
        bic=number(saved["bic"]),
        rsquared=number(saved["rsquared"]),
        velocity=optional_number(saved["velocity"]),
        window=tuple(number(b) for b in saved["window"]),
        sigma_known=bool(saved["sigma_known"]),
        name=saved.get("name"),
        **_arrays(saved, _FIT_ARRAYS),
    )


def curve_fit_to_dict(fit, include_arrays=False):
    """``fit.to_dict()`` of a :class:`granflow.CurveFitResult`, with the fitted points when
    ``include_arrays``."""
    out = fit.to_dict()
    if include_arrays:
        out.update({name: json_safe(getattr(fit, name)) for name in _CURVE_ARRAYS})
    return out


def curve_fit_from_dict(saved):
    """The :class:`granflow.CurveFitResult` of :func:`curve_fit_to_dict`."""
    return CurveFitResult(
        model=saved["model"],
        formula=saved["formula"],
        names=tuple(saved["params"]),
        units=FrozenMap(saved["units"]),
        params=_numbers(saved["params"]),
        stderr=_numbers(saved["stderr"]),
        ci95=_intervals(saved["ci95"]),
        covar=_matrix(saved["covar"]),
        success=bool(saved["success"]),
        message=saved["message"],
        ndata=int(saved["ndata"]),
        nfree=int(saved["nfree"]),
        chisqr=number(saved["chisqr"]),
        redchi=number(saved["redchi"]),
        aic=number(saved["aic"]),
        bic=number(saved["bic"]),
        sigma_known=bool(saved["sigma_known"]),
        **_arrays(saved, _CURVE_ARRAYS),
    )
