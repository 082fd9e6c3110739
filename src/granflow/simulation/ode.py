"""One compiled integrator for every ODE granflow solves: Rodas4 with dense output and events.

Rodas4 (Hairer and Wanner, *Solving Ordinary Differential Equations II*, 2nd ed., 1996,
§IV.7) is a stiffly accurate, L-stable Rosenbrock method of order 4 with an embedded method
of order 3 for the step-size control. Each step solves six linear systems with one LU
factorisation of ``I / (gamma h) - J`` (the analytic Jacobian of
:mod:`granflow.simulation.equations`), so it takes the stiffness of slow creep under the
direct effect and of the rate-and-state laws in its stride, and costs no Newton iteration.
Between steps the solution is the cubic Hermite interpolant of the two ends (values and
slopes), on which events are located by the Illinois method to a few ulps of the time.

Everything is compiled with Numba and cached on disk; the work is bounded by the number of
right-hand-side evaluations only, so the same inputs give bit-identical outputs however busy
the machine is.

The bookkeeping of one integration lives in an int64 array ``counters`` (see the ``COUNT_*``
indices) so that a caller can run several phases into the same output buffers.
"""

import math

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop853

from granflow.simulation.equations import EVENTS, compiled, events, jacobian, rhs

__all__ = [
    "DONE",
    "DOP853",
    "EVENT",
    "RODAS4",
    "STEP_TOO_SMALL",
    "WORK_EXCEEDED",
    "new_counters",
    "solve",
]

#: The methods: Rodas4 for stiff systems, DOP853 (explicit, order 8) for the others.
RODAS4, DOP853 = 0, 1
#: Outcomes of :func:`solve`.
DONE, EVENT, STEP_TOO_SMALL, WORK_EXCEEDED = 0, 1, -1, -2

#: Indices of ``counters``.
COUNT_OUT, COUNT_RECORDED, COUNT_STRIDE, COUNT_SEEN = 0, 1, 2, 3
COUNT_EVENTS, COUNT_STEPS, COUNT_EVALUATIONS, COUNT_FIRED, COUNT_REJECTED = 4, 5, 6, 7, 8
_COUNTERS = 9

# Rodas4 in the form G K_i = f(t + alpha_i h, y + sum_j a_ij K_j) + sum_j c_ij / h K_j
# + gamma_i h df/dt, G = I / (gamma h) - J; y_new = y + sum_j m_j K_j, error K_6.
_GAMMA = 0.25
_ALPHA = np.array([0.0, 0.386, 0.21, 0.63, 1.0, 1.0])
_GAMMA_I = np.array([0.25, -0.1043, 0.1035, -0.03620000000000023, 0.0, 0.0])
_A = np.zeros((6, 6))
_C = np.zeros((6, 6))
_A[1, 0] = 1.544
_A[2, :2] = (0.9466785280815826, 0.2557011698983284)
_A[3, :3] = (3.314825187068521, 2.896124015972201, 0.9986419139977817)
_A[4, :4] = (1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950)
_A[5, :5] = (*_A[4, :4], 1.0)
_C[1, 0] = -5.6688
_C[2, :2] = (-2.430093356833875, -0.2063599157091915)
_C[3, :3] = (-0.1073529058151375, -9.594562251023355, -20.47028614809616)
_C[4, :4] = (7.496443313967647, -10.24680431464352, -33.99990352819905, 11.70890893206160)
_C[5, :5] = (
    8.083246795921522,
    -7.981132988064893,
    -31.52159432874371,
    16.31930543123136,
    -6.058818238834054,
)
_M = np.array([*_A[4, :4], 1.0, 1.0])
_ORDER = 4.0  # of the error estimate: min(4, 3) + 1
# Dormand and Prince's 8(5,3) pair (Hairer, Norsett and Wanner, Solving ODEs I, §II.10),
# with the coefficients SciPy's DOP853 uses; its error estimate is of order 7 + 1.
_RK_STAGES = _dop853.N_STAGES
_RK_A = np.ascontiguousarray(_dop853.A[:_RK_STAGES, :_RK_STAGES])
_RK_B = np.ascontiguousarray(_dop853.B)
_RK_C = np.ascontiguousarray(_dop853.C[:_RK_STAGES])
_RK_E3 = np.ascontiguousarray(_dop853.E3)
_RK_E5 = np.ascontiguousarray(_dop853.E5)
_RK_ORDER = 8.0
_RK_EXTENDED = _dop853.N_STAGES_EXTENDED
_RK_A_EXTRA = np.ascontiguousarray(_dop853.A[_RK_STAGES + 1 :])
_RK_C_EXTRA = np.ascontiguousarray(_dop853.C[_RK_STAGES + 1 :])
_RK_D = np.ascontiguousarray(_dop853.D)
#: Rows of the dense-output polynomial (order 7 for DOP853; the first 3 make the cubic
#: Hermite interpolant, all Rodas4 uses).
_DENSE = _dop853.INTERPOLATOR_POWER
_SAFETY, _SHRINK, _GROW = 0.9, 0.2, 6.0


