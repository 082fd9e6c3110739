"""The imposed force history of a force-controlled record, read from its force column, and
its continuation beyond the record: a linear ramp, or a staircase of equal steps.

The measured force column is noisy; the forecast uses the fitted history (the ramp's line,
each step's median level), both to place the record's points on the rising branch and to
date the failure: the first time the continued history reaches F_peak.
"""

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from granflow.errors import InvalidDataError

__all__ = ["Loading", "continuing_growth", "fit_loading"]

_JUMP_FACTOR = 8.0  # a step is a jump this many noise widths above the point-to-point noise
# A step smaller than that (a height of 3-9 noise widths: one point-to-point difference does
# not show it) is found as a shift of the mean inside a level (:func:`_hidden_steps`): where
# the shift's t-statistic passes _SPLIT_SCORE (the largest of a flat level's many split
# statistics: 99th percentile 3.5-4.3 from 100 to 10^5 samples, under 5 in 900 trials) and
# its height is at least _SPLIT_HEIGHT of the median height of the steps found (a level's
# slow drift is no step).
_SPLIT_SCORE = 6.0
_SPLIT_HEIGHT = 0.25


@dataclass(frozen=True)
class Loading:
    """A force history: ``kind`` "ramp" (``start + rate t``) or "steps".

    Attributes
    ----------
    kind : str
        "ramp" or "steps".
    rate : float
        Ramp: loading rate [N/s]; steps: mean rate step height / step duration [N/s].
    start : float
        Ramp: force at t = 0 [N]; steps: level of the first step [N].
    edges : tuple of float
        Steps: times [s] at which each step after the first begins.
    levels : tuple of float
        Steps: level of each step [N] (one more than ``edges``).
    step : float
        Steps: the height of the steps that continue the staircase [N].
    duration : float
        Steps: the duration of the steps that continue the staircase [s].
    windows : tuple of (float, float)
        Steps: for each edge, the samples [s] between which it fell (the record sees a step
        only at the first sample after it); continued edges are bounded from these.
    error : tuple of float
        ``(var0, cov, var1, origin)``: the covariance of the fitted history's offset [N^2]
        and slope [N^2/s^2 or N^2 per step^2] about ``origin`` (t = 0 for a ramp, the last
        level's index for steps).
    on_line : bool
        Steps: whether the levels are the line through the steps' means (a regular
        staircase; ``error`` is that line's, for every step); else each level is its own
        step's mean, and ``error`` describes only the last level (offset: its mean's
        variance) and the step that continues the staircase beyond the record (slope: the
        sample variance of the record's step heights, or one difference of two levels
        measured like the last, whichever is larger).
    end : float
        Steps: the record's last time [s]; no step began between the last edge and it.
    """

    kind: str
    rate: float
    start: float
    edges: tuple = ()
    levels: tuple = ()
    step: float = 0.0
    duration: float = 0.0
    windows: tuple = ()
    error: tuple = (0.0, 0.0, 0.0, 0.0)
    end: float = -math.inf
    on_line: bool = True

    def force(self, t):
        """The imposed force [N] at times ``t`` [s] (the continued history after the record)."""
        t = np.asarray(t, dtype=float)
        if self.kind == "ramp":
            return self.start + self.rate * t
        index = np.searchsorted(np.asarray(self.edges), t, side="right")
        known = np.asarray(self.levels)[index]
        first = self.edge_range(self.levels[-1] + 0.5 * self.step)
        extra = 1.0 + np.floor(np.maximum(t - 0.5 * sum(first), 0.0) / self.duration)
        beyond = self.levels[-1] + self.step * extra
        return np.where(t >= max(0.5 * sum(first), self.end), beyond, known)

    def _index(self, level):
        """Index of the first step whose level reaches ``level`` (levels[0] is index 0)."""
        for index, value in enumerate(self.levels):
            if value >= level:
                return index
        if self.step <= 0:
            return None
        return len(self.levels) - 1 + math.ceil((level - self.levels[-1]) / self.step)

    def edge_range(self, level):
        """(earliest, latest) time [s] at which the history can first reach ``level`` [N]:
        for a ramp one time; for steps the range of that step's start allowed by the edges'
        sampling windows on a regular staircase (or the estimate +- half the sampling interval
        where the edges are irregular)."""
        if not math.isfinite(level):
            return (math.inf, math.inf)
        if self.kind == "ramp":
            when = math.inf if self.rate <= 0 else max((level - self.start) / self.rate, 0.0)
            return (when, when)
        index = self._index(level)
        if index is None:
            return (math.inf, math.inf)
        if index == 0:
            return (0.0, 0.0)
        if index <= len(self.windows):
            return tuple(float(v) for v in self.windows[index - 1])
        found = _extrapolated_edge(self.windows, index, self.end)
        if found is not None:
            return found
        middle = max(self.edges[-1], self.end) + (index - len(self.edges)) * self.duration
        half = 0.5 * max(hi - lo for lo, hi in self.windows)
        return (middle - half, middle + half)

    def step_starts(self, first, count):
        """(earliest, latest) arrays [s] of the starts of the ``count`` steps from index
        ``first`` on (levels[0] is index 0): :meth:`edge_range` of each, with the regular
        staircase's continued edges found for all of them by a handful of linear programs
        (:func:`_extrapolated_edges`)."""
        indices = np.arange(first, first + count)
        ranges = np.empty((count, 2))
        for position, index in enumerate(indices):
            if index == 0:
                ranges[position] = (0.0, 0.0)
            elif index <= len(self.windows):
                ranges[position] = self.windows[index - 1]
        later = indices > len(self.windows)
        if later.any():
            found = _extrapolated_edges(self.windows, indices[later], self.end)
            if found is None:
                found = np.array([self.edge_range(self._level_of(k)) for k in indices[later]]).T
            ranges[later] = np.column_stack(found)
        return ranges[:, 0], ranges[:, 1]

    def _level_of(self, index):
        """The middle of step ``index``'s force range [N]: a level that step first reaches."""
        return self.levels[-1] + (index - len(self.levels) + 0.5) * self.step

    def time_at(self, level):
        """The first time [s] the history reaches ``level`` [N] (inf if it never does): for
        steps the middle of :meth:`edge_range`."""
        low, high = self.edge_range(level)
        return 0.5 * (low + high) if math.isfinite(high) else math.inf

    def times_at(self, low, high):
        """The interval [s] from the earliest time the history can reach ``low`` to the latest
        it can first reach ``high`` [N]."""
        return (self.edge_range(low)[0], self.edge_range(high)[1])

    def to_dict(self):
        """JSON-safe mapping (SI units)."""
        return {
            "kind": self.kind,
            "rate": self.rate,
            "start": self.start,
            "edges": list(self.edges),
            "levels": list(self.levels),
            "step": self.step,
            "duration": self.duration,
            "windows": [list(w) for w in self.windows],
            "error": list(self.error),
            "end": self.end,
            "on_line": self.on_line,
        }

    @classmethod
    def from_dict(cls, d):
        """Inverse of :meth:`to_dict`."""
        return cls(
            kind=d["kind"],
            rate=float(d["rate"]),
            start=float(d["start"]),
            edges=tuple(float(v) for v in d.get("edges", ())),
            levels=tuple(float(v) for v in d.get("levels", ())),
            step=float(d.get("step", 0.0)),
            duration=float(d.get("duration", 0.0)),
            windows=tuple(tuple(float(v) for v in w) for w in d.get("windows", ())),
            error=tuple(float(v) for v in d.get("error", (0.0, 0.0, 0.0, 0.0))),
            end=-math.inf if d.get("end") is None else float(d["end"]),
            on_line=bool(d.get("on_line", True)),
        )


