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

from granflow.errors import InvalidDataError

__all__ = ["Loading", "fit_loading"]

_JUMP_FACTOR = 8.0  # a step is a jump this many noise widths above the point-to-point noise


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
    """

    kind: str
    rate: float
    start: float
    edges: tuple = ()
    levels: tuple = ()
    step: float = 0.0
    duration: float = 0.0

    def force(self, t):
        """The imposed force [N] at times ``t`` [s] (the continued history after the record)."""
        t = np.asarray(t, dtype=float)
        if self.kind == "ramp":
            return self.start + self.rate * t
        index = np.searchsorted(np.asarray(self.edges), t, side="right")
        known = np.asarray(self.levels)[index]
        extra = np.floor(np.maximum(t - self.edges[-1], 0.0) / self.duration)
        beyond = self.levels[-1] + self.step * extra
        return np.where(t >= self.edges[-1], beyond, known)

    def time_at(self, level):
        """The first time [s] the history reaches ``level`` [N] (inf if it never does)."""
        if not math.isfinite(level):
            return math.inf
        if self.kind == "ramp":
            if self.rate <= 0:
                return math.inf
            return max((level - self.start) / self.rate, 0.0)
        for edge, value in zip((0.0, *self.edges), self.levels, strict=True):
            if value >= level:
                return float(edge)
        if self.step <= 0:
            return math.inf
        count = math.ceil((level - self.levels[-1]) / self.step)
        return float(self.edges[-1] + count * self.duration)

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
        )


def _noise(force):
    """Point-to-point noise of the force column [N] (robust: median absolute difference)."""
    return 1.4826 * float(np.median(np.abs(np.diff(force)))) / math.sqrt(2.0)


def fit_loading(t, force):
    """The force history of a record: a staircase when the force jumps between flat levels,
    else a straight line.

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
    jumps = np.abs(np.diff(force))
    noise = _noise(force)
    big = np.flatnonzero(jumps > max(_JUMP_FACTOR * noise, 1e-12 * np.max(np.abs(force))))
    if 1 <= big.size <= t.size // 4:
        bounds = [0, *(big + 1).tolist(), t.size]
        levels = [float(np.median(force[lo:hi])) for lo, hi in itertools.pairwise(bounds)]
        edges = tuple(float(t[i]) for i in big + 1)
        heights = np.diff(levels)
        durations = np.diff(edges) if len(edges) > 1 else np.array([edges[0] - t[0]])
        step = float(np.median(heights))
        duration = float(np.median(durations))
        if step <= 0 or duration <= 0:
            raise InvalidDataError("the force steps do not rise: no failure to forecast")
        return Loading(
            kind="steps",
            rate=step / duration,
            start=levels[0],
            edges=edges,
            levels=tuple(levels),
            step=step,
            duration=duration,
        )
    rate, start = np.polyfit(t, force, 1)
    return Loading(kind="ramp", rate=float(rate), start=float(start))
