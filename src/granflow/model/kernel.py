"""The Eq. 3 point kernel: F and its parameter derivatives at one point, compiled once.

With s = alpha z, s0 = alpha x0, h = s - s0 and D = exp(-s) [Ei(s) - Ei(s0)], Eq. 3 from the
state (x0, F_init) is

    F = Fd + (F_init - Fd) exp(-h) + a D,

and with the paper's initial condition ``F_init = Fd (1 - exp(-s0))`` it is
``a D + Fd (1 - exp(-s))``. Every evaluation of Eq. 3 in granflow goes through :func:`point`:
:func:`granflow.friction_slip`, :func:`granflow.friction_time` and
:func:`granflow.friction_slip_jacobian` (by :func:`eq3_loop` and :func:`jacobian_loop`), the
fit engine's fused normal equations (:func:`normal_equations`), and the simulator's closed form
from any state (:func:`general_value`).

**Below x0.** The model starts at x0. ``below="raise"`` (the default of the model functions)
rejects abscissae under x0 (a relative tolerance of 1e-12 absorbs round-off in ``v t0``);
``below="hold"`` (the fits' rule) holds the force at its initial value F(x0) there, with the
derivatives of that initial value, so that a fit's objective is continuous in x0. See
:data:`BELOW`.

Compiled API (Numba, ``nogil``, cached on disk; each callable from compiled code and from
Python):

* :func:`curve_start` ``(alpha, x0)`` -- the per-curve constants :func:`point` takes;
* :func:`point` -- value and the derivatives in (a, alpha, Fd, x0, F_init) at one point,
  :func:`point_value` the value alone;
* :func:`eq3_values` -- F over an array in one fused SIMD pass (the scaled argument and the
  decay term computed in it), :func:`eq3_scalar` the same at one point without arrays;
* :func:`eq3_loop`, :func:`jacobian_loop`, :func:`normal_equations` -- loops over arrays;
* :func:`general_value` ``(z, a, alpha, Fd, z0, F_init)`` -- F from any state (the simulator).
"""

import math

import numba
import numpy as np

from granflow.model import _ei_tables as _t
from granflow.model.special import (
    compiled,
    compiled_inline,
    horner,
    scaled_ei_diff_scalar,
    scaled_ei_piece,
    scaled_ei_scalar,
    scaled_ei_simd,
    simd_exp,
    simd_log1p,
)

__all__ = [
    "BELOW",
    "check_below",
    "curve_start",
    "eq3_loop",
    "eq3_scalar",
    "eq3_values",
    "general_value",
    "jacobian_loop",
    "normal_equations",
    "point",
    "point_value",
]

#: Rules for abscissae below the initial state x0: reject them, or hold F at F(x0).
BELOW = ("raise", "hold")

_SERIES = _t.SERIES[::-1].copy()  # highest power first, as in special.horner
_TINY = 1e-300  # the SIMD log needs a normal positive argument
_BLOCK = 256  # points per block of the SIMD passes (their scratch stays in the L1 cache)
_EXPM1_LIMIT = 1e-3  # below this s, 1 - exp(-s) cancels: use its Taylor series instead


def check_below(below):
    """``below`` if it is one of :data:`BELOW`; otherwise InvalidParameterError."""
    if below not in BELOW:
        from granflow.errors import InvalidParameterError

        raise InvalidParameterError(f"below must be 'raise' or 'hold', got {below!r}")
    return below


@compiled_inline
def curve_start(alpha, x0):
    """Per-curve constants of :func:`point`: a tuple
    ``(s0, exp(-s0) Ei(s0), exp(-s0), 1 - exp(-s0), horner_s0, log(s0) + S(s0))``.

    ``horner_s0[k]`` are the partial Horner sums of the power series S of Ei at s0 (used when
    s and s0 are both below 0.5).
    """
    s0 = alpha * x0
    horner_s0 = np.empty(_SERIES.shape[0])
    acc = 0.0
    for k in range(_SERIES.shape[0]):
        acc = acc * s0 + _SERIES[k]
        horner_s0[k] = acc
    log_s0_and_series = math.log(s0) + s0 * acc if s0 < _t.SMALL_LIMIT else 0.0
    return (
        s0,
        scaled_ei_scalar(s0),
        math.exp(-s0),
        -math.expm1(-s0),
        horner_s0,
        log_s0_and_series,
    )