def _noise(force):
    """Point-to-point noise of the force column [N] (robust: median absolute difference)."""
    return 1.4826 * float(np.median(np.abs(np.diff(force)))) / math.sqrt(2.0)


def _extrapolated_edge(windows, index, end):
    """(earliest, latest) start [s] of step ``index`` on a regular staircase e0 + k D whose
    edges k = 1..m fell inside ``windows`` and whose edge m + 1 comes after ``end``; None
    where no regular staircase fits them."""
    found = _extrapolated_edges(windows, [index], end)
    if found is None:
        return None
    return (float(found[0][0]), float(found[1][0]))


def _edge_polygon(windows, end):
    """``(matrix, bound)``: the (e0, D) of a regular staircase e0 + k D whose edges k = 1..m
    fell inside ``windows`` and whose edge m + 1 comes after ``end``, as ``matrix @ (e0, D)
    <= bound``."""
    k = np.arange(1, len(windows) + 1, dtype=float)
    lows, highs = np.array(windows, dtype=float).T
    matrix = np.vstack(
        [np.column_stack([-np.ones_like(k), -k]), np.column_stack([np.ones_like(k), k])]
    )
    bound = np.concatenate([-lows, highs])
    if math.isfinite(end):
        matrix = np.vstack([matrix, [-1.0, -(k.size + 1.0)]])
        bound = np.append(bound, -end)
    return matrix, bound


