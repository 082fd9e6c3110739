"""Small least-squares fits beside Eq. 3: creep under constant stress, and simple models.

:func:`fit_creep` fits the logarithmic creep of Fig. 3b, ``delta(t) = B ln(1 + t / tau_c)``;
:class:`CurveFitResult` is the result of it and of the rival models of
:func:`granflow.compare_models`.
"""

from dataclasses import dataclass

import numpy as np

from granflow.errors import InvalidDataError
from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem
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
from granflow.fitting.statistics import estimates, fit_statistics, statistics, variable_line
from granflow.model.units import si_unit

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


def fit_curve(model, *, name, formula, units, start, x, y, sigma=None):
    """Least squares of a small :class:`~granflow.fitting.engine.Model` from ``start``.

    The engine's Levenberg-Marquardt (trust-region reflective if it does not converge) in the
    model's coordinates (log for its scale parameters); covariance from the analytic
    Jacobian, scaled by the residual variance unless ``sigma`` (the known noise) is given.
    """
    weights = np.ones_like(y) if sigma is None else 1.0 / np.broadcast_to(sigma, y.shape)
    parameters = [
        GlobalParameter(name=slot, value=float(value), log=log)
        for slot, value, log in zip(model.slots, start, model.log, strict=True)
    ]
    identity = tuple((slot, 1.0) for slot in range(len(parameters)))
    problem = Problem([Curve(x, y, weights, identity)], parameters, model)
    solution = problem.solve_from(problem.internal(), rtol=1e-13, max_nfev=400)
    values = problem.values(solution.x)
    stats = fit_statistics(problem, values, model.slots, sigma_known=sigma is not None)
    stderr, ci95, covar = stats.stderr, stats.ci95, stats.covar
    message = solution.message
    if not stats.invertible:  # no uncertainty rather than a pseudo-inverse's
        message = f"{message}; singular covariance"
        stderr = numbers(dict.fromkeys(model.slots))
        ci95 = intervals({name: (None, None) for name in model.slots})
        covar = matrix({p: dict.fromkeys(model.slots) for p in model.slots})
    return CurveFitResult(
        model=name,
        formula=formula,
        names=tuple(model.slots),
        units=FrozenMap(dict(units)),
        params=stats.params,
        stderr=stderr,
        ci95=ci95,
        covar=covar,
        success=bool(solution.status > 0 and stats.invertible),
        message=message,
        ndata=stats.ndata,
        nfree=stats.nfree,
        chisqr=stats.chisqr,
        redchi=stats.redchi,
        aic=stats.aic,
        bic=stats.bic,
        sigma_known=sigma is not None,
        x=read_only(x),
        data=read_only(y),
        best_fit=read_only(stats.best_fit),
        residuals=read_only(stats.residuals),
    )


def _creep(t, B, tau_c):
    return B * np.log1p(t / tau_c)


def _creep_jacobian(t, B, tau_c):
    shape = np.log1p(t / tau_c)
    return B * shape, np.column_stack([shape, -B * t / (tau_c * (tau_c + t))])


#: Logarithmic creep delta(t) = B ln(1 + t / tau_c), tau_c optimised in log coordinates.
CREEP = Model(slots=("B", "tau_c"), function=_creep, jacobian=_creep_jacobian, log=(False, True))


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
        CREEP,
        name="creep",
        formula="delta(t) = B ln(1 + t/tau_c)",
        units={name: si_unit(name) for name in CREEP.slots},
        start=(B, tau),
        x=t,
        y=slip,
        sigma=sigma,
    )