@compiled_inline
def _scaled_terms(s, decay, start):
    """D = exp(-s) (Ei(s) - Ei(s0)) and 1 - exp(-s) at one point (``decay = exp(-(s - s0))``).

    Where s0 and s are both below 0.5, Ei(s) - Ei(s0) = log1p(h/s0) + S(s) - S(s0) with
    h = s - s0; the series difference is h times the divided difference of S (a Horner
    recurrence on the Horner values at s0), so nothing cancels however close s is to s0.
    """
    s0, scaled_ei_s0, exp_minus_s0, _, horner_s0, log_s0_and_series = start
    exp_minus_s = decay * exp_minus_s0
    if s < _t.SMALL_LIMIT and s0 < _t.SMALL_LIMIT:
        h = s - s0
        if abs(h) < 0.5 * s:
            divided = 0.0  # (S(s) - S(s0)) / h
            for k in range(_SERIES.shape[0]):
                divided = divided * s + horner_s0[k]
            ei_diff = math.log1p(h / s0) + h * divided
        else:
            ei_diff = math.log(s) + s * horner(_SERIES, s) - log_s0_and_series
        if s > _EXPM1_LIMIT:
            rise = 1.0 - exp_minus_s
        else:  # 1 - exp(-s) = s - s^2/2 + s^3/6 - s^4/24 + s^5/120 to 1e-19 relative
            rise = s * (1.0 - s * (0.5 - s * (1.0 / 6.0 - s * (1.0 / 24.0 - s / 120.0))))
        return exp_minus_s * ei_diff, rise
    diff = scaled_ei_diff_scalar(s, s0, scaled_ei_s0, decay)
    rise = -math.expm1(-s) if s < _t.SMALL_LIMIT else 1.0 - exp_minus_s
    return diff, rise


@compiled_inline
def _is_plain(s, h):
    """Whether the SIMD formulas of :func:`_plain_block` hold at s (h = s - s0 > 0): below
    s = 0.5 always, above it not within reach of s0 (where the quadrature takes over)."""
    return s >= _TINY and (s < _t.SMALL_LIMIT or h >= 1.0 or h >= 0.5 * s)


@compiled_inline
def _rise(s, exp_minus_s):
    """1 - exp(-s), by its Taylor series where it cancels (s <= 1e-3); branch-free."""
    series = s * (1.0 - s * (0.5 - s * (1.0 / 6.0 - s * (1.0 / 24.0 - s / 120.0))))
    return series if s <= _EXPM1_LIMIT else 1.0 - exp_minus_s


@compiled_inline
def _series_diff(s, decay, start):
    """D at s0 <= s < 0.5: exp(-s) [log1p(h / s0) + h (S(s) - S(s0)) / h]; branch-free.

    As :func:`_scaled_terms` computes it next to s0, which is accurate far from s0 too: the
    divided difference of S is a Horner recurrence on the Horner values at s0.
    """
    s0, horner_s0 = start[0], start[4]
    h = s - s0
    divided = 0.0
    for k in range(_SERIES.shape[0]):
        divided = divided * s + horner_s0[k]
    return decay * start[2] * (simd_log1p(h / s0) + h * divided)


@compiled_inline
def _table_diff(s, decay, start):
    """D at s >= 0.5 where :func:`_is_plain`: the tables, branch-free."""
    row, t = scaled_ei_piece(s)
    return scaled_ei_simd(s, row, t) - decay * start[1]


@compiled
def _plain_block(z, lo, hi, rate, start, diff, decay):
    """D and exp(-(s - s0)) at ``z[lo:hi]`` (s = rate z) into ``diff[:hi - lo]`` and
    ``decay[:hi - lo]``, by the SIMD formulas (where :func:`_is_plain`).

    Only the formulas the block needs are evaluated: the power series where s < 0.5, the
    tables where s >= 0.5 (both, selected point by point, where the block straddles 0.5;
    one row of the table, without gathers, where the block lies within one piece).
    """
    s0, scaled_ei_s0 = start[0], start[1]
    low = high = rate * z[lo]
    for i in range(lo + 1, hi):
        s = rate * z[i]
        low = min(low, s)
        high = max(high, s)
    row = scaled_ei_piece(low)[0]
    if low >= _t.SMALL_LIMIT and row == scaled_ei_piece(high)[0]:
        for i in range(lo, hi):
            s = rate * z[i]
            decay[i - lo] = simd_exp(s0 - s)
            value = scaled_ei_simd(s, row, scaled_ei_piece(s)[1])
            diff[i - lo] = value - decay[i - lo] * scaled_ei_s0
    elif low >= _t.SMALL_LIMIT:
        for i in range(lo, hi):
            s = rate * z[i]
            decay[i - lo] = simd_exp(s0 - s)
            diff[i - lo] = _table_diff(s, decay[i - lo], start)
    elif high < _t.SMALL_LIMIT:
        for i in range(lo, hi):
            s = rate * z[i]
            decay[i - lo] = simd_exp(s0 - s)
            diff[i - lo] = _series_diff(s, decay[i - lo], start)
    else:
        for i in range(lo, hi):
            s = rate * z[i]
            e = simd_exp(s0 - s)
            decay[i - lo] = e
            series = _series_diff(s, e, start)
            table = _table_diff(s, e, start)
            diff[i - lo] = series if s < _t.SMALL_LIMIT else table


