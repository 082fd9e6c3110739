"""Fits of Eq. 3 to one friction curve, with honest uncertainties.

:func:`fit` takes a pair of arrays (slip or time [SI], force [N]) or a :class:`granflow.Run`
and needs no initial guess: it reads a start from the curve (plateau -> Fd, height and
position of the overshoot -> a and alpha through ``F_peak = Fd + a / (alpha x_peak)``, the
early rise -> x0), confirms it from a few starts, and refines with
``scipy.optimize.least_squares`` (trust-region reflective, analytic Jacobian, alpha and x0 in
log coordinates). Standard errors come from ``J^T J`` scaled by the residual variance (or from a
known noise ``sigma``); the 95 % intervals of x0 (t0) and alpha (k) are profile-likelihood
intervals, those of a and Fd Wald intervals.

**Fit window and data before x0.** By default the window is every point with positive
abscissa (the model's ``ln x`` needs x > 0); pass ``window=(start, stop)`` to cut the elastic
loading ramp at the start of a measured interval. Inside the window, points that fall below the
current trial x0 (t0) are compared with the model's initial force ``Fd (1 - exp(-alpha x0))``:
the objective stays a continuous function of x0 and every point stays in the sum.

In the time domain (``domain="time"``) the same mathematics applies with x -> t,
alpha -> k = alpha v, x0 -> t0 = x0 / v; the parameters are called ``a, k, Fd, t0``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow.errors import ConvergenceWarning, InvalidParameterError
from granflow.families import family_of
from granflow.fitting.curves import (
    ABSCISSA,
    check_mapping,
    curve_features,
    prepare,
    require_overshoot,
    start_candidates,
)
from granflow.fitting.curves import noise_level as _noise_level
from granflow.fitting.engine import (
    EQ3,
    SLOTS,
    Curve,
    GlobalParameter,
    Problem,
    model_only,
)
from granflow.fitting.multistart import multistart
from granflow.fitting.parameters import split
from granflow.fitting.profile import profile_interval
from granflow.fitting.results import (
    FrozenMap,
    arrays,
    decode,
    encode,
    matrix,
    number,
    read_arrays,
    read_only,
)
from granflow.fitting.statistics import (
    WALD_Z,
    FitOutcome,
    comparison_row,
    decoded,
    estimates,
    fit_report,
    fit_statistics,
    not_a_fit,
    statistics,
)
from granflow.model.params import Params
from granflow.model.units import si_unit

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from granflow._typing import ArrayLike, FloatArray
    from granflow.families import Likelihood
    from granflow.fitting.parameters import Parameter, Parameters
    from granflow.model.run import Run

__all__ = ["FORMULA", "FitResult", "fit", "parameter_names"]

#: Eq. 3 as text (the model comparison's formula).
FORMULA = "Eq. 3: a e^-s [Ei(s) - Ei(s0)] + Fd (1 - e^-s)"

_NAMES = {"slip": ("a", "alpha", "Fd", "x0"), "time": ("a", "k", "Fd", "t0")}
#: SI unit of each parameter, by domain (from granflow.model.units).
_UNITS = {domain: {name: si_unit(name) for name in names} for domain, names in _NAMES.items()}
_LOG_SLOTS = EQ3.log  # alpha and x0 (k and t0) are searched in log coordinates
_FEW_RISE_POINTS = 50  # below this many points up to the peak, always check x0 < x_first


def parameter_names(domain="slip"):
    """The four parameter names of a domain: ``("a", "alpha", "Fd", "x0")`` or
    ``("a", "k", "Fd", "t0")``."""
    if domain not in _NAMES:
        raise InvalidParameterError(f"domain must be 'slip' or 'time', got {domain!r}")
    return _NAMES[domain]


# --------------------------------------------------------------------------- the result


@dataclass(frozen=True, eq=False)
class FitResult(FitOutcome):
    """The outcome of :func:`fit`: parameters with uncertainties and goodness of fit.

    Attributes
    ----------
    domain : {"slip", "time"}
        Which form of Eq. 3 was fitted.
    names : tuple of str
        ``("a", "alpha", "Fd", "x0")`` (slip) or ``("a", "k", "Fd", "t0")`` (time).
    params, stderr : mapping of str to float
        Best values and standard errors in SI units (stderr 0 for fixed parameters).
    ci95 : mapping of str to (float, float)
        95 % intervals: profile likelihood for alpha/k and x0/t0, Wald for a and Fd.
    ci_method : mapping of str to str
        ``"profile"``, ``"wald"`` or ``"fixed"`` per parameter.
    covar, correl : mapping of str to mapping of str to float
        Covariance [SI units squared] and correlation of the free parameters, by name.
    fixed : tuple of str
        The parameters held fixed.
    at_bound : mapping of str to bool
        Whether a free parameter ended on a bound of its search range.
    success : bool
        Whether the optimiser converged and the uncertainties could be computed.
    message : str
        Why it stopped, and any caveat.
    nfev, ndata, nfree : int
        Model evaluations, points fitted, free parameters.
    chisqr, redchi, aic, bic, rsquared : float
        Weighted sum of squared residuals [N^2, or dimensionless with a known sigma], its
        value per degree of freedom, Akaike and Bayesian information criteria (lmfit's
        definitions), coefficient of determination.
    x, data, best_fit, residuals, weights : numpy.ndarray
        Abscissa of the fitted points [m or s], measured force [N], model [N],
        data - model [N], weights (1/sigma with a known sigma).
    velocity : float or None
        Sliding velocity [m/s] (time domain: needed to convert to slip parameters).
    window : (float, float)
        First and last abscissa fitted.
    sigma_known : bool
        Whether the covariance uses a known noise (True) or the residual variance (False).
    name : str or None
        The run's name, when a Run was fitted.
    dropped : mapping of str to int
        Points of the data left out of the fit, counted by reason (only non-zero counts):
        ``non_finite`` (a Run's rows with a NaN or infinite abscissa or force),
        ``not_positive`` (abscissa <= 0), ``outside_window``, ``zero_weight``.
    """

    domain: str
    names: tuple
    ci_method: FrozenMap
    correl: FrozenMap
    fixed: tuple
    at_bound: FrozenMap
    nfev: int
    rsquared: float
    x: np.ndarray
    data: np.ndarray
    best_fit: np.ndarray
    residuals: np.ndarray
    weights: np.ndarray
    velocity: float | None
    window: tuple
    name: str | None = None
    dropped: FrozenMap = field(default_factory=FrozenMap)

    #: The per-point arrays, which the compact ``to_dict(include_arrays=False)`` leaves out.
    ARRAYS = ("x", "data", "best_fit", "residuals", "weights")

    def __repr__(self):
        values = ", ".join(f"{n}={self.params[n]:.4g}" for n in self.names)
        return (
            f"FitResult({self.domain}, success={self.success}, {values}, "
            f"redchi={self.redchi:.3g}, ndata={self.ndata})"
        )

    @property
    def units(self) -> Mapping[str, str]:
        """Mapping of parameter name to its SI unit."""
        return _UNITS[self.domain]

    def to_params(self, velocity: float | None = None) -> Params:
        """The fitted values as :class:`granflow.Params` (slip domain, SI).

        Parameters
        ----------
        velocity : float, optional
            Sliding velocity [m/s] to convert a time-domain result (k, t0); defaults to the
            velocity the fit was given.
        """
        if self.domain == "slip":
            return Params(**{n: self.params[n] for n in self.names})
        velocity = self.velocity if velocity is None else velocity
        if velocity is None:
            raise InvalidParameterError(
                "a time-domain result needs the sliding velocity to give slip parameters"
            )
        p = self.params
        return Params.from_time_domain(
            a=p["a"], k=p["k"], t0=p["t0"], Fd=p["Fd"], velocity=velocity
        )

    def model(self, x: ArrayLike) -> FloatArray:
        """The fitted curve at abscissae ``x`` [m or s] (held at the initial force below x0)."""
        z = check.real_array(x, "x", ABSCISSA[self.domain][1]).ravel()
        return model_only(np.ascontiguousarray(z), *(self.params[n] for n in self.names))

    def _report_rows(self):
        """The rows of :meth:`report` beside the statistics every fit shows; ``dropped``
        counts the points left out by reason ("3 non finite, 1 not positive")."""
        window = f"[{self.window[0]:.6g}, {self.window[1]:.6g}] {ABSCISSA[self.domain][1]}"
        dropped = ", ".join(f"{n} {why.replace('_', ' ')}" for why, n in self.dropped.items())
        return {
            "extra": (("domain", self.domain), ("# function evals", self.nfev)),
            "after": (("window", window), *((("dropped", dropped),) if dropped else ())),
        }

    def report(self) -> str:
        """A text report in the manner of lmfit's ``fit_report``."""
        return fit_report(self, title="Fit Statistics", **self._report_rows())

    def _repr_html_(self) -> str:
        """The report as HTML tables (Jupyter), in the manner of lmfit's."""
        from granflow._html import fit_html

        title = f"FitResult: Eq. 3 in {self.domain}" + (f" of {self.name}" if self.name else "")
        return fit_html(self, title=title, **self._report_rows())

    def log_likelihood(self) -> Likelihood:
        """The likelihood of the free parameters, from the result's points and weights
        (:func:`granflow.fitting.likelihoods.eq3_likelihood`)."""
        from granflow.fitting.likelihoods import eq3_likelihood

        return eq3_likelihood(self)

    def comparison_row(self) -> dict[str, Any]:
        """The fit's row of :func:`granflow.compare_models` (model ``"eq3"``)."""
        return comparison_row(self, "eq3", FORMULA)

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping of the result, with its ``family``; :meth:`from_dict` inverts it.

        Parameters
        ----------
        include_arrays : bool
            Include ``x``, ``data``, ``best_fit``, ``residuals`` and ``weights`` as lists
            (False: a compact summary, which :meth:`from_dict` rebuilds with empty arrays).
        """
        out = {
            "family": family_of(self),
            "domain": self.domain,
            "name": self.name,
            "names": list(self.names),
            **estimates(self),
            "ci_method": dict(self.ci_method),
            "correl": {n: dict(row) for n, row in self.correl.items()},
            "fixed": list(self.fixed),
            "at_bound": dict(self.at_bound),
            "units": dict(self.units),
            "nfev": self.nfev,
            **statistics(self),
            "rsquared": self.rsquared,
            "velocity": self.velocity,
            "window": list(self.window),
            "dropped": dict(self.dropped),
            **arrays(self, include_arrays),
        }
        return encode(out)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> FitResult:
        """The result a :meth:`to_dict` output (or its JSON) describes.

        Examples
        --------
        >>> import json, numpy as np, granflow
        >>> x = np.linspace(1e-6, 5e-4, 300)
        >>> p = granflow.Params(3e-3, 4e4, 1e-2, 2e-7)
        >>> result = granflow.fit((x, granflow.friction_slip(x, p)))
        >>> granflow.FitResult.from_dict(json.loads(json.dumps(result.to_dict()))) == result
        True
        """
        d = decode(d, cls)
        names = tuple(d.get("names") or d["params"])
        return cls(
            **decoded(d),
            domain=d["domain"],
            names=names,
            ci_method=FrozenMap(d["ci_method"]),
            correl=matrix(d["correl"]),
            fixed=tuple(d["fixed"]),
            at_bound=FrozenMap(d["at_bound"]),
            nfev=d["nfev"],
            rsquared=number(d["rsquared"]),
            **read_arrays(cls, d),
            velocity=None if d["velocity"] is None else float(d["velocity"]),
            window=tuple(number(v) for v in d["window"]),
            name=d.get("name"),
            dropped=FrozenMap({k: int(v) for k, v in d.get("dropped", {}).items()}),
        )

    def plot(self, ax: Axes | None = None, *, residual_ax: Axes | None = None) -> Axes:
        """Data, fit and residuals; see :func:`granflow.plotting.plot_fit`."""
        from granflow.plotting.fits import plot_fit

        return plot_fit(self, ax=ax, residual_ax=residual_ax)


# --------------------------------------------------------------------------- the fit


def _global_parameters(names, start, fixed, bounds, z, from_params=False):
    """The four global parameters with their default search ranges (in SI).

    ``from_params``: ``bounds`` holds the (min, max) of :class:`Parameter` s, whose infinite
    sides keep the default range.
    """
    z_first, z_last = float(z[0]), float(z[-1])
    default = {
        0: (0.0, math.inf),
        1: (1e-4 / z_last, 1e4 / z_first),
        2: (0.0, math.inf),
        3: (z_first * 1e-12, z_last),
    }
    parameters = []
    for slot, name in enumerate(names):
        lower, upper = default[slot]
        if name in bounds:
            if from_params:
                low, high = bounds[name]
                lower = low if math.isfinite(low) else lower
                upper = high if math.isfinite(high) else upper
                where = f"the search range [{lower:g}, {upper:g}] of parameter {name!r}"
            else:
                lower, upper = (check.real_scalar(b, f"bounds[{name!r}]") for b in bounds[name])
                where = f"bounds[{name!r}]"
            if not lower < upper:
                raise InvalidParameterError(f"{where} must have lower < upper")
            if _LOG_SLOTS[slot] and lower <= 0:
                raise InvalidParameterError(f"{where} must be positive")
        value = fixed.get(name, start[slot])
        if name not in fixed:
            value = _clip(value, lower, upper)
            if _LOG_SLOTS[slot] and value <= 0:
                value = lower if lower > 0 else 1.0
        parameters.append(
            GlobalParameter(
                name=name,
                value=value,
                log=_LOG_SLOTS[slot],
                fixed=name in fixed,
                lower=lower,
                upper=upper,
            )
        )
    return parameters


def _clip(value, lower, upper):
    return min(max(value, lower), upper) if math.isfinite(upper) else max(value, lower)


def _check_fixed(fixed, names, domain, label="fixed[{!r}]"):
    """The held values, checked (``label`` names one of them in an error)."""
    fixed = check_mapping(fixed, names, "fixed", domain)
    for slot, name in enumerate(names):
        if name in fixed:
            where = label.format(name)
            value = check.real_scalar(fixed[name], where, _UNITS[domain][name])
            if _LOG_SLOTS[slot] and value <= 0:
                raise InvalidParameterError(f"{where} must be positive, got {value:g}")
            if value < 0:
                raise InvalidParameterError(f"{where} must be non-negative, got {value:g}")
            fixed[name] = value
    return fixed


def _requested(params, fixed, bounds, names, domain):
    """(fixed, bounds, starting values) asked for by ``params`` or by ``fixed`` and
    ``bounds``."""
    if params is None:
        fixed = _check_fixed(fixed, names, domain)
        return fixed, check_mapping(bounds, names, "bounds", domain), {}
    if fixed is not None or bounds is not None:
        raise InvalidParameterError("give params, or fixed and bounds, not both")
    requested = split(params, names, f"the {domain} domain")
    held = _check_fixed(requested.held, names, domain, label="held parameter {!r}")
    return held, requested.ranges, requested.starts


def fit(
    data: Run | tuple[ArrayLike, ArrayLike],
    *,
    domain: str = "slip",
    velocity: float | None = None,
    fixed: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    weights: ArrayLike | None = None,
    sigma: float | ArrayLike | None = None,
    window: tuple[float, float] | None = None,
    profile: bool = True,
    params: Parameters | Iterable[Parameter] | None = None,
) -> FitResult:
    """Fit Eq. 3 to one friction curve, with no initial guess.

    Parameters
    ----------
    data : Run or (array_like, array_like)
        A :class:`granflow.Run` (its ``slip`` or ``t`` and ``force``; rows with a missing value
        are skipped) or a pair ``(x, force)`` in SI units: slip [m] or time [s], force [N].
        The abscissa must increase strictly.
    domain : {"slip", "time"}
        Fit F(x) with ``a, alpha, Fd, x0`` or F(t) with ``a, k, Fd, t0``.
    velocity : float, optional
        Sliding velocity [m/s]; stored for :meth:`FitResult.to_params` in the time domain
        (a Run supplies its nominal velocity).
    fixed : mapping of str to float, optional
        Parameters held at a value [SI], e.g. ``{"Fd": 10e-3}``.
    bounds : mapping of str to (float, float), optional
        Search ranges [SI] replacing the defaults (a, Fd >= 0; alpha in
        [1e-4 / x_last, 1e4 / x_first]; x0 in [1e-12 x_first, x_last]).
    weights : array_like, optional
        Per-point weights w (residuals are ``w (data - model)``); the covariance is then
        scaled by the reduced chi-square. Points of weight 0 are dropped.
    sigma : float or array_like, optional
        Known noise standard deviation [N]; weights 1/sigma and an unscaled covariance.
    window : (float, float), optional
        Fit only ``start <= x <= stop`` [m or s]; default: every point with x > 0.
    profile : bool
        Profile-likelihood intervals for alpha (k) and x0 (t0); False gives Wald intervals
        for all (faster).
    params : Parameters or sequence of Parameter, optional
        Instead of ``fixed`` and ``bounds``: :class:`granflow.fitting.Parameter` s by name.
        One with ``vary=False`` is held at its value; the others are searched in
        ``[min, max]`` (an infinite side keeps the default range), and their values make one
        more start beside those read from the curve.

    Returns
    -------
    FitResult

    Raises
    ------
    InvalidParameterError
        An unknown parameter name, a held value or search range that Eq. 3 cannot take,
        ``params`` together with ``fixed`` or ``bounds``.
    InvalidDataError
        NaN or infinite values, a non-increasing abscissa, fewer than 10 points.
    FitError
        Data without a stress overshoot (unless a is fixed), or a curve still rising at the
        end of the window.

    Examples
    --------
    >>> import numpy as np, granflow
    >>> p = granflow.Params.from_time_domain(3.31e-3, 0.036, 0.23, 10e-3, 0.86e-6)
    >>> t = np.linspace(0.5, 600, 600)
    >>> F = granflow.friction_time(t, p, 0.86e-6)
    >>> result = granflow.fit((t, F), domain="time", velocity=0.86e-6)
    >>> round(result.params["k"], 4), round(result.params["t0"], 3)
    (0.036, 0.23)
    """
    names = parameter_names(domain)
    fixed, bounds, guesses = _requested(params, fixed, bounds, names, domain)
    prepared = prepare(data, domain, velocity, window, weights, sigma)
    z, y = prepared.z, prepared.y
    features = curve_features(z, y)
    slot_fixed = {SLOTS[names.index(n)]: v for n, v in fixed.items()}
    require_overshoot(features, slot_fixed, SLOTS)
    starts = start_candidates(z, y, slot_fixed, features)
    parameters = _global_parameters(names, starts[0], fixed, bounds, z, params is not None)
    if guesses:
        guess = [
            _clip(guesses[p.name], p.lower, p.upper) if p.name in guesses else start
            for p, start in zip(parameters, starts[0], strict=True)
        ]
        starts = [*starts, tuple(guess)]
    curve = Curve(z, y, prepared.w, tuple((slot, 1.0) for slot in range(4)))
    problem = Problem([curve], parameters)
    unweighted = bool(np.all(prepared.w == 1.0))
    noise = features["noise"] if unweighted else _noise_level(prepared.w * y)
    solution = multistart(
        problem,
        starts,
        noise,
        restart=None if names[3] in fixed else (lambda values: _held_restart(values, float(z[0]))),
        insist=features["peak_index"] < _FEW_RISE_POINTS,
    )
    return _result(problem, solution, prepared, domain, names, fixed, profile)


def _held_restart(values, first):
    """A restart with x0 below the first point when the optimum holds points at F(x0).

    Each data point that x0 passes puts a kink into chi-square (the point changes from the
    curve to the held initial force), which can trap the optimiser above the first points.
    The restart puts x0 (t0), the fourth parameter, at 0.99 times the first point ``first``.
    Returns the new values, or None when x0 is already below the first point.
    """
    if values[3] <= first:
        return None
    values = values.copy()
    values[3] = 0.99 * first
    return values


def _interval(problem, solution, stats, index, name, *, profile, exact_data, variance):
    """(ci95, method, at_bound, caveat) of one parameter of a single-curve fit."""
    parameter = problem.parameters[index]
    value = stats.params[name]
    if parameter.fixed:
        return (value, value), "fixed", False, None
    u = solution.x[problem.free.index(index)]
    lower_u, upper_u = parameter.internal_bounds()
    at_bound = bool(
        (math.isfinite(lower_u) and u - lower_u < 1e-6 * max(1.0, abs(lower_u)))
        or (math.isfinite(upper_u) and upper_u - u < 1e-6 * max(1.0, abs(upper_u)))
    )
    if parameter.log and profile and stats.invertible and not exact_data:
        sd_u = stats.stderr[name] / parameter.derivative(u)
        values = problem.values(solution.x)
        interval, exact = profile_interval(
            problem, values, index, variance, stats.chisqr, WALD_Z * sd_u, solution.hessian
        )
        caveat = None if exact else f"the 95 % profile interval of {name} reaches a search bound"
        return interval, "profile", at_bound, caveat
    return stats.ci95[name], "wald", at_bound, None


def _result(problem, solution, prepared, domain, names, fixed, profile):
    values = problem.values(solution.x)
    stats = fit_statistics(
        problem, values, names, sigma_known=prepared.sigma_known, hessian=solution.hessian
    )
    # data fitted to rounding error (synthetic, noise-free): chi-square has no scale left
    # to profile against, so every interval is a Wald interval
    exact_data = stats.chisqr <= stats.ndata * (1e-12 * problem.force_scale) ** 2
    messages = [solution.message]
    variance = 1.0 if prepared.sigma_known else stats.redchi
    ci95, ci_method, at_bound = {}, {}, {}
    for index, name in enumerate(names):
        interval, method, bound, caveat = _interval(
            problem,
            solution,
            stats,
            index,
            name,
            profile=profile,
            exact_data=exact_data,
            variance=variance,
        )
        ci95[name], ci_method[name], at_bound[name] = interval, method, bound
        if caveat:
            messages.append(caveat)
    success = bool(solution.status > 0 and stats.invertible)
    if not stats.invertible:
        messages.append("the parameters are not all determined by the data (singular J^T J)")
    bound_names = [n_ for n_, flag in at_bound.items() if flag]
    if bound_names:
        messages.append(f"at a bound of the search range: {', '.join(bound_names)}")
    verdict = not_a_fit(stats, ci95, bound_names, names, fixed)
    if verdict:
        success = False
        messages.append(verdict)
    if not success or bound_names:
        warnings.warn("; ".join(messages), ConvergenceWarning, stacklevel=3)
    frozen = FrozenMap({k: (float(v[0]), float(v[1])) for k, v in ci95.items()})
    return FitResult(
        **stats.fit_fields(ci95=frozen),
        success=success,
        message="; ".join(messages),
        domain=domain,
        names=names,
        ci_method=FrozenMap(ci_method),
        correl=stats.correl,
        fixed=tuple(n_ for n_ in names if n_ in fixed),
        at_bound=FrozenMap(at_bound),
        nfev=int(solution.nfev),
        rsquared=stats.rsquared,
        x=read_only(prepared.z),
        data=read_only(prepared.y),
        best_fit=read_only(stats.best_fit),
        residuals=read_only(stats.residuals),
        weights=read_only(prepared.w),
        velocity=prepared.velocity,
        window=prepared.window,
        sigma_known=prepared.sigma_known,
        name=prepared.name,
        dropped=FrozenMap(prepared.dropped),
    )
