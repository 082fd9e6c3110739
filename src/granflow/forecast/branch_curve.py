"""The quasi-static branch model of a force-controlled record at the engine's slot values
(:class:`BranchCurve`, the model of :func:`granflow.forecast.models.branch_problem`): the
slip under the held force and its Jacobian from the compiled inversion
(:func:`granflow.forecast.branch.branch_values`), x_peak projected out, and the curve they
belong to; the evaluations a fit and its profiles ask for again are kept.
"""

import math

import numpy as np

from granflow.forecast.branch import branch_values
from granflow.forecast.coordinates import natural
from granflow.model.special import compiled

__all__ = ["BranchCurve"]

#: Evaluations a :class:`BranchCurve` keeps whole (slip and Jacobian): a fit's state, its
#: polish and the profile that starts there ask for the same point again.
_CACHED = 8
#: Curves (Eq. 3's parameters and the peak) it keeps per evaluated point, until cleared.
_CURVES = 4096
#: Projected evaluations whose x_peak and gradient it keeps, to read x_peak next to them.
_RECENT = 64


def _curve(peak_force, ratio, s0, peak_slip):
    """((a, alpha, Fd, x0), (F_peak, x_peak)) of the peak coordinates, or None outside the
    curve's box."""
    a, alpha, fd, x0, _ = natural(peak_force, ratio, s0, peak_slip, np.empty((4, 4)))
    if not (math.isfinite(a) and a > 0.0):
        return None
    return (a, alpha, fd, x0), (peak_force, peak_slip)


@compiled
def _finish(unit, full, d_level, d_nuisance, shape, project, weights, mean, fallback, d_scale):
    """The slip and Jacobian of :class:`BranchCurve` from the kernel's, in place: the
    nuisance columns take F_peak's move (``full[:, 0] d_nuisance``), F_peak's column its
    factor ``d_level``; with ``project`` the unit slip ``unit`` becomes ``x* unit`` and the
    Jacobian ``x* d unit + unit d x*``, x* = sum(w u y) / sum(w u^2) the least-squares scale
    (Golub and Pereyra's variable projection; ``fallback`` where it is not positive, held),
    and ``d_scale`` is filled with d x* / d slots. Returns x* (1.0 without ``project``; 0.0
    where the unit slip has no norm)."""
    size, columns = full.shape
    for i in range(size):
        first = full[i, 0]
        for j in range(shape, columns):
            full[i, j] += first * d_nuisance[j - shape]
        full[i, 0] = first * d_level
    if not project:
        return 1.0
    norm = 0.0
    cross = 0.0
    for i in range(size):
        weighted = weights[i] * unit[i]
        norm += weighted * unit[i]
        cross += weighted * mean[i]
    if not norm > 0.0:
        return 0.0
    scale = cross / norm
    d_scale[:] = 0.0
    if scale > 0.0:
        for i in range(size):
            factor = weights[i] * (mean[i] - 2.0 * scale * unit[i])
            for j in range(columns):
                d_scale[j] += factor * full[i, j]
        for j in range(columns):
            d_scale[j] /= norm
    else:
        scale = fallback
    for i in range(size):
        u = unit[i]
        for j in range(columns):
            full[i, j] = scale * full[i, j] + u * d_scale[j]
        unit[i] = scale * u
    return scale


