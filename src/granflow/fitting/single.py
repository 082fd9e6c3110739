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

import math
import warnings
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from granflow import _validate as check
from granflow.errors import (
    ConvergenceWarning,
    FitError,
    GranflowError,
    InvalidDataError,
    InvalidParameterError,
)
from granflow.fitting.engine import (
    SLOTS,
    WALD_Z,
    Curve,
    GlobalParameter,
    Problem,
    covariance,
    model_only,
    profile_interval,
)
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
from granflow.fitting.statistics import estimates, statistics, statistics_lines
from granflow.model.params import Params
from granflow.model.run import Run
from granflow.model.special import scaled_ei_diff

__all__ = ["FitResult", "fit", "fit_many", "parameter_names"]

_NAMES = {"slip": ("a", "alpha", "Fd", "x0"), "time": ("a", "k", "Fd", "t0")}
_UNITS = {
    "slip": {"a": "N", "alpha": "1/m", "Fd": "N", "x0": "m"},
    "time": {"a": "N", "k": "1/s", "Fd": "N", "t0": "s"},
}
_ABSCISSA = {"slip": ("x", "m"), "time": ("t", "s")}
_LOG_SLOTS = (False, True, False, True)
_MIN_POINTS = 10
_START_PEAK_SLIPS = (0.9, 0.5, 1.6)  # trial alpha * x_peak for the starts
_FEW_RISE_POINTS = 50  # below this many points up to the peak, always check x0 < x_first


def parameter_names(domain="slip"):
    """The four parameter names of a domain: ``("a", "alpha", "Fd", "x0")`` or
    ``("a", "k", "Fd", "t0")``."""
    if domain not in _NAMES:
        raise InvalidParameterError(f"domain must be 'slip' or 'time', got {domain!r}")
    return _NAMES[domain]


# --------------------------------------------------------------------------- data at the door


@dataclass(frozen=True)
class _Data:
    z: np.ndarray
    y: np.ndarray
    w: np.ndarray
    sigma_known: bool
    velocity: float | None
    window: tuple
    name: str | None


