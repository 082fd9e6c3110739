"""Small least-squares fits beside Eq. 3: creep under constant stress, and simple models.

:func:`fit_creep` fits the logarithmic creep of Fig. 3b, ``delta(t) = B ln(1 + t / tau_c)``;
:class:`CurveFitResult` is the result of it and of the rival models of
:func:`granflow.compare_models`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidDataError
from granflow.families import family_of
from granflow.fitting.curves import real_column
from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem
from granflow.fitting.parameters import Split, require_positive, split
from granflow.fitting.results import (
    FrozenMap,
    arrays,
    decode,
    encode,
    intervals,
    matrix,
    numbers,
    read_arrays,
    read_only,
)
from granflow.fitting.statistics import (
    FitOutcome,
    comparison_row,
    decoded,
    estimates,
    fit_report,
    fit_statistics,
    statistics,
)
from granflow.model.units import si_unit

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from granflow._typing import ArrayLike, FloatArray
    from granflow.families import Likelihood
    from granflow.fitting.parameters import Parameter, Parameters

__all__ = ["CurveFitResult", "fit_creep"]


@dataclass(frozen=True, eq=False)
class CurveFitResult(FitOutcome):
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
    covar, correl : mapping of str to mapping of str to float
        Covariance and correlation (a property) of the free parameters, by name.
    success, message, ndata, nfree, chisqr, redchi, aic, bic, sigma_known
        As in :class:`granflow.FitResult`.
    x, data, best_fit, residuals : numpy.ndarray
    fixed : tuple of str
        The parameters held at their value (``params=`` with ``vary=False``).
    function : str
        The engine :class:`~granflow.fitting.Model` fitted, as ``"module:NAME"`` (what
        :meth:`log_likelihood` evaluates); "" where unknown.
    sigma : float, numpy.ndarray or None
        The known noise of the data [unit of the data] (``sigma_known``): one number, or one
        per point; None where it was estimated from the residuals.
    """

    model: str
    formula: str
    names: tuple
    units: FrozenMap
    x: np.ndarray
    data: np.ndarray
    best_fit: np.ndarray
    residuals: np.ndarray
    fixed: tuple = ()
    function: str = ""
    sigma: float | np.ndarray | None = None

    #: The per-point arrays, which the compact ``to_dict(include_arrays=False)`` leaves out.
    ARRAYS = ("x", "data", "best_fit", "residuals")

    def __repr__(self):
        values = ", ".join(f"{n}={self.params[n]:.4g}" for n in self.names)
        return f"CurveFitResult({self.model}, success={self.success}, {values})"

    @property
    def residual_std(self) -> float:
        """The residuals' standard deviation per degree of freedom, sqrt(χ²/(n − p)), in the
        unit of the data ([m] for a creep fit); NaN where the noise was given (``sigma_known``:
        χ² is then already normalised, see ``redchi``)."""
        dof = self.ndata - self.nfree
        if self.sigma_known or dof <= 0:
            return math.nan
        return math.sqrt(self.chisqr / dof)

    @property
    def correl(self) -> FrozenMap:
        """Correlation of the free parameters, by name (from the covariance)."""
        free = [name for name in self.names if name in self.covar]
        scale = {name: math.sqrt(self.covar[name][name]) for name in free}
        return FrozenMap(
            {
                p: FrozenMap(
                    {
                        q: self.covar[p][q] / (scale[p] * scale[q])
                        if scale[p] * scale[q] > 0
                        else 0.0
                        for q in free
                    }
                )
                for p in free
            }
        )

    def report(self) -> str:
        """A text report in the manner of lmfit's ``fit_report``."""
        return fit_report(self, title=f"Fit of {self.formula}")

    def _repr_html_(self) -> str:
        """The report as HTML tables (Jupyter), in the manner of lmfit's."""
        from granflow._html import fit_html

        return fit_html(self, title=f"CurveFitResult: {self.formula}")

    def log_likelihood(self) -> Likelihood:
        """The likelihood of the free parameters, from the result's points, model and noise
        (:func:`granflow.fitting.likelihoods.curve_likelihood`)."""
        from granflow.fitting.likelihoods import curve_likelihood

        return curve_likelihood(self)

    def comparison_row(self) -> dict[str, Any]:
        """The fit's row of :func:`granflow.compare_models` (its ``model`` and ``formula``)."""
        return comparison_row(self, self.model, self.formula)

    def plot(self, ax: Axes | None = None, *, residual_ax: Axes | None = None) -> Axes:
        """Data, fit and residuals; see :func:`granflow.plotting.plot_fit`."""
        from granflow.plotting.fits import plot_fit

        return plot_fit(self, ax=ax, residual_ax=residual_ax)

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping of the result, with its ``family``; :meth:`from_dict` inverts it.

        Parameters
        ----------
        include_arrays : bool
            Include ``x``, ``data``, ``best_fit`` and ``residuals`` as lists (False: a compact
            summary, which :meth:`from_dict` rebuilds with empty arrays).
        """
        out = {
            "family": family_of(self),
            "model": self.model,
            "formula": self.formula,
            "names": list(self.names),
            **estimates(self),
            "units": dict(self.units),
            **statistics(self),
            **arrays(self, include_arrays),
        }
        if self.fixed:
            out["fixed"] = list(self.fixed)
        if self.function:
            out["function"] = self.function
        if self.sigma is not None:
            out["sigma"] = self.sigma if np.ndim(self.sigma) == 0 else list(self.sigma)
        return encode(out)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> CurveFitResult:
        """The result a :meth:`to_dict` output (or its JSON) describes."""
        d = decode(d, cls)
        return cls(
            **decoded(d),
            model=d["model"],
            formula=d["formula"],
            names=tuple(d.get("names") or d["params"]),
            units=FrozenMap(d["units"]),
            **read_arrays(cls, d),
            fixed=tuple(d.get("fixed", ())),
            function=str(d.get("function", "")),
            sigma=_noise(d.get("sigma")),
        )


def check_xy(x: Any, y: Any, names: tuple[str, str], minimum: int) -> tuple[FloatArray, FloatArray]:
    """Finite 1-d float arrays of one length, x strictly increasing; at least ``minimum``."""
    x, y = (real_column(values, name) for values, name in zip((x, y), names, strict=True))
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


def fit_curve(
    model, *, name, formula, units, start, x, y, sigma=None, held=None, ranges=None, function=""
):
    """Least squares of a small :class:`~granflow.fitting.engine.Model` from ``start``.

    The engine's Levenberg-Marquardt (trust-region reflective if it does not converge) in the
    model's coordinates (log for its scale parameters); covariance from the analytic
    Jacobian, scaled by the residual variance unless ``sigma`` (the known noise) is given.
    ``held``: values [SI] of parameters held fixed; ``ranges``: (min, max) search ranges
    [SI] by name (the start is moved inside); ``function``: the model as ``"module:NAME"``
    (kept for the result's :meth:`~CurveFitResult.log_likelihood`); ``sigma``: the known noise,
    a number or one per point.
    """
    held, ranges = held or {}, ranges or {}
    weights = np.ones_like(y) if sigma is None else 1.0 / np.broadcast_to(sigma, y.shape)
    parameters = []
    for slot, value, log in zip(model.slots, start, model.log, strict=True):
        lower, upper = ranges.get(slot, (-math.inf, math.inf))
        parameters.append(
            GlobalParameter(
                name=slot,
                value=float(held.get(slot, min(max(value, lower), upper))),
                log=log,
                fixed=slot in held,
                lower=lower,
                upper=upper,
            )
        )
    identity = tuple((slot, 1.0) for slot in range(len(parameters)))
    problem = Problem([Curve(x, y, weights, identity)], parameters, model)
    solution = problem.solve_from(problem.internal(), rtol=1e-13, max_nfev=400)
    values = problem.values(solution.x)
    stats = fit_statistics(problem, values, model.slots, sigma_known=sigma is not None)
    changes = {}
    message = solution.message
    if not stats.invertible:  # no uncertainty rather than a pseudo-inverse's
        message = f"{message}; singular covariance"
        free = [slot for slot in model.slots if slot not in held]
        changes = {
            "stderr": numbers(dict.fromkeys(model.slots)),
            "ci95": intervals({slot: (None, None) for slot in model.slots}),
            "covar": matrix({p: dict.fromkeys(free) for p in free}),
        }
    return CurveFitResult(
        **stats.fit_fields(**changes),
        success=bool(solution.status > 0 and stats.invertible),
        message=message,
        sigma_known=sigma is not None,
        model=name,
        formula=formula,
        names=tuple(model.slots),
        units=FrozenMap(dict(units)),
        x=read_only(x),
        data=read_only(y),
        best_fit=read_only(stats.best_fit),
        residuals=read_only(stats.residuals),
        fixed=tuple(slot for slot in model.slots if slot in held),
        function=function,
        sigma=_noise(sigma),
    )


def _noise(sigma: Any) -> float | np.ndarray | None:
    """The known noise as the result keeps it: None, a float, or a read-only array of floats."""
    if sigma is None:
        return None
    if np.ndim(sigma) == 0:
        return float(sigma)
    return read_only(np.asarray(sigma, dtype=float))


def _creep(t, B, tau_c):
    return B * np.log1p(t / tau_c)


def _creep_jacobian(t, B, tau_c):
    shape = np.log1p(t / tau_c)
    return B * shape, np.column_stack([shape, -B * t / (tau_c * (tau_c + t))])


#: Logarithmic creep delta(t) = B ln(1 + t / tau_c), tau_c optimised in log coordinates.
CREEP = Model(slots=("B", "tau_c"), function=_creep, jacobian=_creep_jacobian, log=(False, True))


def fit_creep(
    t: ArrayLike,
    slip: ArrayLike,
    *,
    sigma: float | None = None,
    params: Parameters | Iterable[Parameter] | None = None,
) -> CurveFitResult:
    """Fit logarithmic creep ``delta(t) = B ln(1 + t / tau_c)`` (Fig. 3b).

    Parameters
    ----------
    t : array_like
        Time since the stress was applied [s]; non-negative, strictly increasing.
    slip : array_like
        Creep slip delta [m] (or angle, in any unit: B takes it).
    sigma : float, optional
        Known noise of the slip [m]; default: the residual variance.
    params : Parameters or sequence of Parameter, optional
        :class:`granflow.fitting.Parameter` s ``B`` and ``tau_c``: held at their value
        (``vary=False``), or searched in ``[min, max]`` with their value as one more start
        beside those the fit finds itself.

    Returns
    -------
    CurveFitResult
        Parameters ``B`` [m] and ``tau_c`` [s] with standard errors and 95 % intervals.

    Raises
    ------
    InvalidDataError
        Fewer than 4 points, NaN, a non-increasing time, or no creep (slip not growing).
    InvalidParameterError
        A parameter other than B and tau_c, or a tau_c that is not positive.

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
    requested = Split({}, {}, {}) if params is None else split(params, CREEP.slots, "the creep law")
    require_positive(requested, ("tau_c",))
    held = requested.held
    positive = t[t > 0]
    if "tau_c" in held:
        candidates = [held["tau_c"]]
    else:
        candidates = np.geomspace(positive[0] * 0.1, t[-1] * 10, 25)

    def cost(B, shape):
        return float(np.sum((B * shape - slip) ** 2))

    best = None
    for tau in candidates:
        shape = np.log1p(t / tau)
        B = held.get("B", float(shape @ slip / (shape @ shape)))
        candidate = (cost(B, shape), B, tau)
        if best is None or candidate[0] < best[0]:
            best = candidate
    if requested.starts:  # the caller's start, completed from the best of the grid
        B = requested.starts.get("B", best[1])
        tau = requested.starts.get("tau_c", best[2])
        guess = (cost(B, np.log1p(t / tau)), B, tau)
        best = min(best, guess, key=lambda item: item[0])
    return fit_curve(
        CREEP,
        name="creep",
        formula="delta(t) = B ln(1 + t/tau_c)",
        units={name: si_unit(name) for name in CREEP.slots},
        start=best[1:],
        x=t,
        y=slip,
        sigma=sigma,
        held=held,
        ranges=requested.ranges,
        function=f"{__name__}:CREEP",
    )
