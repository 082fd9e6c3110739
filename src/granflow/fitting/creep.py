"""Small least-squares fits beside Eq. 3: creep under constant stress, and simple models.

:func:`fit_creep` fits the logarithmic creep of Fig. 3b, ``delta(t) = B ln(1 + t / tau_c)``;
:class:`CurveFitResult` is the result of it and of the rival models of
:func:`granflow.compare_models`.
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from granflow.errors import InvalidDataError
from granflow.fitting.engine import WALD_Z
from granflow.fitting.results import (
    FrozenMap,
    ValueEquality,
    decode,
    encode,
    intervals,
    matrix,
    number,
    numbers,
    read_only,
)
from granflow.fitting.statistics import estimates, statistics, variable_line

__all__ = ["CurveFitResult", "fit_creep"]


@dataclass(frozen=True, eq=False)
class CurveFitResult(ValueEquality):
    """A least-squares fit of a small closed-form model.

    Attributes
    ----------
    model : str
        Which model (``"creep"``, ``"log_aging"``, ``"exponential"``).
    formula : str
        The model as text.
    names : tuple of str
    params, stderr : mapping of str to float
        Values and standard errors [SI].
    ci95 : mapping of str to (float, float)
        95 % Wald intervals.
    covar : mapping of str to mapping of str to float
    success, message, ndata, nfree, chisqr, redchi, aic, bic, sigma_known
        As in :class:`granflow.FitResult`.
    x, data, best_fit, residuals : numpy.ndarray
    """

    model: str
    formula: str
    names: tuple
    units: FrozenMap
    params: FrozenMap
    stderr: FrozenMap
    ci95: FrozenMap
    covar: FrozenMap
    success: bool
    message: str
    ndata: int
    nfree: int
    chisqr: float
    redchi: float
    aic: float
    bic: float
    sigma_known: bool
    x: np.ndarray
    data: np.ndarray
    best_fit: np.ndarray
    residuals: np.ndarray

    def __repr__(self):
        values = ", ".join(f"{n}={self.params[n]:.4g}" for n in self.names)
        return f"CurveFitResult({self.model}, success={self.success}, {values})"

    def report(self):
        """A text report in the manner of lmfit's ``fit_report``."""
        lines = [
            f"[[Fit of {self.formula}]]",
            f"    success = {self.success}; # data points = {self.ndata}; "
            f"# variables = {self.nfree}",
            f"    chi-square = {self.chisqr:.6g}; reduced chi-square = {self.redchi:.6g}",
            f"    AIC = {self.aic:.6g}; BIC = {self.bic:.6g}",
        ]
        lines += [
            variable_line(
                name,
                self.params[name],
                self.stderr[name],
                self.ci95[name],
                unit=self.units[name],
            )
            for name in self.names
        ]
        return "\n".join(lines)

    def to_dict(self):
        """JSON-safe mapping with the arrays as lists; :meth:`from_dict` inverts it."""
        return encode(
            {
                "model": self.model,
                "formula": self.formula,
                "names": list(self.names),
                **estimates(self),
                "units": dict(self.units),
                **statistics(self),
                **{key: getattr(self, key) for key in _ARRAYS},
            }
        )

    @classmethod
    def from_dict(cls, d):
        """The result a :meth:`to_dict` output (or its JSON) describes."""
        d = decode(d, cls)
        return cls(
            model=d["model"],
            formula=d["formula"],
            names=tuple(d.get("names") or d["params"]),
            units=FrozenMap(d["units"]),
            params=numbers(d["params"]),
            stderr=numbers(d["stderr"]),
            ci95=intervals(d["ci95"]),
            covar=matrix(d["covar"]),
            success=d["success"],
            message=d["message"],
            ndata=d["ndata"],
            nfree=d["nfree"],
            chisqr=number(d["chisqr"]),
            redchi=number(d["redchi"]),
            aic=number(d["aic"]),
            bic=number(d["bic"]),
            sigma_known=d["sigma_known"],
            **{key: read_only(d.get(key, [])) for key in _ARRAYS},
        )


_ARRAYS = ("x", "data", "best_fit", "residuals")