def _extrapolated_edges(windows, indices, end):
    """(earliest, latest) arrays [s] of the starts of steps ``indices`` (increasing) as
    :func:`_extrapolated_edge` gives them, for many indices at once; None where no regular
    staircase fits the windows.

    The earliest start of step k, the minimum of e0 + k D over the polygon of allowed (e0, D),
    is a concave piecewise-linear function of k, one piece for each vertex of the polygon that
    is optimal somewhere (the latest start, the maximum, convex likewise). So the program is
    solved at the ends of a run of indices only: where the vertex optimal at one end gives the
    optimum at the other too, it is optimal all along the run; else the run is split where
    the two ends' vertices give the same start."""
    from scipy.optimize import linprog

    matrix, bound = _edge_polygon(windows, end)
    indices = np.asarray(indices, dtype=float)
    out = []
    for sign in (1.0, -1.0):

        def vertex(k, sign=sign):
            found = linprog(
                sign * np.array([1.0, k]), A_ub=matrix, b_ub=bound, bounds=[(None, None)] * 2
            )
            return found.x if found.success else None

        values = np.empty(indices.size)
        runs = [(0, indices.size - 1, vertex(indices[0]), vertex(indices[-1]))]
        while runs:
            a, b, x_a, x_b = runs.pop()
            if x_a is None or x_b is None:
                return None
            at_b = (x_a[0] + indices[b] * x_a[1], x_b[0] + indices[b] * x_b[1])
            scale = max(abs(at_b[1]), 1.0)
            if b - a <= 1 or abs(at_b[0] - at_b[1]) <= 1e-12 * scale:
                values[a : b + 1] = x_a[0] + indices[a : b + 1] * x_a[1]
                values[b] = at_b[1]
                continue
            # the two vertices give the same start at k*: split the run there
            cross = (x_b[0] - x_a[0]) / (x_a[1] - x_b[1]) if x_a[1] != x_b[1] else indices[a]
            m = int(np.clip(np.searchsorted(indices, cross, side="right") - 1, a, b - 1))
            x_m, x_n = vertex(indices[m]), vertex(indices[m + 1])
            runs.append((a, m, x_a, x_m))
            runs.append((m + 1, b, x_n, x_b))
        out.append(values)
    return out[0], out[1]


def _line(index, values, weights):
    """Weighted straight line through ``values`` against ``index``: (fitted values,
    covariance of (offset, slope) with the offset at the last index, misfit chi-square)."""
    design = np.column_stack([np.ones_like(index), index - index[-1]])
    root = np.sqrt(weights)
    coef = np.linalg.lstsq(design * root[:, None], values * root, rcond=None)[0]
    line = design @ coef
    cov = np.linalg.inv(design.T @ (design * weights[:, None]))
    return line, cov, float(np.sum(weights * (values - line) ** 2))


def continuing_growth(loading):
    """``growth`` of :class:`~granflow.forecast.models.Continuation` [-]: for an irregular
    staircase of n heights, pi / (2 n), the median height's variance over one height's (the
    steps to come are new draws about it); None where the history's error grows linearly
    (a ramp, a regular staircase's line)."""
    if loading.kind != "steps" or loading.on_line or len(loading.levels) < 3:
        return None
    return math.pi / (2.0 * (len(loading.levels) - 1))