class BranchCurve:
    """The branch model of a record at slot values: the slip and its Jacobian, and the curve
    (Eq. 3's parameters, the peak) they belong to.

    In the peak coordinates the slip is ``x_peak u(H; F_peak, r, s0)``: x_peak scales it. So
    with ``project`` (no prior on alpha, the one prior that involves x_peak) x_peak is not a
    slot: at each (F_peak, r, s0, z) it is the least-squares scale of the unit slip u
    (variable projection; Golub and Pereyra), and the Jacobian is that of the projected
    model, ``x* du + u dx*``. The optimiser then moves over the curve's shape only, where
    the valleys of chi-square are nearly straight. Without ``project`` x_peak is the fourth
    slot.
    """

    def __init__(self, groups, floor, continuation, project):
        self.groups, self.floor = groups, floor
        self.continuation, self.project = continuation, project
        self.base = np.ascontiguousarray(groups.base)
        self.error = np.ascontiguousarray(groups.error)
        self.size, self.m = self.error.shape
        self.shape = 3 if project else 4  # slots before the nuisance
        # (sqrt(count) / sigma)^2 up to sigma^-2
        self.weights = np.ascontiguousarray(groups.count, dtype=float)
        self.mean = np.ascontiguousarray(groups.mean, dtype=float)
        # x_peak where the unit slip's best scale is not positive (a penalty's flat value)
        self.fallback = 1e-3 * max(float(np.max(np.abs(groups.mean))), 1e-12)
        self._cache = {}  # the last few evaluations, newest last
        self._curves = {}  # the curve of every evaluation (small): the profiles' points
        self._recent = []  # (values, x*, dx*/d slots) of the last projected evaluations

    def peak_force(self, values):
        """(F_peak [N], dF_peak / d slot 0, dF_peak / dz) at ``values``."""
        level = self.floor + values[0]
        if self.continuation is None:
            return level, 1.0, np.zeros(self.m)
        return self.continuation.peak_force(level, values[self.shape :])

    def __call__(self, values):
        """(slip, jacobian, curve) at the slot ``values``: curve is ``((a, alpha, Fd, x0),
        (F_peak, x_peak))``, or None (the slip then a flat penalty) outside the box."""
        key = values.tobytes()
        found = self._cache.pop(key, None)
        if found is None:
            found = self._evaluate(values)
            if len(self._cache) >= _CACHED:
                del self._cache[next(iter(self._cache))]
            if len(self._curves) >= _CURVES:
                self._curves.clear()
            self._curves[key] = found[2]
        self._cache[key] = found
        return found

    def found(self, values):
        """The curve ``((a, alpha, Fd, x0), (F_peak, x_peak))`` at ``values`` (None outside
        the box), without a new pass over the data where it was evaluated there before."""
        values = np.asarray(values, dtype=float)
        key = values.tobytes()
        if key in self._curves:
            return self._curves[key]
        return self(values)[2]

    def peak_at(self, values, near=1e-3):
        """The curve at ``values`` as :meth:`found` gives it, but where ``values`` lies next
        to a projected evaluation (every slot within ``near`` of it, relative, or absolute
        below 1: a profile's point, one Gauss-Newton step from its last evaluation), x_peak
        from that evaluation's x* and its gradient (first order: off by about 1e-6 of it
        within 1e-3, 3e-5 within 3e-2), and without ``project`` from the slots alone: for
        reporting x_peak over many points (the slip's interval), not for fitting."""
        values = np.asarray(values, dtype=float)
        key = values.tobytes()
        if key in self._curves:
            return self._curves[key]
        peak_force = self.peak_force(values)[0]
        if not self.project:
            curve = _curve(peak_force, values[1], values[2], values[3])
            return curve if curve is not None else self(values)[2]
        for recent, scale, gradient in reversed(self._recent):
            size = np.maximum(np.maximum(np.abs(recent), np.abs(values)), 1.0)
            if np.all(np.abs(values - recent) <= near * size):
                peak_slip = scale + float(gradient @ (values - recent))
                if peak_slip > 0:
                    unit = _curve(peak_force, values[1], values[2], 1.0)
                    if unit is not None:
                        a, alpha, fd, x0 = unit[0]
                        return (a, alpha / peak_slip, fd, x0 * peak_slip), (peak_force, peak_slip)
                break
        return self(values)[2]

    def _evaluate(self, values):
        shape, m, size = self.shape, self.m, self.size
        peak_force, d_level, d_nuisance = self.peak_force(values)
        ratio, s0 = values[1], values[2]
        peak_slip = 1.0 if self.project else values[3]
        inner = np.empty((4, 4))
        a, alpha, fd, x0, _ = natural(peak_force, ratio, s0, peak_slip, inner)
        slots = shape + m
        if not (math.isfinite(a) and a > 0.0):
            penalty = np.full(size, 1e3 * (np.max(np.abs(self.groups.mean)) + 1e-12))
            return penalty, np.zeros((size, slots)), None
        nuisance = np.ascontiguousarray(values[shape:])
        # columns: the shape's coordinates (F_peak, r, s0[, x_peak]), then z through H
        unit = np.empty(size)
        full = np.empty((size, shape + m))
        branch_values(
            self.base,
            self.error,
            nuisance,
            (a, alpha, fd, x0),
            (peak_force, peak_slip),
            np.ascontiguousarray(inner[:, :shape]),
            unit,
            full,
        )
        if not np.all(np.isfinite(unit)):
            penalty = np.full(size, 1e3 * (np.max(np.abs(self.groups.mean)) + 1e-12))
            return penalty, np.zeros((size, slots)), None
        # slot 0 is F_peak's (or P's) gap; z also moves F_peak in the time variant; with
        # ``project``, x_peak is the least-squares scale of the unit slip
        d_scale = np.empty(slots)
        scale = _finish(
            unit,
            full,
            d_level,
            np.ascontiguousarray(d_nuisance, dtype=float),
            shape,
            self.project,
            self.weights,
            self.mean,
            self.fallback,
            d_scale,
        )
        if not scale > 0:
            penalty = np.full(size, 1e3 * (np.max(np.abs(self.groups.mean)) + 1e-12))
            return penalty, np.zeros((size, slots)), None
        if not self.project:
            return unit, full, ((a, alpha, fd, x0), (peak_force, peak_slip))
        params = (a, alpha / scale, fd, x0 * scale)
        self._recent.append((values.copy(), scale, d_scale))
        if len(self._recent) > _RECENT:
            del self._recent[0]
        return unit, full, (params, (peak_force, scale))

    def subset(self, index, values):
        """The slip at the groups ``index`` only (the engine ranks starts on every k-th
        point): the held force from all groups, the inversion (and the projected scale) at
        those."""
        shape, m = self.shape, self.m
        peak_force, _, _ = self.peak_force(values)
        peak_slip = 1.0 if self.project else values[3]
        inner = np.empty((4, 4))
        a, alpha, fd, x0, _ = natural(peak_force, values[1], values[2], peak_slip, inner)
        flat = np.full(index.size, 1e3 * (np.max(np.abs(self.groups.mean)) + 1e-12))
        if not (math.isfinite(a) and a > 0.0):
            return flat
        nuisance = np.ascontiguousarray(values[shape:])
        history = self.base + self.error @ nuisance
        held = np.maximum.accumulate(history)
        argmax = np.maximum.accumulate(np.where(history >= held, np.arange(self.size), 0))
        rows = argmax[index]
        chosen_error = np.ascontiguousarray(self.error[rows])
        chosen_base = np.ascontiguousarray(held[index] - chosen_error @ nuisance)
        unit = np.empty(index.size)
        branch_values(
            chosen_base,
            chosen_error,
            nuisance,
            (a, alpha, fd, x0),
            (peak_force, peak_slip),
            np.eye(4),
            unit,
            np.empty((index.size, 4 + m)),
        )
        if not np.all(np.isfinite(unit)):
            return flat
        if not self.project:
            return unit
        weight = self.weights[index]
        norm = float(np.sum(weight * unit * unit))
        if not norm > 0:
            return flat
        return unit * max(float(np.sum(weight * unit * self.groups.mean[index])) / norm, 0.0)

    def natural(self, values):
        """((a, alpha, Fd, x0), d(a, alpha, Fd, x0) / d slots) at ``values``, or None."""
        curve = self.found(values)
        if curve is None:
            return None
        shape, m = self.shape, self.m
        peak_force, d_level, d_nuisance = self.peak_force(values)
        peak_slip = curve[1][1]
        inner = np.empty((4, 4))
        natural(peak_force, values[1], values[2], peak_slip, inner)
        chain = np.zeros((4, shape + m))
        chain[:, :shape] = inner[:, :shape]
        chain[:, 0] = inner[:, 0] * d_level
        if m:
            chain[:, shape:] = np.outer(inner[:, 0], d_nuisance)
        return np.array(curve[0]), chain