@compiled
def new_counters():
    """A fresh ``counters`` array (stride of the step record 1)."""
    counters = np.zeros(_COUNTERS, dtype=np.int64)
    counters[COUNT_STRIDE] = 1
    return counters


@compiled
def _error_norm(error, y0, y1, rtol, atol):
    total = 0.0
    for i in range(error.size):
        scale = atol[i] + rtol * max(abs(y0[i]), abs(y1[i]))
        total += (error[i] / scale) ** 2
    return math.sqrt(total / error.size)


@compiled
def _factorise(a, pivot):
    """LU factorisation with partial pivoting in place; False if singular."""
    n = a.shape[0]
    for k in range(n):
        best = k
        for i in range(k + 1, n):
            if abs(a[i, k]) > abs(a[best, k]):
                best = i
        pivot[k] = best
        if a[best, k] == 0.0 or not math.isfinite(a[best, k]):
            return False
        if best != k:
            for j in range(n):
                a[k, j], a[best, j] = a[best, j], a[k, j]
        for i in range(k + 1, n):
            a[i, k] /= a[k, k]
            for j in range(k + 1, n):
                a[i, j] -= a[i, k] * a[k, j]
    return True


@compiled
def _back_substitute(a, pivot, b):
    n = a.shape[0]
    for k in range(n):
        b[k], b[pivot[k]] = b[pivot[k]], b[k]
        for i in range(k + 1, n):
            b[i] -= a[i, k] * b[k]
    for k in range(n - 1, -1, -1):
        for j in range(k + 1, n):
            b[k] -= a[k, j] * b[j]
        b[k] /= a[k, k]


@compiled
def _prepare_dense(method, kind, p, t0, h, y0, y1, f0, f1, stages, stage_y, dense, counters):
    """The coefficients of the dense output over the step (t0, t0 + h] into ``dense``.

    The cubic Hermite interpolant of the two ends (values and slopes); for DOP853 the
    order-7 polynomial of Dormand and Prince, at the cost of three more evaluations.
    """
    n = y0.size
    for i in range(n):
        delta = y1[i] - y0[i]
        dense[0, i] = delta
        dense[1, i] = h * f0[i] - delta
        dense[2, i] = 2.0 * delta - h * (f1[i] + f0[i])
        for row in range(3, _DENSE):
            dense[row, i] = 0.0
    if method != DOP853:
        return
    for extra in range(_RK_EXTENDED - _RK_STAGES - 1):
        s = _RK_STAGES + 1 + extra
        for i in range(n):
            total = 0.0
            for j in range(s):
                total += _RK_A_EXTRA[extra, j] * stages[j, i]
            stage_y[i] = y0[i] + h * total
        rhs(kind, t0 + _RK_C_EXTRA[extra] * h, stage_y, p, stages[s])
    counters[COUNT_EVALUATIONS] += _RK_EXTENDED - _RK_STAGES - 1
    for row in range(_DENSE - 3):
        for i in range(n):
            total = 0.0
            for j in range(_RK_EXTENDED):
                total += _RK_D[row, j] * stages[j, i]
            dense[3 + row, i] = h * total


@compiled
def _interpolate(t0, h, y0, dense, t, out):
    """The dense output of the step from t0 (:func:`_prepare_dense`) at t."""
    x = (t - t0) / h
    for i in range(out.size):
        value = 0.0
        for k in range(_DENSE):
            value += dense[_DENSE - 1 - k, i]
            value *= x if k % 2 == 0 else 1.0 - x
        out[i] = y0[i] + value