def _next_height_variance(heights):
    """The predictive variance [N^2] of the next step's height about the median of the
    record's ``heights`` [N]: the heights' sample variance s^2, times ``1 + pi / (2 n)`` (the
    median's own error, for n heights) and times ``nu / (nu - 2)``, the variance of
    Student's t with ``nu = n - 1`` degrees of freedom (s^2 is itself estimated; nu taken
    as at least 3). 0 with fewer than two heights.

    With 10 heights the factor is 1.16 x 1.29 = 1.49: the sample variance alone made the
    next step's height 18 % too sure. The steps after it grow as k new draws
    (:func:`continuing_growth`), not k times this one. Over the calibration study's 2000
    irregular staircases the step PIT's central 90 % at 10 % lead held 84.4 % before these
    two and 85.5 % after (87-93 % asked): the next height is a small part of that miss."""
    n = heights.size
    if n < 2:
        return 0.0
    nu = max(n - 1, 3)
    return float(np.var(heights, ddof=1)) * (1.0 + math.pi / (2.0 * n)) * nu / (nu - 2.0)


def _best_split(values, noise):
    """(index, score, shift) of the best single split of ``values`` into two flat levels:
    the first index of the second level, the t-statistic of the difference of their means
    (in units of ``noise`` [N] per sample) and that difference [N]; None for fewer than two
    values."""
    n = values.size
    if n < 2:
        return None
    k = np.arange(1, n, dtype=float)
    cumulative = np.cumsum(values)[:-1]
    shift = (cumulative[-1] + values[-1] - cumulative) / (n - k) - cumulative / k
    score = np.abs(shift) / (noise * np.sqrt(1.0 / k + 1.0 / (n - k)))
    best = int(np.argmax(score))
    return best + 1, float(score[best]), float(shift[best])


def _splits(force, noise, lo, hi, smallest):
    """The first sample of the second level where ``force[lo:hi]`` splits into two (see
    :func:`_hidden_steps`), or None."""
    split = _best_split(force[lo:hi], noise)
    if split is None:
        return None
    index, score, shift = split
    return lo + index if score >= _SPLIT_SCORE and abs(shift) >= smallest else None


def _hidden_steps(force, big, noise):
    """``big`` (the samples after which a step shows as a jump) with the steps that no single
    jump shows: each level is split where its mean shifts by a t-statistic of at least
    ``_SPLIT_SCORE`` and by at least ``_SPLIT_HEIGHT`` of the median height of the steps
    found, over and over (binary segmentation), until no level splits. Each edge so found is
    then placed again where its two neighbours' span splits best, or dropped where that span
    does not split (a split of several merged steps can land a few samples off an edge that
    a later split finds exactly). All again with the median of the steps found so far
    (levels that merged several steps made it too high), until it no longer falls.

    With the point-to-point noise sigma, a jump shows a step of height h only where h plus
    the difference of two samples' noise passes 8 sigma: half the steps of h = 8 sigma, 8 %
    of h = 6 sigma. A hidden step merged two levels into one whose mean lay between them, and
    the forecast read the record against that history (over the calibration design, 10-16 %
    of the staircases at 10 % lead, whose 90 % intervals then held the failure in 44 %)."""
    jumps = set(big.tolist())
    found = set(jumps)
    smallest = math.inf
    for _ in range(8):
        bounds = [0, *(k + 1 for k in sorted(found)), force.size]
        levels = np.array([np.mean(force[lo:hi]) for lo, hi in itertools.pairwise(bounds)])
        heights = np.abs(np.diff(levels))
        if heights.size == 0 or not _SPLIT_HEIGHT * float(np.median(heights)) < smallest:
            break
        smallest = _SPLIT_HEIGHT * float(np.median(heights))
        pending = list(itertools.pairwise(bounds))
        while pending:
            lo, hi = pending.pop()
            start = _splits(force, noise, lo, hi, smallest)
            if start is not None:
                found.add(start - 1)
                pending += [(lo, start), (start, hi)]
        for _ in range(8):
            moved = False
            for edge in sorted(found - jumps):
                edges = sorted(found)
                at = edges.index(edge)
                lo = edges[at - 1] + 1 if at > 0 else 0
                hi = edges[at + 1] + 1 if at + 1 < len(edges) else force.size
                found.discard(edge)
                start = _splits(force, noise, lo, hi, smallest)
                if start is not None:
                    found.add(start - 1)
                moved = moved or start != edge + 1
            if not moved:
                break
    return np.array(sorted(found), dtype=big.dtype)