def _as_curve_arrays(data, domain):
    """(z, y, velocity, name) from a Run or a pair of arrays; Run rows with NaN are dropped."""
    if isinstance(data, Run):
        z = data.slip if domain == "slip" else data.t
        keep = np.isfinite(z) & np.isfinite(data.force)
        if not keep.any():
            raise InvalidDataError(
                f"{data.name}: no point has both a finite {'slip' if domain == 'slip' else 't'} "
                "and a finite force"
            )
        return np.array(z[keep]), np.array(data.force[keep]), data.nominal_velocity, data.name
    if not isinstance(data, tuple | list) or len(data) != 2:
        raise InvalidDataError(
            "data must be a granflow.Run or a pair (abscissa, force) of arrays, "
            f"got {type(data).__name__}"
        )
    abscissa, unit = _ABSCISSA[domain]
    arrays = []
    for values, name, unit_ in ((data[0], abscissa, unit), (data[1], "force", "N")):
        try:
            array = np.array(values, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InvalidDataError(f"{name} must be an array of real numbers: {exc}") from None
        if array.ndim != 1:
            raise InvalidDataError(f"{name} must be one-dimensional, got shape {array.shape}")
        bad = ~np.isfinite(array)
        if bad.any():
            index = int(np.argmax(bad))
            raise InvalidDataError(
                f"{name} must be finite, got {array[index]} {unit_} at index {index}"
            )
        arrays.append(array)
    if arrays[0].shape != arrays[1].shape:
        raise InvalidDataError(
            f"{abscissa} and force must have the same length, got {arrays[0].size} and "
            f"{arrays[1].size}"
        )
    return arrays[0], arrays[1], None, None


def _prepare(data, domain, velocity, window, weights, sigma):
    z, y, run_velocity, name = _as_curve_arrays(data, domain)
    abscissa, unit = _ABSCISSA[domain]
    steps = np.diff(z)
    if np.any(steps <= 0):
        index = int(np.argmax(steps <= 0))
        raise InvalidDataError(
            f"{abscissa} must increase strictly, but {abscissa}[{index + 1}] = "
            f"{z[index + 1]:.6g} {unit} follows {abscissa}[{index}] = {z[index]:.6g} {unit}"
        )
    if velocity is None:
        velocity = run_velocity
    elif velocity is not None:
        velocity = check.positive(velocity, "velocity", "m/s")
    n_all = z.size
    if weights is not None and sigma is not None:
        raise InvalidParameterError("give weights or sigma, not both")
    if sigma is not None:
        w = 1.0 / _per_point(sigma, n_all, "sigma", positive=True)
    elif weights is not None:
        w = _per_point(weights, n_all, "weights", positive=False)
    else:
        w = np.ones(n_all)
    if window is None:
        start, stop = 0.0, math.inf
        keep = z > 0
    else:
        if len(window) != 2:
            raise InvalidParameterError(f"window must be a pair (start, stop), got {window!r}")
        start = check.real_scalar(window[0], "window start", unit)
        stop = math.inf if window[1] is None else check.real_scalar(window[1], "window stop", unit)
        if stop <= start:
            raise InvalidParameterError(f"window must have start < stop, got {window!r}")
        keep = (z >= start) & (z <= stop) & (z > 0)
    keep &= w > 0
    z, y, w = z[keep], y[keep], w[keep]
    if z.size < _MIN_POINTS:
        raise InvalidDataError(
            f"a fit needs at least {_MIN_POINTS} points with positive {abscissa} and positive "
            f"weight inside the window, got {z.size}"
        )
    used = (float(z[0]), float(z[-1]))
    return _Data(z, y, w, sigma is not None, velocity, used, name)


def _per_point(values, n, name, positive):
    array = np.broadcast_to(np.asarray(values, dtype=np.float64), (n,)).copy()
    if not np.all(np.isfinite(array)):
        raise InvalidParameterError(f"{name} must be finite")
    if positive and np.any(array <= 0):
        raise InvalidParameterError(f"{name} must be positive")
    if np.any(array < 0):
        raise InvalidParameterError(f"{name} must be non-negative")
    return array


def _check_mapping(mapping, names, what, domain):
    mapping = dict(mapping or {})
    for key in mapping:
        if key not in names:
            raise InvalidParameterError(
                f"{what}: unknown parameter {key!r} for the {domain} domain; "
                f"the parameters are {', '.join(names)}"
            )
    return mapping


# --------------------------------------------------------------------------- starting values


def _smooth(y, width):
    """Running mean over ``width`` points (edges padded with the end values)."""
    if width < 2:
        return y.copy()
    padded = np.concatenate([np.full(width // 2, y[0]), y, np.full(width - 1 - width // 2, y[-1])])
    total = np.concatenate([[0.0], np.cumsum(padded)])
    return (total[width:] - total[:-width]) / width


def _noise_level(y):
    """Robust estimate of the point-to-point noise (median absolute second difference)."""
    if y.size < 4:
        return 0.0
    second = np.diff(y, 2)
    return float(1.4826 * np.median(np.abs(second - np.median(second))) / math.sqrt(6.0))


def curve_features(z, y):
    """Plateau, overshoot and early rise of a friction curve, for starting values.

    Returns a dict with ``plateau``, ``peak_z``, ``peak_force``, ``overshoot`` and ``noise``.
    """
    n = z.size
    # smooth over at most a quarter of the rise, so that a narrow overshoot survives
    rough_peak = int(np.argmax(_smooth(y, max(1, min(5, n // 50)))))
    width = max(1, min(n // 50, rough_peak // 4))
    smooth = _smooth(y, width)
    tail = y[int(0.9 * n) :]
    plateau = float(np.mean(tail))
    index = int(np.argmax(smooth))
    noise = _noise_level(y)
    return {
        "plateau": plateau,
        "peak_index": index,
        "peak_z": float(z[index]),
        "peak_force": float(smooth[index]),
        "overshoot": float(smooth[index] - plateau),
        "noise": noise,
        # the largest of n / width smoothed noise values, minus the plateau, exceeds
        # this only by chance of order 1e-6
        "resolution": noise
        * (math.sqrt(2.0 * math.log(max(n / width, 2.0))) + 5.0)
        * math.sqrt(1.0 / width + 1.0 / max(tail.size, 1)),
        "smooth": smooth,
    }


def _x0_from_rise(z, y, smooth, index, a, alpha, Fd):
    """x0 such that the model passes through the smoothed curve half-way up the rise.

    F at that point decreases monotonically with x0; it is evaluated for 64 trial values of
    x0 in one vectorised call and the crossing is interpolated in log x0.
    """
    half = 0.5 * smooth[index]
    rising = np.nonzero(smooth[: index + 1] >= half)[0]
    point = int(rising[0]) if rising.size else index
    # the raw data near the point: a running mean is biased upwards on a steep rise
    z_rise, f_rise = float(z[point]), float(np.mean(y[max(point - 1, 0) : point + 2]))
    trial = z_rise * np.exp(-np.linspace(26.0, 1e-6, 64))  # x0 from 5e-12 z_rise to z_rise
    s, s0 = alpha * z_rise, alpha * trial
    force = a * scaled_ei_diff(s, s0) - Fd * math.expm1(-s)
    above = np.nonzero(force <= f_rise)[0]
    if not np.all(np.isfinite(force)) or above.size == 0 or above[0] == 0:
        return z_rise * 0.01
    k = int(above[0])
    log_x0 = np.log(trial[k - 1 : k + 1])
    weight = (force[k - 1] - f_rise) / (force[k - 1] - force[k])
    return float(math.exp(log_x0[0] + weight * (log_x0[1] - log_x0[0])))


def _starts(z, y, fixed, features):
    """Candidate (a, alpha, Fd, x0) starts from the curve features, honouring fixed values."""
    Fd = fixed.get("Fd", max(features["plateau"], 0.0))
    overshoot = max(features["peak_force"] - Fd, features["overshoot"], 1e-12)
    z_peak = max(features["peak_z"], z[0])
    candidates = []
    for peak_slip in _START_PEAK_SLIPS:
        alpha = fixed.get("alpha", peak_slip / z_peak)
        a = fixed.get("a", overshoot * alpha * z_peak)
        rise = _x0_from_rise(z, y, features["smooth"], features["peak_index"], a, alpha, Fd)
        # the initial state from the rise, or just before the first point
        for x0 in (rise, 0.5 * z[0]):
            candidates.append((a, alpha, Fd, fixed.get("x0", x0)))
    return candidates


# --------------------------------------------------------------------------- the result


def _frozen(mapping):
    return FrozenMap(dict(mapping))


_ARRAYS = ("x", "data", "best_fit", "residuals", "weights")


@dataclass(frozen=True, eq=False)
class FitResult(ValueEquality):
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
    """

    domain: str
    names: tuple
    params: FrozenMap
    stderr: FrozenMap
    ci95: FrozenMap
    ci_method: FrozenMap
    covar: FrozenMap
    correl: FrozenMap
    fixed: tuple
    at_bound: FrozenMap
    success: bool
    message: str
    nfev: int
    ndata: int
    nfree: int
    chisqr: float
    redchi: float
    aic: float
    bic: float
    rsquared: float
    x: np.ndarray
    data: np.ndarray
    best_fit: np.ndarray
    residuals: np.ndarray
    weights: np.ndarray
    velocity: float | None
    window: tuple
    sigma_known: bool
    name: str | None = None

    def __repr__(self):
        values = ", ".join(f"{n}={self.params[n]:.4g}" for n in self.names)
        return (
            f"FitResult({self.domain}, success={self.success}, {values}, "
            f"redchi={self.redchi:.3g}, ndata={self.ndata})"
        )

    @property
    def units(self):
        """Mapping of parameter name to its SI unit."""
        return _UNITS[self.domain]

    def to_params(self, velocity=None):
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

    def model(self, x):
        """The fitted curve at abscissae ``x`` [m or s] (held at the initial force below x0)."""
        z = check.real_array(x, "x", _ABSCISSA[self.domain][1]).ravel()
        return model_only(np.ascontiguousarray(z), *(self.params[n] for n in self.names))

    def report(self):
        """A text report in the manner of lmfit's ``fit_report``."""
        lines = statistics_lines(
            self,
            title="Fit Statistics",
            extra=(("domain", self.domain), ("# function evals", self.nfev)),
        )
        lines += [
            f"    R-squared          = {self.rsquared:.8f}",
            f"    window             = [{self.window[0]:.6g}, {self.window[1]:.6g}] "
            f"{_ABSCISSA[self.domain][1]}",
            "[[Variables]]",
        ]
        for n in self.names:
            unit = self.units[n]
            if n in self.fixed:
                lines.append(f"    {n:<5} = {self.params[n]:.8g} {unit} (fixed)")
                continue
            value, err = self.params[n], self.stderr[n]
            rel = f" ({100 * err / abs(value):.2f}%)" if value else ""
            low, high = self.ci95[n]
            flag = " at bound" if self.at_bound[n] else ""
            lines.append(
                f"    {n:<5} = {value:.8g} +/- {err:.4g}{rel} {unit}  "
                f"95%: [{low:.6g}, {high:.6g}] ({self.ci_method[n]}){flag}"
            )
        lines.append("[[Correlations]] (unreported correlations are < 0.100)")
        free = [n for n in self.names if n not in self.fixed]
        pairs = [(self.correl[p][q], p, q) for i, p in enumerate(free) for q in free[i + 1 :]]
        for value, p, q in sorted(pairs, key=lambda item: -abs(item[0])):
            if abs(value) >= 0.1:
                lines.append(f"    C({p}, {q}) = {value:+.4f}")
        return "\n".join(lines)

    def to_dict(self, include_arrays=True):
        """JSON-safe mapping of the result; :meth:`from_dict` inverts it.

        Parameters
        ----------
        include_arrays : bool
            Include ``x``, ``data``, ``best_fit``, ``residuals`` and ``weights`` as lists
            (False: a compact summary, which :meth:`from_dict` rebuilds with empty arrays).
        """
        out = {
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
        }
        if include_arrays:
            for key in _ARRAYS:
                out[key] = getattr(self, key)
        return encode(out)

    @classmethod
    def from_dict(cls, d):
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
            domain=d["domain"],
            names=names,
            params=numbers(d["params"]),
            stderr=numbers(d["stderr"]),
            ci95=intervals(d["ci95"]),
            ci_method=FrozenMap(d["ci_method"]),
            covar=matrix(d["covar"]),
            correl=matrix(d["correl"]),
            fixed=tuple(d["fixed"]),
            at_bound=FrozenMap(d["at_bound"]),
            success=d["success"],
            message=d["message"],
            nfev=d["nfev"],
            ndata=d["ndata"],
            nfree=d["nfree"],
            chisqr=number(d["chisqr"]),
            redchi=number(d["redchi"]),
            aic=number(d["aic"]),
            bic=number(d["bic"]),
            rsquared=number(d["rsquared"]),
            **{key: read_only(d.get(key, [])) for key in _ARRAYS},
            velocity=None if d["velocity"] is None else float(d["velocity"]),
            window=tuple(number(v) for v in d["window"]),
            sigma_known=d["sigma_known"],
            name=d.get("name"),
        )

    def plot(self, ax=None, *, residual_ax=None):
        """Data, fit and residuals; see :func:`granflow.plotting.plot_fit`."""
        from granflow.plotting.fits import plot_fit

        return plot_fit(self, ax=ax, residual_ax=residual_ax)


# --------------------------------------------------------------------------- the fit


def _global_parameters(names, start, fixed, bounds, z):
    """The four global parameters with their default search ranges (in SI)."""
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
            lower, upper = (check.real_scalar(b, f"bounds[{name!r}]") for b in bounds[name])
            if not lower < upper:
                raise InvalidParameterError(f"bounds[{name!r}] must have lower < upper")
            if _LOG_SLOTS[slot] and lower <= 0:
                raise InvalidParameterError(f"bounds[{name!r}] must be positive")
        value = fixed.get(name, start[slot])
        if name not in fixed:
            value = min(max(value, lower), upper) if math.isfinite(upper) else max(value, lower)
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


def _check_fixed(fixed, names, domain):
    fixed = _check_mapping(fixed, names, "fixed", domain)
    for slot, name in enumerate(names):
        if name in fixed:
            value = check.real_scalar(fixed[name], f"fixed[{name!r}]", _UNITS[domain][name])
            if _LOG_SLOTS[slot] and value <= 0:
                raise InvalidParameterError(f"fixed[{name!r}] must be positive, got {value:g}")
            if value < 0:
                raise InvalidParameterError(f"fixed[{name!r}] must be non-negative, got {value:g}")
            fixed[name] = value
    return fixed


def _require_overshoot(features, fixed, names):
    """Refuse data without a stress overshoot when a and x0 are to be fitted."""
    if names[0] in fixed:
        return
    overshoot = features["overshoot"]
    resolution = max(features["resolution"], 1e-6 * abs(features["peak_force"]))
    if overshoot <= resolution:
        raise FitError(
            "the data show no stress overshoot (the smoothed maximum exceeds the final "
            f"plateau by {overshoot:.3g} N, within the noise allowance {resolution:.3g} N), "
            "so the aging amplitude a and the initial state cannot be determined; fix them "
            "(fixed={'a': ...}) or compare simpler models with granflow.compare_models"
        )
    if features["peak_index"] >= 0.95 * features["smooth"].size:
        raise FitError(
            "the force still rises at the end of the window: the overshoot and the plateau Fd "
            "are not in the data; extend the window or fix Fd"
        )


def fit(
    data,
    *,
    domain="slip",
    velocity=None,
    fixed=None,
    bounds=None,
    weights=None,
    sigma=None,
    window=None,
    profile=True,
):
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

    Returns
    -------
    FitResult

    Raises
    ------
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
    fixed = _check_fixed(fixed, names, domain)
    bounds = _check_mapping(bounds, names, "bounds", domain)
    prepared = _prepare(data, domain, velocity, window, weights, sigma)
    z, y = prepared.z, prepared.y
    features = curve_features(z, y)
    slot_fixed = {SLOTS[names.index(n)]: v for n, v in fixed.items()}
    _require_overshoot(features, slot_fixed, SLOTS)
    starts = _starts(z, y, slot_fixed, features)
    parameters = _global_parameters(names, starts[0], fixed, bounds, z)
    curve = Curve(z, y, prepared.w, tuple((slot, 1.0) for slot in range(4)))
    problem = Problem([curve], parameters)
    unweighted = bool(np.all(prepared.w == 1.0))
    noise = features["noise"] if unweighted else _noise_level(prepared.w * y)
    solution = _multistart(problem, starts, noise, features["peak_index"])
    return _result(problem, solution, prepared, domain, names, fixed, profile)


@dataclass
class _Solution:
    x: np.ndarray
    status: int
    message: str
    nfev: int
    hessian: np.ndarray | None = None  # J^T J in internal coordinates at x, when known


def _held_restart(problem, u):
    """A restart with x0 below the first point when the optimum holds points at F(x0).

    Each data point that x0 passes puts a kink into chi-square (the point changes from the
    curve to the held initial force), which can trap the optimiser above the first points.
    The restart puts x0 at 0.99 times the first point (see :func:`_multistart` for when it
    is pursued). Returns the start in internal coordinates, or None.
    """
    index = 3  # x0 (t0) is the fourth global parameter of a single-curve problem
    if index not in problem.free:
        return None
    first = float(problem.curves[0].z[0])
    values = problem.values(u)
    if values[index] <= first:
        return None
    values[index] = 0.99 * first
    return problem.internal(values)


def _multistart(problem, starts, noise, rise_points):
    """Levenberg-Marquardt from the start with the smallest chi-square, confirmed by the others.

    When the converged fit leaves a residual variance above twice the point-to-point noise
    (``noise``, from the data's second differences), the other starts are tried as well and
    the best optimum is kept. If LM does not converge, scipy's least_squares (trust-region
    reflective) takes over.
    """
    ranked = []
    for start in starts:
        u = problem.internal(list(start))
        cost = problem.chisqr(problem.values(u), stride=8)
        ranked.append((cost if math.isfinite(cost) else math.inf, u))
    ranked.sort(key=lambda item: item[0])
    expected = 2.0 * noise**2 * max(problem.ndata - len(problem.free), 1)
    best, nfev = None, len(starts)
    for count, (_, u_start) in enumerate(ranked, start=1):
        u, cost, converged, steps, hessian = problem.lm(u_start, max_iter=200, rtol=1e-10)
        nfev += steps
        if best is None or cost < best[1]:
            best = (u, cost, converged, count, hessian)
        if noise > 0 and best[1] <= expected:
            break
    u, cost, converged, tried, hessian = best
    start = _held_restart(problem, u)
    if start is not None:
        start_cost, g, H = problem.state(start, problem.free)
        nfev += 1
        try:
            promised = start_cost + 0.5 * float(g @ np.linalg.solve(H, -g))
        except np.linalg.LinAlgError:
            promised = -math.inf
        # pursue it when the step promises a gain, when chi-square exceeds what the noise
        # allows (5 standard deviations of chi-square plus the error of the noise estimate),
        # or when few points describe the rise, so that one held point weighs much
        dof = max(problem.ndata - len(problem.free), 1)
        implausible = noise <= 0 or cost > (1.0 + 10.0 / math.sqrt(dof)) * dof * noise**2
        if promised < cost or implausible or rise_points < _FEW_RISE_POINTS:
            u_new, cost_new, converged_new, steps, hessian_new = problem.lm(
                start, max_iter=200, rtol=1e-10
            )
            nfev += steps
            if cost_new < cost:
                u, cost, converged, hessian = u_new, cost_new, converged_new, hessian_new
    if converged:
        message = f"converged (Levenberg-Marquardt, {tried} of {len(starts)} starts)"
        return _Solution(u, 1, message, nfev, hessian)
    try:
        solution = problem.solve(u)
    except ValueError as exc:  # e.g. residuals that are not finite at the start
        return _Solution(u, 0, f"the optimiser failed: {exc}", nfev)
    return _Solution(solution.x, solution.status, solution.message, nfev + solution.nfev)


def _result(problem, solution, prepared, domain, names, fixed, profile):
    values = problem.values(solution.x)
    n, nfree = problem.ndata, len(problem.free)
    best_fit = model_only(prepared.z, *values)
    residuals = prepared.y - best_fit
    chisqr = float(np.sum((prepared.w * residuals) ** 2))
    dof = max(n - nfree, 1)
    redchi = chisqr / dof
    variance = 1.0 if prepared.sigma_known else redchi
    covar_free, invertible = covariance(problem, values, variance, solution.hessian)
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
    ci95, ci_method, at_bound = {}, {}, {}
    # data fitted to rounding error (synthetic, noise-free): chi-square has no scale left
    # to profile against, so every interval is a Wald interval
    exact_data = chisqr <= n * (1e-12 * problem.force_scale) ** 2
    messages = [solution.message]
    u_all = dict(zip(problem.free, solution.x, strict=True))
    for index, name in enumerate(names):
        parameter = problem.parameters[index]
        if parameter.fixed:
            ci95[name] = (values[index], values[index])
            ci_method[name] = "fixed"
            at_bound[name] = False
            continue
        lower_u, upper_u = parameter.internal_bounds()
        u = u_all[index]
        at_bound[name] = bool(
            (math.isfinite(lower_u) and u - lower_u < 1e-6 * max(1.0, abs(lower_u)))
            or (math.isfinite(upper_u) and upper_u - u < 1e-6 * max(1.0, abs(upper_u)))
        )
        if parameter.log and profile and invertible and not exact_data:
            sd_u = stderr[name] / parameter.derivative(u)
            interval, exact = profile_interval(
                problem, values, index, variance, chisqr, WALD_Z * sd_u, solution.hessian
            )
            ci95[name] = interval
            ci_method[name] = "profile"
            if not exact:
                messages.append(f"the 95 % profile interval of {name} reaches a search bound")
        else:
            half = WALD_Z * stderr[name]
            ci95[name] = (values[index] - half, values[index] + half)
            ci_method[name] = "wald"
    success = bool(solution.status > 0 and invertible)
    if not invertible:
        messages.append("the parameters are not all determined by the data (singular J^T J)")
    bound_names = [n_ for n_, flag in at_bound.items() if flag]
    if bound_names:
        messages.append(f"at a bound of the search range: {', '.join(bound_names)}")
    total = float(np.sum((prepared.y - np.mean(prepared.y)) ** 2))
    rsquared = 1.0 - float(residuals @ residuals) / total if total > 0 else math.nan
    log_term = n * math.log(chisqr / n) if chisqr > 0 else -math.inf
    if not success or bound_names:
        warnings.warn("; ".join(messages), ConvergenceWarning, stacklevel=3)
    return FitResult(
        domain=domain,
        names=names,
        params=_frozen({name: float(values[i]) for i, name in enumerate(names)}),
        stderr=_frozen(stderr),
        ci95=_frozen({k: (float(v[0]), float(v[1])) for k, v in ci95.items()}),
        ci_method=_frozen(ci_method),
        covar=_frozen({k: _frozen(v) for k, v in covar.items()}),
        correl=_frozen({k: _frozen(v) for k, v in correl.items()}),
        fixed=tuple(n_ for n_ in names if n_ in fixed),
        at_bound=_frozen(at_bound),
        success=success,
        message="; ".join(messages),
        nfev=int(solution.nfev),
        ndata=n,
        nfree=nfree,
        chisqr=chisqr,
        redchi=redchi,
        aic=log_term + 2 * nfree,
        bic=log_term + math.log(n) * nfree,
        rsquared=rsquared,
        x=read_only(prepared.z),
        data=read_only(prepared.y),
        best_fit=read_only(best_fit),
        residuals=read_only(residuals),
        weights=read_only(prepared.w),
        velocity=prepared.velocity,
        window=prepared.window,
        sigma_known=prepared.sigma_known,
        name=prepared.name,
    )


# --------------------------------------------------------------------------- batches


def _portable(data):
    """A Run as a picklable tuple (its metadata mapping cannot cross a process boundary)."""
    if isinstance(data, Run):
        columns = {
            name: np.asarray(getattr(data, name)) for name in ("t", "slip", "velocity", "force")
        }
        return ("run", columns, data.control, dict(data.meta))
    return data


def _fit_item(item):
    """Fit one (data, options) item; returns the FitResult or the GranflowError raised."""
    data, options = item
    if isinstance(data, tuple) and len(data) == 4 and data[0] == "run":
        _, columns, control, meta = data
        data = Run(control=control, meta=meta, **columns)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            return fit(data, **options)
    except GranflowError as exc:
        return exc


def fit_many(datasets, *, jobs=2, errors="raise", **options):
    """Fit many curves over local processes, in the order given.

    Parameters
    ----------
    datasets : iterable
        Items :func:`fit` accepts (Runs or pairs of arrays).
    jobs : int
        Worker processes (1: in this process, no pool).
    errors : {"raise", "return"}
        On a curve that cannot be fitted, raise its error, or put the exception in its place
        in the returned list and go on with the rest.
    **options
        Keyword arguments of :func:`fit`, the same for every curve.

    Returns
    -------
    list of FitResult (or of the exceptions, with ``errors="return"``)

    Examples
    --------
    >>> import numpy as np, granflow
    >>> p = granflow.Params(3e-3, 4e4, 10e-3, 2e-7)
    >>> x = np.linspace(1e-6, 5e-4, 400)
    >>> curves = [(x, granflow.friction_slip(x, p.replace(Fd=Fd))) for Fd in (8e-3, 10e-3)]
    >>> [round(r.params["Fd"] * 1e3, 3) for r in granflow.fit_many(curves, jobs=1)]
    [8.0, 10.0]
    """
    if errors not in ("raise", "return"):
        raise InvalidParameterError(f"errors must be 'raise' or 'return', got {errors!r}")
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InvalidParameterError(f"jobs must be a positive integer, got {jobs!r}")
    items = [(_portable(data), options) for data in datasets]
    if jobs == 1 or len(items) <= 1:
        results = [_fit_item(item) for item in items]
    else:
        chunk = max(1, len(items) // (4 * jobs))
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            results = list(pool.map(_fit_item, items, chunksize=chunk))
    if errors == "raise":
        for index, result in enumerate(results):
            if isinstance(result, Exception):
                raise type(result)(f"dataset {index}: {result}") from result
    return results