def check_xy(x, y, names, minimum):
    """Finite 1-d float arrays of one length, x strictly increasing; at least ``minimum``."""
    arrays = []
    for values, name in zip((x, y), names, strict=True):
        try:
            array = np.array(values, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InvalidDataError(f"{name} must be an array of real numbers: {exc}") from None
        if array.ndim != 1:
            raise InvalidDataError(f"{name} must be one-dimensional, got shape {array.shape}")
        if not np.all(np.isfinite(array)):
            index = int(np.argmax(~np.isfinite(array)))
            raise InvalidDataError(f"{name} must be finite, got {array[index]} at index {index}")
        arrays.append(array)
    x, y = arrays
    if x.shape != y.shape:
        raise InvalidDataError(f"{names[0]} and {names[1]} must have the same length")
    if x.size < minimum:
        raise InvalidDataError(f"the fit needs at least {minimum} points, got {x.size}")
    if np.any(np.diff(x) <= 0):
        index = int(np.argmax(np.diff(x) <= 0))
        raise InvalidDataError(
            f"{names[0]} must increase strictly, but {names[0]}[{index + 1}] does not exceed "
            f"{names[0]}[{index}]"
        )
    return x, y


def fit_curve(model, *, name, formula, names, units, log, start, x, y, sigma=None):
    """Least squares of ``model(x, *params)`` from ``start``; log-parameterised where asked.

    The covariance comes from a central-difference Jacobian in the natural parameters,
    scaled by the residual variance unless ``sigma`` (the known noise) is given.
    """
    start = np.asarray(start, dtype=float)
    log = np.asarray(log, dtype=bool)
    scale = np.where(start != 0, np.abs(start), 1.0)
    weights = np.ones_like(y) if sigma is None else 1.0 / np.broadcast_to(sigma, y.shape)
    y_scale = float(np.max(np.abs(weights * y))) or 1.0

    def natural(u):
        return np.where(log, scale * np.exp(u), scale * u)

    def residuals(u):
        return weights * (model(x, *natural(u)) - y) / y_scale

    u0 = np.where(log, 0.0, start / scale)
    solution = least_squares(residuals, u0, method="trf", x_scale="jac", xtol=1e-13, ftol=1e-13)
    values = natural(solution.x)
    best_fit = model(x, *values)
    jac = np.empty((x.size, values.size))
    for k in range(values.size):
        step = 1e-6 * max(abs(values[k]), 1e-300)
        up, down = values.copy(), values.copy()
        up[k] += step
        down[k] -= step
        jac[:, k] = weights * (model(x, *up) - model(x, *down)) / (2 * step)
    resid = weights * (y - best_fit)
    chisqr = float(resid @ resid)
    n, nfree = x.size, values.size
    redchi = chisqr / max(n - nfree, 1)
    norms = np.sqrt(np.sum(jac**2, axis=0))
    norms[norms == 0] = 1.0
    hessian = (jac / norms).T @ (jac / norms)
    ok = bool(np.all(np.isfinite(hessian)) and np.linalg.cond(hessian) < 1e13)
    inverse = np.linalg.inv(hessian) / np.outer(norms, norms) if ok else hessian * np.nan
    cov = inverse * (1.0 if sigma is not None else redchi)
    stderr = np.sqrt(np.abs(np.diag(cov)))
    log_term = n * math.log(chisqr / n) if chisqr > 0 else -math.inf
    message = solution.message if ok else f"{solution.message}; singular covariance"
    frozen = FrozenMap
    return CurveFitResult(
        model=name,
        formula=formula,
        names=tuple(names),
        units=frozen(dict(units)),
        params=frozen({k: float(v) for k, v in zip(names, values, strict=True)}),
        stderr=frozen({k: float(v) for k, v in zip(names, stderr, strict=True)}),
        ci95=frozen(
            {
                k: (float(v - WALD_Z * e), float(v + WALD_Z * e))
                for k, v, e in zip(names, values, stderr, strict=True)
            }
        ),
        covar=frozen(
            {
                p: frozen({q: float(cov[i, j]) for j, q in enumerate(names)})
                for i, p in enumerate(names)
            }
        ),
        success=bool(solution.status > 0 and ok),
        message=message,
        ndata=n,
        nfree=nfree,
        chisqr=chisqr,
        redchi=redchi,
        aic=log_term + 2 * nfree,
        bic=log_term + math.log(n) * nfree,
        sigma_known=sigma is not None,
        x=read_only(x),
        data=read_only(y),
        best_fit=read_only(best_fit),
        residuals=read_only(y - best_fit),
    )


def _creep(t, B, tau_c):
    return B * np.log1p(t / tau_c)


def fit_creep(t, slip, *, sigma=None):
    """Fit logarithmic creep ``delta(t) = B ln(1 + t / tau_c)`` (Fig. 3b).

    Parameters
    ----------
    t : array_like
        Time since the stress was applied [s]; non-negative, strictly increasing.
    slip : array_like
        Creep slip delta [m] (or angle, in any unit: B takes it).
    sigma : float, optional
        Known noise of the slip [m]; default: the residual variance.

    Returns
    -------
    CurveFitResult
        Parameters ``B`` [m] and ``tau_c`` [s] with standard errors and 95 % intervals.

    Raises
    ------
    InvalidDataError
        Fewer than 4 points, NaN, a non-increasing time, or no creep (slip not growing).

    Examples
    --------
    >>> import numpy as np, granflow
    >>> t = np.linspace(0, 300, 301)
    >>> result = granflow.fit_creep(t, 2e-6 * np.log1p(t / 5.0))
    >>> round(result.params["B"] * 1e6, 6), round(result.params["tau_c"], 6)
    (2.0, 5.0)
    """
    t, slip = check_xy(t, slip, ("t", "slip"), 4)
    if t[0] < 0:
        raise InvalidDataError(f"t must be non-negative (time since loading), got {t[0]:g} s")
    if not slip[-1] > slip[0]:
        raise InvalidDataError("the slip does not grow: there is no creep to fit")
    positive = t[t > 0]
    candidates = np.geomspace(positive[0] * 0.1, t[-1] * 10, 25)
    best = None
    for tau in candidates:
        shape = np.log1p(t / tau)
        B = float(shape @ slip / (shape @ shape))
        cost = float(np.sum((B * shape - slip) ** 2))
        if best is None or cost < best[0]:
            best = (cost, B, tau)
    _, B, tau = best
    return fit_curve(
        _creep,
        name="creep",
        formula="delta(t) = B ln(1 + t/tau_c)",
        names=("B", "tau_c"),
        units={"B": "m", "tau_c": "s"},
        log=(False, True),
        start=(B, tau),
        x=t,
        y=slip,
        sigma=sigma,
    )