def _staircase(t, force, big, noise):
    """The Loading of a staircase whose steps start at samples ``big + 1``."""
    bounds = [0, *(big + 1).tolist(), t.size]
    pieces = [force[lo:hi] for lo, hi in itertools.pairwise(bounds)]
    levels = np.array([float(np.mean(p)) for p in pieces])
    counts = np.array([p.size for p in pieces], dtype=float)
    noise = max(noise, 1e-12 * float(np.max(np.abs(force))), 1e-300)
    weights = counts / noise**2
    origin = levels.size - 1
    # A regular staircase (levels on a line of the step index within their noise, chi-square
    # at 99.9 %) is known far better from the line than from each step's points, which
    # matters near the peak, where the slip is most sensitive to the force.
    # Otherwise each level is its own step's mean, independent of the others, and no line
    # describes their errors: the error kept is the last level's (its mean's variance) and
    # the continuing step's. That step is the median difference of the levels; the heights
    # to come are as uncertain as a new draw of the record's own (their predictive
    # variance, :func:`_next_height_variance`), and no less than one difference of two
    # levels as well measured as the last. The earlier levels' own errors are not kept
    # here: the quasi-static forecast gives each its own coordinate, from its step's
    # samples (failure._loading_error).
    heights = np.diff(levels)
    spread = _next_height_variance(heights)
    error = (1.0 / weights[-1], 0.0, max(2.0 / weights[-1], spread), float(origin))
    step = float(np.median(heights))
    on_line = False
    if levels.size >= 3:
        line, cov, misfit = _line(np.arange(levels.size, dtype=float), levels, weights)
        if misfit <= chi2.ppf(0.999, levels.size - 2):
            levels = line
            step = float(line[-1] - line[-2])
            error = (float(cov[0, 0]), float(cov[0, 1]), float(cov[1, 1]), float(origin))
            on_line = True
    windows = tuple((float(t[i]), float(t[i + 1])) for i in big)
    found = np.array([0.5 * (lo + hi) for lo, hi in windows])
    if found.size > 1:
        duration = float(np.polyfit(np.arange(found.size, dtype=float), found, 1)[0])
    else:
        duration = float(found[0] - t[0])
    if step <= 0 or duration <= 0:
        raise InvalidDataError("the force steps do not rise: no failure to forecast")
    return Loading(
        kind="steps",
        rate=step / duration,
        start=float(levels[0]),
        edges=tuple(float(v) for v in found),
        levels=tuple(float(v) for v in levels),
        step=step,
        duration=duration,
        windows=windows,
        error=error,
        end=float(t[-1]),
        on_line=on_line,
    )


def fit_loading(t, force):
    """The force history of a record: a staircase when the force jumps between flat levels,
    else a straight line.

    A step that shows first at sample i began between samples i - 1 and i: the edge is put
    half way and the pair kept in ``windows``.

    Parameters
    ----------
    t : numpy.ndarray
        Time [s], increasing.
    force : numpy.ndarray
        Imposed force [N] at ``t``.

    Returns
    -------
    Loading
    """
    # a jump is a step only beyond what a ramp's rate explains over its interval (a gap in
    # a ramp's sampling is no step): the median point-to-point rate, 0 on flat levels
    rate = float(np.median(np.diff(force) / np.diff(t))) if t.size > 1 else 0.0
    jumps = np.abs(np.diff(force) - rate * np.diff(t))
    noise = _noise(force)
    big = np.flatnonzero(jumps > max(_JUMP_FACTOR * noise, 1e-12 * np.max(np.abs(force))))
    if 1 <= big.size <= t.size // 4:
        big = _hidden_steps(force, big, max(noise, 1e-300))
        return _staircase(t, force, big, noise)
    (rate, start), cov = np.polyfit(t, force, 1, cov="unscaled")
    residual = force - (start + rate * t)
    variance = float(residual @ residual) / max(t.size - 2, 1)
    error = (variance * cov[1, 1], variance * cov[0, 1], variance * cov[0, 0], 0.0)
    return Loading(kind="ramp", rate=float(rate), start=float(start), error=error)