@compiled_inline
def point_value(s, decay, a, Fd, offset, paper, held, start):
    """F alone at one point: :func:`point`'s first value, without the derivatives' cost."""
    if held:
        return Fd * start[3] if paper else Fd + offset
    diff, rise_s = _scaled_terms(s, decay, start)
    if paper:
        return a * diff + Fd * rise_s
    return Fd + offset * decay + a * diff


@compiled_inline
def point(z, s, decay, a, alpha, Fd, x0, offset, paper, held, start):
    """F and its derivatives at one point, Eq. 3.

    Parameters
    ----------
    z : float
        Abscissa [m] (or [s], with alpha [1/s] and x0 [s]).
    s, decay : float
        ``alpha z`` and ``exp(alpha x0 - s)`` (callers with many points compute them with
        NumPy's vectorised exp, about three times faster than a scalar one).
    a, alpha, Fd, x0 : float
        Parameters [N, 1/m, N, m].
    offset : float
        ``F_init - Fd`` [N] (ignored with ``paper``).
    paper : bool
        The paper's initial condition ``F_init = Fd (1 - exp(-alpha x0))``.
    held : bool
        Give the initial state: F(x0) and its derivatives (the ``below="hold"`` rule).
    start : tuple
        :func:`curve_start` ``(alpha, x0)``.

    Returns
    -------
    tuple of float
        ``(F, dF/da, dF/dalpha, dF/dFd, dF/dx0, dF/dF_init)`` [N, -, N m, -, N/m, -]; with
        ``paper`` the derivatives include those of the initial condition and dF/dF_init is 0.
    """
    exp_minus_s0, start_rise = start[2], start[3]
    if held:
        if paper:
            return (
                Fd * start_rise,
                0.0,
                Fd * x0 * exp_minus_s0,
                start_rise,
                Fd * alpha * exp_minus_s0,
                0.0,
            )
        return Fd + offset, 0.0, 0.0, 0.0, 0.0, 1.0
    diff, rise_s = _scaled_terms(s, decay, start)
    h = s - start[0]
    rise_h = -math.expm1(-h) if h < _t.SMALL_LIMIT else 1.0 - decay
    d_alpha = a * (rise_h / alpha - z * diff)
    d_x0 = -a * decay / x0
    if paper:
        return (
            a * diff + Fd * rise_s,
            diff,
            d_alpha + Fd * z * decay * exp_minus_s0,
            rise_s,
            d_x0,
            0.0,
        )
    return (
        Fd + offset * decay + a * diff,
        diff,
        d_alpha - offset * (z - x0) * decay,
        rise_h,
        d_x0 + offset * alpha * decay,
        decay,
    )


@compiled
def eq3_loop(z, s, decay, lowest, z0, a, alpha, Fd, x0, offset, paper, hold, out):
    """F at the points z (slip, or time) into out, in one pass.

    ``s`` and ``decay`` are as :func:`point` takes them; ``z0`` is the initial state in the
    unit of z (x0, or t0 = x0 / v). Points at or below z0 are held at F(x0) with ``hold``;
    every point must reach ``lowest``. Returns the index of the first z that is not finite or
    lies below ``lowest``, or -1.
    """
    start = curve_start(alpha, x0)
    for i in range(z.shape[0]):
        zi = z[i]
        if not (zi >= lowest and zi < math.inf):
            return i
        out[i] = point_value(s[i], decay[i], a, Fd, offset, paper, hold and zi <= z0, start)
    return -1