@compiled
def _crosses(direction, before, after):
    if direction > 0:
        return before < 0.0 <= after
    if direction < 0:
        return before > 0.0 >= after
    return False


@compiled
def _locate(kind, p, k, t0, h, y0, dense, g_before, g_after, work, g):
    """Time where event k crosses in (t0, t0 + h]: Illinois on the dense output.

    Returns the end of the final bracket past the crossing, so that the event function has
    crossed there.
    """
    low, high = t0, t0 + h
    g_low, g_high = g_before, g_after
    side = 0
    for _ in range(200):
        if high - low <= 4.0 * 2.220446049250313e-16 * max(abs(low), abs(high), 1e-300):
            break
        middle = (low * g_high - high * g_low) / (g_high - g_low)
        if not (low < middle < high):
            middle = 0.5 * (low + high)
        _interpolate(t0, h, y0, dense, middle, work)
        events(kind, middle, work, p, g)
        value = g[k]
        if value == 0.0 or (value > 0.0) == (g_high > 0.0):
            high, g_high = middle, value
            if value == 0.0:
                break
            if side == -1:
                g_low *= 0.5
            side = -1
        else:
            low, g_low = middle, value
            if side == 1:
                g_high *= 0.5
            side = 1
    return high


@compiled
def _record_step(t, y, rec_t, rec_y, counters):
    """Keep every ``stride``-th step; when the record is full, drop every other one."""
    capacity = rec_t.size
    if capacity < 2:
        return
    counters[COUNT_SEEN] += 1
    if counters[COUNT_SEEN] % counters[COUNT_STRIDE] != 0:
        return
    if counters[COUNT_RECORDED] == capacity:
        half = capacity // 2
        for i in range(half):
            rec_t[i] = rec_t[2 * i + 1]
            rec_y[i, :] = rec_y[2 * i + 1, :]
        counters[COUNT_RECORDED] = half
        counters[COUNT_STRIDE] *= 2
    rec_t[counters[COUNT_RECORDED]] = t
    rec_y[counters[COUNT_RECORDED], :] = y
    counters[COUNT_RECORDED] += 1


@compiled
def _rodas_step(
    kind,
    p,
    t,
    y,
    f0,
    h,
    rtol,
    atol,
    jac,
    dfdt,
    matrix,
    pivot,
    stages,
    y1,
    stage_y,
    stage_f,
    counters,
):
    """One Rodas4 step of size h from (t, y): y1, and the scaled error norm."""
    n = y.size
    for i in range(n):
        for j in range(n):
            matrix[i, j] = -jac[i, j]
        matrix[i, i] += 1.0 / (_GAMMA * h)
    if not _factorise(matrix, pivot):
        return math.inf
    for s in range(6):
        if s == 0:
            stage_f[:] = f0
        else:
            for i in range(n):
                total = y[i]
                for j in range(s):
                    total += _A[s, j] * stages[j, i]
                stage_y[i] = total
            rhs(kind, t + _ALPHA[s] * h, stage_y, p, stage_f)
            counters[COUNT_EVALUATIONS] += 1
        for i in range(n):
            total = stage_f[i] + _GAMMA_I[s] * h * dfdt[i]
            for j in range(s):
                total += _C[s, j] / h * stages[j, i]
            stages[s, i] = total
        _back_substitute(matrix, pivot, stages[s])
    for i in range(n):
        total = y[i]
        for j in range(6):
            total += _M[j] * stages[j, i]
        y1[i] = total
    return _error_norm(stages[5], y, y1, rtol, atol)


@compiled
def _dop853_step(kind, p, t, y, f0, h, rtol, atol, stages, y1, stage_y, counters):
    """One DOP853 step of size h from (t, y): y1, and the scaled error norm (stages[12] is
    f(t + h, y1))."""
    n = y.size
    stages[0, :] = f0
    for s in range(1, _RK_STAGES):
        for i in range(n):
            total = 0.0
            for j in range(s):
                total += _RK_A[s, j] * stages[j, i]
            stage_y[i] = y[i] + h * total
        rhs(kind, t + _RK_C[s] * h, stage_y, p, stages[s])
    for i in range(n):
        total = 0.0
        for j in range(_RK_STAGES):
            total += _RK_B[j] * stages[j, i]
        y1[i] = y[i] + h * total
    rhs(kind, t + h, y1, p, stages[_RK_STAGES])
    counters[COUNT_EVALUATIONS] += _RK_STAGES
    high = 0.0
    low = 0.0
    for i in range(n):
        scale = atol[i] + rtol * max(abs(y[i]), abs(y1[i]))
        e5 = 0.0
        e3 = 0.0
        for j in range(_RK_STAGES + 1):
            e5 += _RK_E5[j] * stages[j, i]
            e3 += _RK_E3[j] * stages[j, i]
        high += (e5 / scale) ** 2
        low += (e3 / scale) ** 2
    if high == 0.0 and low == 0.0:
        return 0.0
    if not math.isfinite(high):
        return math.inf
    return abs(h) * high / math.sqrt((high + 0.01 * low) * n)


