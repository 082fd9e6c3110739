"""The creep model of the failure forecast: the direct effect (:mod:`granflow.forecast.creep`)
fitted to the slip before the cut, as a model of the fitting engine (:class:`CreepModel`,
:func:`creep_problem`); :mod:`granflow.forecast.creeping` forecasts with it.

The curve is in the peak coordinates (:mod:`granflow.forecast.coordinates`). With x = x_peak
xi the curve is ``F_peak f(xi; r, s0)``, so ``Gamma(x) = x_peak gamma(xi)`` with gamma the
unit curve's, and the slip ``x - x0 = x_peak (xi(t) - xi0)`` where ``gamma(xi) = 2 w S(t)``,
``w = v_ref / x_peak``: x_peak scales the slip and is projected out (variable projection,
as in :class:`~granflow.forecast.models.BranchCurve`). Two models share the data and differ
in one slot:

* the strength's: slots ``(F_peak, r, s0, A, lag[, e, d], z0, z1)``; the failure time
  follows;
* the time's: slots ``(t_f - until, r, s0, A, F_peak[, e, d], z0, z1)``; w follows from
  t_f in closed form (``gamma(xi_fail) = 2 w S(t_f)``), so the profile over the failure
  time is a profile over a slot.

The direct effect makes the friction lag behind the force: sliding at velocity v the layer
holds ``F(x) = sigma - A ln(v / v_ref)``. Over a record whose velocity changes little, the
data fix that lag far better than A and v_ref apart, so v_ref enters through it: ``lag =
A ln(w_ref / w)`` [N], the lag at the reference rate ``w_ref`` (the record's last velocity
over the quasi-static fit's x_peak), ``w = w_ref exp(-lag / A)``.

``A`` is absent where it is held. A staircase's edges, known to within their sampling
windows only, move by ``(e, d)`` (offset and stretch, unpenalised: :func:`history_with_error`),
and the force history's error is two standard-normal coordinates (as in the quasi-static
forecast). The Jacobian is taken by forward differences: the shape's slots rebuild the
unit curve, the others only the history and its inversion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem
from granflow.forecast.coordinates import natural
from granflow.forecast.creep import (
    FIT_FALLING,
    FIT_RISING,
    History,
    curve_grid,
    curve_grid_slopes,
    history_cumulative,
    history_integral,
    ramp_history,
    slip_at,
    slip_jacobian,
)
from granflow.forecast.creep_failure import first_passage, rate_for_passage
from granflow.forecast.models import NUISANCE_BOUND, S0_RANGE, Penalty, ratio_parameter
from granflow.model.params import Params

__all__ = [
    "EDGE_BOUND",
    "STEP",
    "CreepModel",
    "CreepState",
    "creep_problem",
    "history_with_error",
    "staircase_edges",
]

_EDGE_SCALE, _PERIOD_SCALE = 0.1, 0.02  # the edges move by 0.1 e sampling intervals, and
# each step lasts 0.02 d sampling intervals longer
_CONTINUED_STEPS = 400
_PEAK = FIT_RISING.size - 1  # the unit curve's node at its peak (x = 1)
STEP = 1e-7  # forward differences: relative in log slots, absolute in linear ones
EDGE_BOUND = 10.0  # the edges' offset and stretch slots (e, d) lie within +-10


@dataclass(frozen=True)
class CreepState:
    """One point of a creep fit: Eq. 3's parameters, the direct effect and the failure.

    Attributes
    ----------
    params : Params
        a [N], alpha [1/m], Fd [N], x0 [m].
    amplitude : float
        A [N].
    velocity : float
        v_ref [m/s].
    peak_force : float
        F_peak [N].
    peak_slip : float
        x_peak [m].
    failure_time : float
        When the layer runs past the peak under the continued history [s] (inf if never).
    """

    params: object
    amplitude: float
    velocity: float
    peak_force: float
    peak_slip: float
    failure_time: float


def staircase_edges(loading):
    """The edges of a staircase's steps [s] in the record, and when its first continued
    step begins [s]; (None, 0) for a ramp. Computed once per record.

    A creeping layer slips fastest just after an edge, so its time matters to within a
    fraction of the sampling interval: where the edges' sampling windows allow a regular
    staircase (the midpoints within a window's width of their straight line against the
    step index), the edges are that line (and the continued steps go on along it), else
    the midpoints (and the continuation of :meth:`Loading.force`).
    """
    if loading.kind == "ramp":
        return None, 0.0
    found = np.asarray(loading.edges, dtype=float)
    if found.size >= 3:
        index = np.arange(1, found.size + 1, dtype=float)
        slope, intercept = np.polyfit(index, found, 1)
        line = intercept + slope * index
        width = max(hi - lo for lo, hi in loading.windows)
        if np.max(np.abs(line - found)) <= width:
            return line, max(intercept + slope * (found.size + 1), loading.end)
    first = loading.edge_range(loading.levels[-1] + 0.5 * loading.step)
    return found, max(0.5 * (first[0] + first[1]), loading.end)


def history_with_error(loading, root, z, ceiling, shift=(0.0, 0.0), edges=None):
    """The imposed force history: the fitted one plus its error (``root @ z``, the offset and
    slope errors of :func:`~granflow.forecast.quasistatic.loading_error`), and its continuation
    beyond the record (steps up to ``ceiling`` [N], then the last level).

    A staircase's edges (:func:`staircase_edges`, or ``edges``: its result) are known to
    within their sampling windows only, and a creeping layer slips fastest just after each
    edge, so they move: ``shift`` = (offset [s], stretch [s]) puts edge k (1 the first,
    n the record's last) ``offset + (k - n) stretch`` later (both fitted), the record's
    edges no further than their windows' ends (an edge past the sample before it would
    have that sample see the burst of creep after the edge: a cliff in chi-square that
    the force record rules out)."""
    c0, c1 = root @ z if z.size else (0.0, 0.0)
    if loading.kind == "ramp":
        origin = loading.error[3]
        start = loading.start + c0 - c1 * origin
        return ramp_history(start, max(loading.rate + c1, 1e-9 * abs(loading.rate)))
    levels = np.asarray(loading.levels, dtype=float)
    origin = levels.size - 1
    index = np.arange(levels.size, dtype=float) - origin
    levels = levels + (c0 + c1 * index if loading.on_line else c0 * (index == 0))
    step = loading.step + c1
    known, begin = staircase_edges(loading) if edges is None else edges
    count = 0
    if step > 0:
        count = int(min(max(math.ceil((ceiling - levels[-1]) / step), 1), _CONTINUED_STEPS))
    continued = levels[-1] + step * np.arange(1, count + 1)
    edges = np.concatenate([known, begin + loading.duration * np.arange(count)])
    offset, stretch = shift
    edges = edges + offset + stretch * (np.arange(1, edges.size + 1) - known.size)
    if len(loading.windows) == known.size:
        edges[: known.size] = np.clip(edges[: known.size], *np.transpose(loading.windows))
    starts = np.concatenate([[0.0], edges])
    values = np.concatenate([levels, continued])
    return History(starts, values, np.zeros(values.size))


class _Slopes:
    """A unit curve's shape derivatives (:func:`curve_grid_slopes`), made when first asked:
    only a Jacobian needs them, and most curves are built for chi-square alone (a trial
    step, a ranked start, a moved curve's failure rate)."""

    def __init__(self, params, transform, peak_force, amplitude, grid, rows):
        self._inputs = (params, transform, peak_force, amplitude, grid, rows)
        self._arrays = None

    def arrays(self):
        """``(slope, cumulative)``: (rows, nodes) arrays over the curve's grid."""
        if self._arrays is None:
            params, transform, peak_force, amplitude, grid, rows = self._inputs
            size = grid[0].size
            slope, cumulative = np.empty((rows, size)), np.empty((rows, size))
            inner = np.ascontiguousarray(transform[:, :3])
            curve_grid_slopes(
                params, inner, peak_force, amplitude, grid[0], grid[1], slope, cumulative
            )
            self._arrays = (slope, cumulative)
        return self._arrays


class CreepModel:
    """The creep model of one record at slot values (see the module's docstring).

    The slots are ``(F_peak, r, s0[, A], lag or gap[, e, d], z0, z1)``: the first three or
    four move the unit curve (its derivatives analytic, :func:`curve_grid_slopes`), the
    others only the targets ``2 w S(t)`` its inverse is read at (their derivatives by
    forward differences, which rebuild no curve).

    Parameters
    ----------
    time, slip : numpy.ndarray
        The record up to the cut [s, m].
    loading : Loading
        Its force history.
    root : numpy.ndarray
        (2, 2): the history's offset and slope errors per nuisance coordinate [N].
    amplitude : float or None
        A held [N], or None (fitted).
    until : float
        The cut [s] (the time variant's floor).
    rate : float
        The reference rate w_ref [1/s] of the lag.
    peak_slip : float
        x_peak [m] at which the time variant reads the failure's velocity threshold (the
        strength's best fit's; the threshold moves the failure by milliseconds only).
    timed : bool
        The time variant.
    """

    def __init__(self, time, slip, loading, root, amplitude, until, rate, peak_slip, timed=False):
        self.time, self.slip, self.loading, self.root = time, slip, loading, root
        self.fixed = amplitude
        self.until, self.timed = until, timed
        self.reference_rate, self.reference_slip = rate, peak_slip
        self.staircase = loading.kind == "steps"
        self.edges = staircase_edges(loading)
        self.window = max((hi - lo for lo, hi in loading.windows), default=0.0)
        self.ceiling = float(np.max(loading.force(time)))
        names = ["peak_force", "ratio", "s0"]
        if amplitude is None:
            names.append("amplitude")
        self.shape = len(names)  # slots that move the curve
        names.append("gap" if timed else "lag")
        if self.staircase:
            names += ["e", "d"]
        names += ["z0", "z1"]
        self.names = tuple(names)
        self.profiled = names.index("gap") if timed else 0
        self.first_nuisance = len(names) - 2
        self._curve_key, self._curve = None, None
        self._cache = {}
        self._histories = {}

    def unpack(self, values):
        """The slot values by name."""
        out = dict(zip(self.names, values, strict=True))
        if self.fixed is not None:
            out["amplitude"] = self.fixed
        return out

    def unit_curve(self, peak_force, ratio, s0, amplitude):
        """The unit curve (x_peak = 1) at a shape, or None outside the box: ``(params, grid,
        slopes, d_start)`` with ``grid = (x, exponent, gamma)``, the shape derivatives of
        :func:`curve_grid_slopes` (made when first asked: ``slopes.arrays()``) and d x0 /
        d shape; the last one kept (the targets' forward differences reuse it)."""
        key = (peak_force, ratio, s0, amplitude)
        if key != self._curve_key:
            self._curve_key, self._curve = key, self._build(peak_force, ratio, s0, amplitude)
        return self._curve

    def _build(self, peak_force, ratio, s0, amplitude):
        transform = np.empty((4, 4))
        a, alpha, fd, x0, _ = natural(peak_force, ratio, s0, 1.0, transform)
        if not (math.isfinite(a) and a > 0 and amplitude > 0):
            return None
        size = FIT_RISING.size + FIT_FALLING.size
        grid = (np.empty(size), np.empty(size), np.empty(size))
        params = (a, alpha, fd, x0)
        curve_grid(params, peak_force, 1.0, amplitude, FIT_RISING, FIT_FALLING, *grid)
        d_start = np.zeros(self.shape)
        d_start[:3] = transform[3, :3]
        slopes = _Slopes(params, transform, peak_force, amplitude, grid, self.shape)
        return params, grid, slopes, d_start

    def history(self, slots, peak_force, amplitude):
        """The imposed history at the slots' nuisance and edge shift."""
        z = np.array([slots["z0"], slots["z1"]])
        shift = (0.0, 0.0)
        if self.staircase:
            window = self.window
            shift = (_EDGE_SCALE * slots["e"] * window, _PERIOD_SCALE * slots["d"] * window)
        ceiling = max(self.ceiling, peak_force + 40.0 * amplitude)
        return history_with_error(self.loading, self.root, z, ceiling, shift, self.edges)

    def edges_at(self, values):
        """A staircase's edges [s] at the slot ``values``: the record's, moved by (e, d), and
        the continued ones (as many as the nuisance's history asks; empty for a ramp)."""
        if not self.staircase:
            return np.zeros(0)
        slots = self.unpack(values)
        return self.history(slots, slots["peak_force"], slots["amplitude"]).starts[1:]

    def edge_slot(self, seconds):
        """The offset slot e that moves every edge ``seconds`` [s] later."""
        return seconds / (_EDGE_SCALE * self.window) if self.window > 0 else 0.0

    def _history(self, slots):
        """(history, pieces, S at the record's times) of the slots; the last few kept by
        what moves them (the nuisance, the edges, A), since F_peak only scales S:
        ``S(t; F_peak) = S(t; F_ref) exp(-(F_peak - F_ref) / A)``."""
        peak_force, amplitude = slots["peak_force"], slots["amplitude"]
        key = (slots["z0"], slots["z1"], slots.get("e"), slots.get("d"), amplitude)
        found = self._histories.get(key)
        if found is None or abs(found[0] - peak_force) > 5.0 * amplitude:
            history = self.history(slots, peak_force, amplitude)
            cumulative = np.empty(history.starts.size)
            history_cumulative(
                history.starts, history.begin, history.rate, amplitude, peak_force, cumulative
            )
            integral = np.empty(self.time.size)
            pieces = (history.starts, history.begin, history.rate, cumulative)
            history_integral(self.time, *pieces, amplitude, peak_force, integral)
            if len(self._histories) > 16:
                self._histories.clear()
            found = self._histories[key] = (peak_force, history, cumulative, integral)
        reference, history, cumulative, integral = found
        factor = math.exp(-(peak_force - reference) / amplitude)
        pieces = (
            history.starts,
            history.begin,
            history.rate,
            cumulative * factor,
            amplitude,
            peak_force,
        )
        return history, pieces, integral * factor

    def targets(self, values, curve):
        """``(2 w S(t) [m] at the record's times, w [1/s], history, pieces)`` at the slot
        ``values`` on the unit curve ``curve`` (None where w is not finite)."""
        slots = self.unpack(values)
        amplitude = slots["amplitude"]
        history, pieces, integral = self._history(slots)
        if self.timed:
            w = self._rate_for_failure(curve, history, pieces, self.until + slots["gap"])
        else:
            exponent_of_rate = -slots["lag"] / amplitude
            w = (
                self.reference_rate * math.exp(exponent_of_rate)
                if abs(exponent_of_rate) < 700.0
                else math.inf
            )
        if not (math.isfinite(w) and w > 0):
            return None
        return 2.0 * w * np.maximum(integral, 0.0), w, history, pieces

    def evaluate(self, values):
        """(slip [m] at the record's times, CreepState) at the slot ``values``; the slip is
        None outside the box."""
        key = values.tobytes()
        if key in self._cache:
            return self._cache[key]
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            # a far start's curve overflows: not finite, so outside the box (None)
            found = self._evaluate(values)
        if len(self._cache) > 64:
            self._cache.clear()
        self._cache[key] = found
        return found

    def _evaluate(self, values):
        slots = self.unpack(values)
        peak_force, amplitude = slots["peak_force"], slots["amplitude"]
        curve = self.unit_curve(peak_force, slots["ratio"], slots["s0"], amplitude)
        if curve is None:
            return None, None
        found = self.targets(values, curve)
        if found is None:
            return None, None
        target, w, history, pieces = found
        params, (x, exponent, gamma), _, _ = curve
        xi = np.empty(self.time.size)
        slip_at(target, x, exponent, gamma, xi)
        shape = xi - params[3]
        norm = float(shape @ shape)
        scale = float(shape @ self.slip) / norm if norm > 0 else 0.0
        if not (math.isfinite(scale) and scale > 0):
            return None, None
        velocity = w * scale
        if self.timed:
            failure_time = self.until + slots["gap"]
        else:
            failure_time = self._failure_time(curve, history, pieces, w, velocity)
        a, alpha, fd, x0 = params
        state = CreepState(
            Params(a=a, alpha=alpha / scale, Fd=fd, x0=x0 * scale),
            amplitude,
            velocity,
            peak_force,
            scale,
            failure_time,
        )
        return scale * shape, state

    @staticmethod
    def _failure_time(curve, history, pieces, w, velocity):
        """When the layer passes the failure velocity past the peak [s] (inf if never):
        :func:`~granflow.forecast.creep_failure.first_passage` on the unit curve."""
        _, (x, exponent, gamma), _, _ = curve
        return float(first_passage(*pieces, x, exponent, gamma, _PEAK, w, velocity))

    def _rate_for_failure(self, curve, history, pieces, failure_time):
        """w [1/s] that puts the failure at ``failure_time`` [s] (inf where S(t_f) is 0):
        :func:`~granflow.forecast.creep_failure.rate_for_passage` on the unit curve, v_ref = w
        times the reference x_peak."""
        _, (x, exponent, gamma), _, _ = curve
        amplitude, peak_force = pieces[4], pieces[5]
        scaled = np.empty(1)
        history_integral(np.array([failure_time]), *pieces, scaled)
        sigma = float(history.force(failure_time))
        return float(
            rate_for_passage(
                float(scaled[0]),
                sigma,
                amplitude,
                peak_force,
                x,
                exponent,
                gamma,
                _PEAK,
                self.reference_slip,
            )
        )

    def function_and_jacobian(self, values, log):
        """(slip, d slip / d slots); a flat penalty outside the box."""
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            # a far start's curve overflows; the engine takes what is not finite as no step
            return self._function_and_jacobian(values, log)

    def _function_and_jacobian(self, values, log):
        size, n = self.time.size, values.size
        base, state = self.evaluate(values)
        if base is None:
            return np.full(size, 1e3 * (np.max(np.abs(self.slip)) + 1e-12)), np.zeros((size, n))
        slots = self.unpack(values)
        curve = self.unit_curve(
            slots["peak_force"], slots["ratio"], slots["s0"], slots["amplitude"]
        )
        params, (x, exponent, gamma), slopes, d_start = curve
        slope, cumulative = slopes.arrays()
        target, w, history, pieces = self.targets(values, curve)
        # the targets' own derivatives, the unit curve held
        d_target = np.empty((size, n))
        amplitude = slots["amplitude"]
        for k, name in enumerate(self.names):
            if name in ("peak_force", "lag"):
                # S scales as exp(-F_peak / A), w as exp(-lag / A); in the time variant w
                # goes as 1 / S(t_f), so F_peak's scale cancels there
                d_target[:, k] = 0.0 if self.timed and name == "peak_force" else -target / amplitude
                continue
            if name in ("ratio", "s0"):
                d_target[:, k] = 0.0  # the curve's shape only (added by slip_jacobian)
                continue
            step = STEP * abs(values[k]) if log[k] else STEP
            moved = values.copy()
            moved[k] += step if step > 0 else STEP
            found = self.targets(moved, curve)
            d_target[:, k] = 0.0 if found is None else (found[0] - target) / (moved[k] - values[k])
        if self.timed:
            # w moves with the curve's shape too (the failure's point on it): forward
            # differences of ln w over each shape slot on its own rebuilt curve, less what
            # the loop above took at the curve held (A's history) or what cancels exactly
            # (F_peak's: S scales as exp(-F_peak / A))
            failure_time = self.until + slots["gap"]
            names = ("peak_force", "ratio", "s0", "amplitude")
            for k in range(self.shape):
                name = names[k]
                step = STEP * abs(values[k]) if log[k] else STEP
                moved = dict(slots)
                moved[name] = values[k] + (step if step > 0 else STEP)
                other = self._build(
                    moved["peak_force"], moved["ratio"], moved["s0"], moved["amplitude"]
                )
                if other is None:
                    continue
                held = w
                moved_pieces = pieces
                if name in ("peak_force", "amplitude"):
                    _, moved_pieces, _ = self._history(moved)
                    held = self._rate_for_failure(curve, history, moved_pieces, failure_time)
                w_moved = self._rate_for_failure(other, history, moved_pieces, failure_time)
                if not (math.isfinite(w_moved) and w_moved > 0 and held > 0):
                    continue
                change = math.log(w_moved / held) / (moved[name] - values[k])
                d_target[:, k] += target * change
        xi = np.empty(size)
        jacobian = np.empty((size, n))
        slip_jacobian(
            target, d_target, x, exponent, gamma, slope, cumulative, d_start, xi, jacobian
        )
        jacobian[:, : self.shape] -= d_start[None, :]
        shape = xi - params[3]
        norm = float(shape @ shape)
        scale = state.peak_slip
        d_scale = (self.slip @ jacobian - 2.0 * scale * (shape @ jacobian)) / norm
        return base, scale * jacobian + np.outer(shape, d_scale)


def creep_problem(model, sigma, values, prior=None):
    """The engine's Problem of a :class:`CreepModel` at noise ``sigma`` [m] and slot
    ``values``."""
    log = []
    parameters = []
    held = float(np.max(model.loading.force(model.time)))
    duration = float(model.time[-1] - model.time[0]) or 1.0
    for name, value in zip(model.names, values, strict=True):
        if name == "peak_force":
            parameter = GlobalParameter(
                name, float(value), log=True, lower=1e-3 * held, upper=1e3 * held
            )
        elif name == "gap":
            parameter = GlobalParameter(
                name, float(value), log=True, lower=1e-9 * duration, upper=1e4 * duration
            )
        elif name == "ratio":
            parameter = ratio_parameter(value)
        elif name == "s0":
            parameter = GlobalParameter(
                name, float(value), log=True, lower=S0_RANGE[0], upper=S0_RANGE[1]
            )
        elif name == "amplitude":
            parameter = GlobalParameter(name, float(value), log=True, lower=1e-6 * held, upper=held)
        elif name == "lag":
            parameter = GlobalParameter(name, float(value), log=False, lower=-held, upper=held)
            parameter.scale = 1e-3 * held
        elif name in ("e", "d"):
            parameter = GlobalParameter(
                name, float(value), log=False, lower=-EDGE_BOUND, upper=EDGE_BOUND
            )
            parameter.scale = 1.0
        else:
            parameter = GlobalParameter(
                name, float(value), log=False, lower=-NUISANCE_BOUND, upper=NUISANCE_BOUND
            )
            parameter.scale = 1.0
        parameters.append(parameter)
        log.append(parameter.log)

    def function(z, *current):
        current = np.array(current, dtype=float)
        slip, _ = model.evaluate(current)
        if slip is None:
            return np.full(z.shape[0], 1e3 * (np.max(np.abs(model.slip)) + 1e-12))
        return slip[z.astype(np.int64)]

    def jacobian(z, *current):
        return model.function_and_jacobian(np.array(current, dtype=float), log)

    engine_model = Model(slots=model.names, function=function, jacobian=jacobian, log=tuple(log))

    def natural_of(current):
        _, state = model.evaluate(np.asarray(current, dtype=float))
        if state is None:
            return None
        p = state.params
        # the prior's derivatives by forward differences through the model
        base = np.array([p.a, p.alpha, p.Fd, p.x0])
        chain = np.zeros((4, len(current)))
        for k in range(len(current)):
            step = STEP * abs(current[k]) if log[k] else STEP
            moved = np.array(current, dtype=float)
            moved[k] += step
            _, other = model.evaluate(moved)
            if other is not None:
                q = other.params
                chain[:, k] = (np.array([q.a, q.alpha, q.Fd, q.x0]) - base) / step
        return base, chain

    penalty = Penalty(model.first_nuisance, 2, prior, natural_of)
    data = Curve(
        z=np.arange(model.time.size, dtype=float),
        y=np.ascontiguousarray(model.slip),
        w=np.full(model.time.size, 1.0 / sigma),
        links=tuple((k, 1.0) for k in range(len(values))),
    )
    return Problem([data], parameters, model=engine_model, penalty=penalty, rough=model.staircase)