@compiled
def eq3_values(z, scale, lowest, z0, a, alpha, Fd, x0, offset, paper, hold, out):
    """F at the points z (slip, or time with ``scale`` = velocity) into out; fused and SIMD.

    :func:`eq3_loop` with the scaled argument ``s = alpha scale z`` and the decay term
    computed in the same pass: block by block, a branch-free pass evaluates every point by the
    SIMD formulas (:func:`_plain_block`); then a second pass re-evaluates, with
    :func:`point_value`, the few points where they do not hold (:func:`_is_plain`: next to
    the initial state above s = 0.5, held, invalid). Returns
    the index of the first z that is not finite or lies below ``lowest``, or -1.
    """
    start = curve_start(alpha, x0)
    s0, exp_minus_s0 = start[0], start[2]
    rate = alpha * scale
    diff = np.empty(_BLOCK)
    decay = np.empty(_BLOCK)
    for lo in range(0, z.shape[0], _BLOCK):
        hi = min(lo + _BLOCK, z.shape[0])
        _plain_block(z, lo, hi, rate, start, diff, decay)
        for i in range(lo, hi):
            if paper:
                s = rate * z[i]
                out[i] = a * diff[i - lo] + Fd * _rise(s, decay[i - lo] * exp_minus_s0)
            else:
                out[i] = Fd + offset * decay[i - lo] + a * diff[i - lo]
    for i in range(z.shape[0]):
        zi = z[i]
        s = alpha * (scale * zi)
        if zi > z0 and zi >= lowest and zi < math.inf and _is_plain(s, s - s0):
            continue
        if not (zi >= lowest and zi < math.inf):
            return i
        out[i] = point_value(s, math.exp(s0 - s), a, Fd, offset, paper, hold and zi <= z0, start)
    return -1


@compiled
def eq3_scalar(z, scale, lowest, z0, a, alpha, Fd, x0, offset, paper, hold):
    """F at one z, as :func:`eq3_values` takes its arguments, without arrays: the scalar path
    of the model functions, the simulator and root finders. NaN where z is not finite or
    lies below ``lowest`` (the caller names the problem)."""
    if not (z >= lowest and z < math.inf):
        return math.nan
    start = curve_start(alpha, x0)
    s = alpha * (scale * z)
    return point_value(s, math.exp(start[0] - s), a, Fd, offset, paper, hold and z <= z0, start)


@compiled
def eq3_default(z, scale, a, alpha, Fd, x0):
    """F at one z >= x0 / scale with the paper's initial force: :func:`eq3_scalar` with the
    model functions' defaults (``F_init=None``, ``below="raise"``) and six arguments, since
    each argument costs the dispatcher a type check on a call from Python. NaN where z is
    not finite or lies below x0 / scale by more than 1e-12 relative (the caller names why)."""
    z0 = x0 / scale
    if not (z >= z0 * (1.0 - 1e-12) and z < math.inf):
        return math.nan
    start = curve_start(alpha, x0)
    s = alpha * (scale * z)
    return point_value(s, math.exp(start[0] - s), a, Fd, 0.0, True, False, start)


@compiled
def jacobian_loop(z, a, alpha, Fd, x0, offset, paper, hold, F, J):
    """F and the columns d/da, d/dalpha, d/dFd, d/dx0, d/dF_init of J (n by 5) at z."""
    start = curve_start(alpha, x0)
    s0 = start[0]
    for i in range(z.shape[0]):
        zi = z[i]
        s = alpha * zi
        F[i], J[i, 0], J[i, 1], J[i, 2], J[i, 3], J[i, 4] = point(
            zi, s, math.exp(s0 - s), a, alpha, Fd, x0, offset, paper, hold and zi <= x0, start
        )


#: The sums of the normal equations over a block of weighted residuals and Jacobian rows
#: (rows 0..4: r, then d r / d(a, alpha, Fd, x0)) may be reordered into SIMD partial sums:
#: deterministic, and different from the sequential sum by rounding only.
_summed = numba.njit(cache=True, error_model="numpy", nogil=True, fastmath={"contract", "reassoc"})


@_summed
def _accumulate(rows, count, sums):
    """sums += (r.r, J^T r (4), upper J^T J (10)) over the first ``count`` columns of rows."""
    c = g0 = g1 = g2 = g3 = 0.0
    h00 = h01 = h02 = h03 = h11 = h12 = h13 = h22 = h23 = h33 = 0.0
    for k in range(count):
        r, j0, j1, j2, j3 = rows[0, k], rows[1, k], rows[2, k], rows[3, k], rows[4, k]
        c += r * r
        g0 += j0 * r
        g1 += j1 * r
        g2 += j2 * r
        g3 += j3 * r
        h00 += j0 * j0
        h01 += j0 * j1
        h02 += j0 * j2
        h03 += j0 * j3
        h11 += j1 * j1
        h12 += j1 * j2
        h13 += j1 * j3
        h22 += j2 * j2
        h23 += j2 * j3
        h33 += j3 * j3
    totals = (c, g0, g1, g2, g3, h00, h01, h02, h03, h11, h12, h13, h22, h23, h33)
    for m, value in enumerate(totals):
        sums[m] += value


