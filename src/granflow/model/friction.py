"""The aging-rejuvenation friction model of Farain & Bonn: pure functions, SI units.

In the slip domain (x = v t, the primary form) Eq. 2 of the paper reads

    dF/dx = a/x - alpha (F - Fd),

and its solution from the initial state x0 on (Eq. 3) is, with s = alpha x, s0 = alpha x0,

    F(x) = Fd + (F_init - Fd) exp(-(s - s0)) + a exp(-s) [Ei(s) - Ei(s0)].

The paper's initial condition is ``F_init = Fd (1 - exp(-s0))``, which turns the solution into
``a exp(-s) [Ei(s) - Ei(s0)] + Fd (1 - exp(-s))``; it is the default everywhere here. Under an
imposed velocity v the time-domain form is the same curve at x = v t (k = alpha v,
t0 = x0 / v): the transient depends on slip only, not on the rate.

The model starts at x0. By default (``below="raise"``) slips below it are rejected (a relative
tolerance of 1e-12 absorbs round-off in ``v * t0``); ``below="hold"`` holds the force at its
initial value F(x0) there, the rule the fits use. Every value comes from the compiled point
kernel :mod:`granflow.model.kernel`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import brentq

from granflow import _threads
from granflow import _validate as check
from granflow.errors import GranflowError, InvalidParameterError
from granflow.model import kernel
from granflow.model.params import Params
from granflow.model.special import scaled_ei_diff_scalar, scaled_ei_scalar

if TYPE_CHECKING:
    from granflow._typing import ArrayLike, FloatArray, FloatOrArray
    from granflow.model.params import Params

__all__ = [
    "NoPeakError",
    "Peak",
    "friction_aging",
    "friction_asymptote",
    "friction_slip",
    "friction_slip_jacobian",
    "friction_time",
    "has_peak",
    "initial_force",
    "peak",
    "rhs_slip",
    "rhs_time",
    "steady_state",
]

_BELOW_X0_TOLERANCE = 1e-12


class NoPeakError(GranflowError, ValueError):
    """The friction curve has no maximum: it decreases monotonically from the initial state."""


def _evaluate_chunk(flat, out, scale, start, lowest, params, offset, paper, hold):
    """Fill ``out`` with F at ``flat``; returns the index of the first bad point, or -1."""
    p = params
    return kernel.eq3_values(
        flat, scale, lowest, start, p.a, p.alpha, p.Fd, p.x0, offset, paper, hold, out
    )


def _evaluate(values, params, F_init, *, scale=1.0, name="x", unit="m", below="raise"):
    """Friction [N] at slips (or times, with scale = velocity) given as any array_like.

    Validates in the same pass: every value must be finite and (``below="raise"``) at least
    x0 / scale. Large arrays are split over threads (the compiled loop and NumPy release the
    GIL).
    """
    hold = kernel.check_below(below) == "hold"
    start = params.x0 / scale
    paper = F_init is None
    offset = 0.0 if paper else F_init - params.Fd
    lowest = -math.inf if hold else start * (1.0 - _BELOW_X0_TOLERANCE)
    if type(values) is float:  # the scalar path: no arrays (NaN: let the array path say why)
        p = params
        value = kernel.eq3_scalar(
            values, scale, lowest, start, p.a, p.alpha, p.Fd, p.x0, offset, paper, hold
        )
        if value == value:
            return value
    array = check.float_array(values, name, unit)
    flat = np.ascontiguousarray(array).ravel()
    out = np.empty_like(flat)
    args = (scale, start, lowest, params, offset, paper, hold)
    bounds = _threads.chunks(flat.shape[0])
    if len(bounds) == 1:
        bad = _evaluate_chunk(flat, out, *args)
    else:
        results = _threads.map_chunks(
            lambda lo, hi: _evaluate_chunk(flat[lo:hi], out[lo:hi], *args), bounds
        )
        bad = next((lo + r for (lo, _), r in zip(bounds, results, strict=True) if r >= 0), -1)
    if bad >= 0:
        check.finite_at(flat[bad], bad, array.shape, name, unit)
        _check_from_start(array, start, name, unit)
    out = out.reshape(array.shape)
    return float(out) if out.ndim == 0 else out


def _check_params(params):
    if not isinstance(params, Params):
        raise InvalidParameterError(
            f"params must be a granflow.Params, got {type(params).__name__}"
        )


def _check_f_init(F_init):
    return None if F_init is None else check.non_negative(F_init, "F_init", "N")


def _check_from_start(values, start, name, unit):
    """Reject values below the initial state ``start`` (slip x0 or time t0)."""
    if values.size == 0:
        return
    index = int(np.argmin(values))
    lowest = float(values.flat[index])
    if lowest < start * (1.0 - _BELOW_X0_TOLERANCE):
        where = (
            f" at index {check.index_text(np.unravel_index(index, values.shape))}"
            if values.ndim
            else ""
        )
        raise InvalidParameterError(
            f"{name} must not lie below the initial state {start:.6g} {unit} where the model "
            f"starts, got {lowest:.6g} {unit}{where}"
        )


def _like_input(values):
    """A float for a 0-d result, the array otherwise."""
    return float(values) if np.ndim(values) == 0 else values


def friction_slip(
    x: ArrayLike, params: Params, *, F_init: float | None = None, below: str = "raise"
) -> FloatOrArray:
    """Friction force against slip, Eq. 3 in the slip domain.

    Parameters
    ----------
    x : float or array_like
        Slip [m] (the aging coordinate, which is x0 at the initial state); every value
        must be at least ``params.x0`` unless ``below="hold"``.
    params : Params
        Model parameters (a [N], alpha [1/m], Fd [N], x0 [m]).
    F_init : float, optional
        Friction at x0 [N]. Default: the paper's initial condition ``Fd (1 - exp(-alpha x0))``.
    below : {"raise", "hold"}
        Abscissae below the initial state: rejected (default), or given the initial force
        F(x0) (the rule of the fits).

    Returns
    -------
    float or numpy.ndarray
        Friction force F(x) [N], same shape as ``x``; accurate to about 1e-15 relative.

    Raises
    ------
    InvalidParameterError
        If x is not finite, lies below x0 (with ``below="raise"``), or F_init is negative or
        not finite.

    Examples
    --------
    >>> from granflow import Params, friction_slip
    >>> p = Params(a=3.31e-3, alpha=4.186e4, Fd=10e-3, x0=1.978e-7)
    >>> round(friction_slip(20e-6, p) * 1e3, 4)  # mN, near the peak
    13.7829
    """
    if type(x) is float and type(params) is Params and F_init is None and below == "raise":
        value = kernel.eq3_default(x, 1.0, params.a, params.alpha, params.Fd, params.x0)
        if value == value:  # the scalar path with the defaults (NaN: the checks say why)
            return value
    _check_params(params)
    return _evaluate(x, params, _check_f_init(F_init), below=below)


def friction_time(
    t: ArrayLike,
    params: Params,
    velocity: float,
    *,
    F_init: float | None = None,
    below: str = "raise",
) -> FloatOrArray:
    """Friction force against time under a constant imposed velocity, Eq. 3.

    The same curve as :func:`friction_slip` at slip ``velocity * t``: with k = alpha v and
    t0 = x0 / v this is ``a e^{-kt} [Ei(kt) - Ei(k t0)] + Fd (1 - e^{-kt})``.

    Parameters
    ----------
    t : float or array_like
        Time since shearing started [s] (the record's clock, which is the model's t); every
        value must be at least ``params.t0(velocity)``, where the model takes over.
    params : Params
        Model parameters in SI units.
    velocity : float
        Imposed sliding velocity [m/s]; positive.
    F_init : float, optional
        Friction at t0 [N]; default the paper's initial condition.
    below : {"raise", "hold"}
        Times below t0: rejected (default), or given the initial force (the fits' rule).

    Returns
    -------
    float or numpy.ndarray
        Friction force F(t) [N], same shape as ``t``.

    Examples
    --------
    >>> from granflow import Params, friction_time
    >>> p = Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    >>> round(friction_time(24.0, p, 0.86e-6) * 1e3, 6)  # mN
    13.782683
    """
    if (
        type(t) is float
        and type(velocity) is float
        and type(params) is Params
        and F_init is None
        and below == "raise"
        and 0.0 < velocity < math.inf
    ):  # the scalar path with the defaults, checked in place: no per-call overhead
        value = kernel.eq3_default(t, velocity, params.a, params.alpha, params.Fd, params.x0)
        if value == value:
            return value
    _check_params(params)
    velocity = check.positive(velocity, "velocity", "m/s")
    return _evaluate(
        t, params, _check_f_init(F_init), scale=velocity, name="t", unit="s", below=below
    )


def friction_slip_jacobian(
    x: ArrayLike, params: Params, *, F_init: float | None = None, below: str = "raise"
) -> dict[str, FloatArray]:
    """Partial derivatives of :func:`friction_slip` with respect to the parameters.

    With s = alpha x, h = alpha (x - x0) and D = exp(-s) [Ei(s) - Ei(s0)]:
    dF/da = D, dF/dx0 = -a exp(-h) / x0 (+ (F_init - Fd) alpha exp(-h) for a given F_init),
    dF/dalpha = a [(1 - exp(-h)) / alpha - x D] + (Fd x exp(-s), or -(F_init - Fd)(x - x0)
    exp(-h)), dF/dFd = 1 - exp(-s) (or 1 - exp(-h)), dF/dF_init = exp(-h).

    Parameters
    ----------
    x : array_like
        Slip [m], at least x0 unless ``below="hold"``.
    params : Params
        Model parameters.
    F_init : float, optional
        Friction at x0 [N]; default the paper's initial condition.
    below : {"raise", "hold"}
        Abscissae below the initial state: rejected (default), or given the initial force
        F(x0) (the rule of the fits).

    Returns
    -------
    dict of str to numpy.ndarray
        ``{"a": dF/da [-], "alpha": dF/dalpha [N m], "Fd": dF/dFd [-], "x0": dF/dx0 [N/m]}``,
        plus ``"F_init"`` [-] when F_init is given; each the shape of ``x`` (below x0 with
        ``below="hold"``: the derivatives of the initial force).
    """
    _check_params(params)
    hold = kernel.check_below(below) == "hold"
    slip = check.real_array(x, "x", "m")
    if not hold:
        _check_from_start(slip, params.x0, "x", "m")
    F_init = _check_f_init(F_init)
    paper = F_init is None
    offset = 0.0 if paper else F_init - params.Fd
    flat = np.ascontiguousarray(slip, dtype=np.float64).ravel()
    F = np.empty_like(flat)
    J = np.empty((flat.size, 5))
    p = params
    kernel.jacobian_loop(flat, p.a, p.alpha, p.Fd, p.x0, offset, paper, hold, F, J)
    names = ("a", "alpha", "Fd", "x0") if paper else ("a", "alpha", "Fd", "x0", "F_init")
    return {name: J[:, k].reshape(slip.shape) for k, name in enumerate(names)}


def initial_force(params: Params, *, F_init: float | None = None) -> float:
    """Friction at the initial state x0 [N]: F_init, or the paper's Fd (1 - exp(-alpha x0))."""
    _check_params(params)
    F_init = _check_f_init(F_init)
    if F_init is not None:
        return F_init
    return -params.Fd * math.expm1(-params.alpha * params.x0)


def steady_state(params: Params) -> float:
    """Steady-state friction [N] reached at large slip: Fd, approached as Fd + a/(alpha x)."""
    _check_params(params)
    return params.Fd


def friction_asymptote(x: ArrayLike, params: Params) -> FloatOrArray:
    """Large-slip limit ``Fd + a / (alpha x)`` [N]; friction_slip minus it is O(1/x**2).

    Parameters
    ----------
    x : float or array_like
        Slip [m]; positive.
    params : Params
        Model parameters.
    """
    _check_params(params)
    slip = check.real_array(x, "x", "m")
    if np.any(slip <= 0):
        raise InvalidParameterError("x must be positive for the large-slip asymptote")
    return _like_input(params.Fd + params.a / (params.alpha * slip))


def friction_aging(x: ArrayLike, params: Params, *, F_init: float | None = None) -> FloatOrArray:
    """Pure-aging limit alpha -> 0 of Eq. 3: ``F_init + a ln(x / x0)`` [N] (Eq. 1).

    friction_slip approaches this for alpha x << 1 (the relative difference is of order
    alpha x); without rejuvenation the strength grows logarithmically without bound.

    Parameters
    ----------
    x : float or array_like
        Slip [m] (or, equivalently, ``v t``), at least x0.
    params : Params
        Model parameters; alpha is not used.
    F_init : float, optional
        Friction at x0 [N]; default the paper's initial condition (which tends to 0 with alpha).
    """
    _check_params(params)
    slip = check.real_array(x, "x", "m")
    _check_from_start(slip, params.x0, "x", "m")
    start = initial_force(params, F_init=F_init)
    return _like_input(start + params.a * np.log(slip / params.x0))


def rhs_slip(x: FloatOrArray, F: FloatOrArray, params: Params) -> FloatOrArray:
    """Right-hand side of Eq. 2 in slip: ``dF/dx = a/x - alpha (F - Fd)`` [N/m].

    Parameters
    ----------
    x : float or array_like
        Slip (aging coordinate) [m]; positive.
    F : float or array_like
        Friction force [N].
    params : Params
        Model parameters.
    """
    return params.a / x - params.alpha * (F - params.Fd)


def rhs_time(t: FloatOrArray, F: FloatOrArray, params: Params, velocity: float) -> FloatOrArray:
    """Right-hand side of Eq. 2 in time: ``dF/dt = a/t - alpha v (F - Fd)`` [N/s].

    Parameters
    ----------
    t : float or array_like
        Time since preparation [s]; positive.
    F : float or array_like
        Friction force [N].
    params : Params
        Model parameters.
    velocity : float
        Imposed sliding velocity [m/s].
    """
    return params.a / t - params.alpha * velocity * (F - params.Fd)


@dataclass(frozen=True, slots=True)
class Peak:
    """The static yield point: the maximum of F, where ``a/x = alpha (F - Fd)``.

    Attributes
    ----------
    slip : float
        Slip at the peak [m] (the aging coordinate, counted from 0 like x0).
    force : float
        Peak friction ``Fd + a / (alpha slip)`` [N].
    time : float or None
        Time of the peak ``slip / velocity`` [s] when a velocity was given.
    velocity : float or None
        The velocity [m/s] the time refers to.
    """

    slip: float
    force: float
    time: float | None = None
    velocity: float | None = None

    def to_dict(self) -> dict[str, float | None]:
        """JSON-safe mapping (SI units)."""
        return {
            "slip": self.slip,
            "force": self.force,
            "time": self.time,
            "velocity": self.velocity,
        }


def _peak_offset(params, F_init):
    """(F_init - Fd) / a, the dimensionless initial offset from steady state."""
    if F_init is None:
        return -params.Fd / params.a * math.exp(-params.alpha * params.x0)
    return (F_init - params.Fd) / params.a


def has_peak(params: Params, *, F_init: float | None = None) -> bool:
    """Whether F(x) has an interior maximum.

    It has one exactly when a > 0 and F starts below the nullcline of Eq. 2,
    ``F_init < Fd + a / (alpha x0)``; this always holds for the paper's initial condition.
    """
    _check_params(params)
    F_init = _check_f_init(F_init)
    if params.a == 0:
        return False
    s0 = params.alpha * params.x0
    return _peak_offset(params, F_init) < 1.0 / s0


def peak(params: Params, *, F_init: float | None = None, velocity: float | None = None) -> Peak:
    """The static yield point (stress overshoot): slip and force of the maximum of F.

    The peak is the root of ``a/x = alpha (F(x) - Fd)``, found by Brent's method in the
    dimensionless slip s = alpha x to full double precision. Trajectories of Eq. 2 cross the
    nullcline F = Fd + a/(alpha x) at most once, and only upwards, so the peak is unique when
    it exists.

    Parameters
    ----------
    params : Params
        Model parameters.
    F_init : float, optional
        Friction at x0 [N]; default the paper's initial condition (which always has a peak).
    velocity : float, optional
        Sliding velocity [m/s]; when given, the result also carries the time of the peak.

    Returns
    -------
    Peak
        ``slip`` [m], ``force`` [N] and, with a velocity, ``time`` [s].

    Raises
    ------
    NoPeakError
        If a = 0 or F_init >= Fd + a/(alpha x0): F then never rises, and there is no yield peak.

    Examples
    --------
    >>> from granflow import Params, peak
    >>> p = Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    >>> pk = peak(p, velocity=0.86e-6)
    >>> round(pk.time, 6), round(pk.force * 1e3, 8)
    (24.304978, 13.78294706)
    """
    _check_params(params)
    F_init = _check_f_init(F_init)
    if velocity is not None:
        velocity = check.positive(velocity, "velocity", "m/s")
    if not has_peak(params, F_init=F_init):
        start = initial_force(params, F_init=F_init)
        nullcline = params.Fd + params.a / (params.alpha * params.x0)
        reason = (
            "a = 0 (no aging)"
            if params.a == 0
            else f"F_init = {start:.6g} N is not below Fd + a/(alpha x0) = {nullcline:.6g} N"
        )
        raise NoPeakError(f"the friction curve has no peak: {reason}, so F never rises")
    s0 = params.alpha * params.x0
    offset = _peak_offset(params, F_init)
    scaled_ei_s0 = scaled_ei_scalar(s0)

    def nullcline_gap(s):
        # a/x - alpha (F - Fd), divided by alpha a: positive before the peak, negative after
        decay = math.exp(s0 - s)
        return 1.0 / s - scaled_ei_diff_scalar(s, s0, scaled_ei_s0, decay) - offset * decay

    upper = s0 + max(s0, 1.0)
    for _ in range(1100):  # doubling from >= 1 reaches the largest float
        if nullcline_gap(upper) < 0:
            break
        upper *= 2.0
    else:  # pragma: no cover - the gap is negative beyond s ~ ln(|offset|) + 2 ln(s)
        raise NoPeakError("the friction peak could not be bracketed")
    root = brentq(
        nullcline_gap, s0, upper, xtol=s0 * 1e-18, rtol=4 * np.finfo(float).eps, maxiter=500
    )
    slip = root / params.alpha
    force = params.Fd + params.a / root
    time = None if velocity is None else slip / velocity
    return Peak(slip=slip, force=force, time=time, velocity=velocity)