@compiled
def solve(
    method,
    kind,
    p,
    t,
    y,
    t_end,
    rtol,
    atol,
    h,
    max_evaluations,
    directions,
    terminal,
    out_t,
    out_y,
    land,
    rec_t,
    rec_y,
    ev_t,
    ev_y,
    ev_k,
    counters,
):
    """Integrate system ``kind`` from (t, y) to ``t_end`` or its first terminal event.

    Parameters
    ----------
    method : int
        :data:`RODAS4` (stiff systems; uses the Jacobian) or :data:`DOP853`.
    kind : int
        The system (:mod:`granflow.simulation.equations`).
    p : ndarray
        Its parameter vector.
    t : float
        Start time.
    y : ndarray
        State at ``t``; overwritten with the state at the end.
    t_end : float
        End time (> t).
    rtol : float
        Relative tolerance.
    atol : ndarray
        Absolute tolerance per component.
    h : float
        First step to try; 0 to choose one.
    max_evaluations : int
        Bound on ``counters[COUNT_EVALUATIONS]`` (right-hand sides, all calls together).
    directions : ndarray of int64
        Per event function: +1 (rising through 0), -1 (falling), 0 (inactive).
    terminal : ndarray of bool
        Per event function: whether it ends the integration.
    out_t : ndarray
        Increasing output times; the interpolant fills ``out_y`` from
        ``counters[COUNT_OUT]`` on, as far as the integration gets.
    out_y : ndarray, shape (len(out_t), len(y))
    land : bool
        Whether to end steps on the output times (outputs then carry the accuracy of the
        steps, not that of the interpolant, at the cost of more steps).
    rec_t, rec_y : ndarray
        Record of the accepted steps (thinned to fit; capacity 0 for none).
    ev_t, ev_y, ev_k : ndarray
        Non-terminal events found (time, state, index), up to their capacity.
    counters : ndarray of int64
        Bookkeeping (:func:`new_counters`), carried from call to call.

    Returns
    -------
    status : int
        :data:`DONE`, :data:`EVENT` (``counters[COUNT_FIRED]`` says which),
        :data:`STEP_TOO_SMALL` or :data:`WORK_EXCEEDED`.
    t : float
        Time reached.
    h : float
        The step to try next.
    """
    n = y.size
    f0 = np.empty(n)
    f1 = np.empty(n)
    y1 = np.empty(n)
    stage_y = np.empty(n)
    stage_f = np.empty(n)
    dfdt = np.empty(n)
    jac = np.empty((n, n))
    matrix = np.empty((n, n))
    pivot = np.empty(n, dtype=np.int64)
    stages = np.empty((max(6, _RK_EXTENDED), n))
    dense = np.empty((_DENSE, n))
    g0 = np.empty(EVENTS)
    g1 = np.empty(EVENTS)
    g_work = np.empty(EVENTS)
    rhs(kind, t, y, p, f0)
    counters[COUNT_EVALUATIONS] += 1
    events(kind, t, y, p, g0)
    if h <= 0.0:
        scale_y = 0.0
        scale_f = 0.0
        for i in range(n):
            weight = atol[i] + rtol * abs(y[i])
            scale_y += (y[i] / weight) ** 2
            scale_f += (f0[i] / weight) ** 2
        scale_y, scale_f = math.sqrt(scale_y / n), math.sqrt(scale_f / n)
        h = 0.01 * scale_y / scale_f if scale_y > 1e-5 and scale_f > 1e-5 else 1e-6
        h = min(h, 1e-3 * (t_end - t)) if h > 1e-6 else min(h, t_end - t)
    rejected = False
    order = _ORDER if method == RODAS4 else _RK_ORDER
    while t < t_end:
        if counters[COUNT_EVALUATIONS] > max_evaluations:
            return WORK_EXCEEDED, t, h
        last = t + 1.01 * h >= t_end
        landing = False
        if last:
            h = t_end - t
        elif land and counters[COUNT_OUT] < out_t.size:
            target = out_t[counters[COUNT_OUT]]
            if t < target < t_end and t + 1.01 * h >= target:
                h = target - t
                landing = True
        if method == RODAS4:
            jacobian(kind, t, y, p, jac, dfdt)
        while True:
            if method == RODAS4:
                error = _rodas_step(
                    kind,
                    p,
                    t,
                    y,
                    f0,
                    h,
                    rtol,
                    atol,
                    jac,
                    dfdt,
                    matrix,
                    pivot,
                    stages,
                    y1,
                    stage_y,
                    stage_f,
                    counters,
                )
            else:
                error = _dop853_step(
                    kind, p, t, y, f0, h, rtol, atol, stages, y1, stage_y, counters
                )
            if error <= 1.0:
                break
            counters[COUNT_REJECTED] += 1
            rejected = True
            factor = _SHRINK
            if math.isfinite(error):
                factor = max(_SHRINK, _SAFETY * error ** (-1.0 / order))
            h *= factor
            last = False
            landing = False
            if h <= 1e-14 * max(abs(t), 1e-300):
                return STEP_TOO_SMALL, t, h
            if counters[COUNT_EVALUATIONS] > max_evaluations:
                return WORK_EXCEEDED, t, h
        t_new = t_end if last else (out_t[counters[COUNT_OUT]] if landing else t + h)
        if method == DOP853:
            f1[:] = stages[_RK_STAGES]
        else:
            rhs(kind, t_new, y1, p, f1)
            counters[COUNT_EVALUATIONS] += 1
        counters[COUNT_STEPS] += 1
        events(kind, t_new, y1, p, g1)
        crossing = False
        for k in range(EVENTS):
            crossing = crossing or _crosses(directions[k], g0[k], g1[k])
        wanted = counters[COUNT_OUT] < out_t.size and out_t[counters[COUNT_OUT]] <= t_new
        if crossing or wanted:
            _prepare_dense(method, kind, p, t, h, y, y1, f0, f1, stages, stage_y, dense, counters)
        fired = -1
        t_fire = t_new
        for k in range(EVENTS):
            if terminal[k] and _crosses(directions[k], g0[k], g1[k]):
                when = _locate(kind, p, k, t, h, y, dense, g0[k], g1[k], stage_y, g_work)
                if fired < 0 or when < t_fire:
                    fired, t_fire = k, when
        for k in range(EVENTS):
            if not terminal[k] and _crosses(directions[k], g0[k], g1[k]):
                when = _locate(kind, p, k, t, h, y, dense, g0[k], g1[k], stage_y, g_work)
                found = counters[COUNT_EVENTS]
                if when <= t_fire and found < ev_t.size:
                    ev_t[found] = when
                    ev_k[found] = k
                    _interpolate(t, h, y, dense, when, ev_y[found])
                    counters[COUNT_EVENTS] += 1
        while counters[COUNT_OUT] < out_t.size and out_t[counters[COUNT_OUT]] <= t_fire:
            if out_t[counters[COUNT_OUT]] == t_new:
                out_y[counters[COUNT_OUT]] = y1
            else:
                _interpolate(t, h, y, dense, out_t[counters[COUNT_OUT]], out_y[counters[COUNT_OUT]])
            counters[COUNT_OUT] += 1
        if fired >= 0:
            _interpolate(t, h, y, dense, t_fire, stage_y)
            y[:] = stage_y
            _record_step(t_fire, y, rec_t, rec_y, counters)
            counters[COUNT_FIRED] = fired
            return EVENT, t_fire, h
        y[:] = y1
        f0[:] = f1
        g0[:] = g1
        t = t_new
        _record_step(t, y, rec_t, rec_y, counters)
        factor = min(_GROW, max(_SHRINK, _SAFETY * max(error, 1e-10) ** (-1.0 / order)))
        if rejected:
            factor = min(factor, 1.0)
            rejected = False
        h *= factor
    return DONE, t, h