@compiled
def normal_equations(z, y, w, a, alpha, Fd, x0, jtj, jtr):
    """Sum of squared weighted residuals; J^T J into jtj (4x4) and J^T r into jtr (4).

    The fits' fused pass: r = w (F - y), J = dr/d(a, alpha, Fd, x0), paper initial condition,
    held below x0. Block by block: D and the decay term from the SIMD formulas
    (:func:`_plain_block`), the residuals and Jacobian rows in SIMD code, the few points where
    those formulas do not hold (and dF/dalpha where 1 - exp(-h) cancels) patched with
    :func:`point`, then the sums (:func:`_accumulate`); no n-by-4 array.
    """
    start = curve_start(alpha, x0)
    s0, exp_minus_s0 = start[0], start[2]
    diff = np.empty(_BLOCK)
    decay = np.empty(_BLOCK)
    rows = np.empty((5, _BLOCK))
    sums = np.zeros(15)
    for lo in range(0, z.shape[0], _BLOCK):
        hi = min(lo + _BLOCK, z.shape[0])
        _plain_block(z, lo, hi, alpha, start, diff, decay)
        for i in range(lo, hi):
            k = i - lo
            zi, d, e, wi = z[i], diff[k], decay[k], w[i]
            rise = _rise(alpha * zi, e * exp_minus_s0)
            rows[0, k] = wi * (a * d + Fd * rise - y[i])
            rows[1, k] = wi * d
            rows[2, k] = wi * (a * ((1.0 - e) / alpha - zi * d) + Fd * zi * e * exp_minus_s0)
            rows[3, k] = wi * rise
            rows[4, k] = wi * (-a * e / x0)
        for i in range(lo, hi):
            zi = z[i]
            s = alpha * zi
            h = s - s0
            plain = zi > x0 and _is_plain(s, h)
            if plain and h >= _t.SMALL_LIMIT:
                continue
            k = i - lo
            wi = w[i]
            if plain:  # 1 - exp(-h) cancels: dF/dalpha with expm1
                d, e = diff[k], decay[k]
                d_alpha = a * (-math.expm1(-h) / alpha - zi * d) + Fd * zi * e * exp_minus_s0
                rows[2, k] = wi * d_alpha
                continue
            F, j0, j1, j2, j3, _ = point(
                zi, s, math.exp(s0 - s), a, alpha, Fd, x0, 0.0, True, zi <= x0, start
            )
            rows[0, k] = wi * (F - y[i])
            rows[1, k], rows[2, k], rows[3, k], rows[4, k] = wi * j0, wi * j1, wi * j2, wi * j3
        _accumulate(rows, hi - lo, sums)
    jtr[0], jtr[1], jtr[2], jtr[3] = sums[1], sums[2], sums[3], sums[4]
    jtj[0, 0], jtj[1, 1], jtj[2, 2], jtj[3, 3] = sums[5], sums[9], sums[12], sums[14]
    jtj[0, 1] = jtj[1, 0] = sums[6]
    jtj[0, 2] = jtj[2, 0] = sums[7]
    jtj[0, 3] = jtj[3, 0] = sums[8]
    jtj[1, 2] = jtj[2, 1] = sums[10]
    jtj[1, 3] = jtj[3, 1] = sums[11]
    jtj[2, 3] = jtj[3, 2] = sums[13]
    return sums[0]


@compiled
def general_value(z, a, alpha, Fd, z0, F_init):
    """F(z) [N] from the state (z0, F_init), Eq. 3 with the general initial condition.

    Parameters
    ----------
    z, z0 : float
        Abscissa and initial state [m] (or [s] with alpha in [1/s]); z >= z0 > 0.
    a, alpha, Fd, F_init : float
        Aging amplitude [N], rejuvenation constant [1/m], dynamic friction [N], force at z0 [N].

    Examples
    --------
    >>> from granflow.model.kernel import general_value
    >>> round(general_value(2e-5, 3.31e-3, 4.186e4, 10e-3, 1.978e-7, 8e-3) * 1e3, 6)
    17.235915
    """
    start = curve_start(alpha, z0)
    s = alpha * z
    return point_value(s, math.exp(start[0] - s), a, Fd, F_init - Fd, False, False, start)
