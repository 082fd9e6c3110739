"""A force-controlled record that already shows its failure: where the layer started to flow.

Quasi-statically the slip before failure is bounded (it reaches x_peak - x0 at most, tens of
micrometres), and at failure the layer flows: its slip runs away at a rate far above
anything it showed before. A sample interval is the failure when

* its slip rate exceeds the record's mean rate before it (the slip so far over the time so
  far) by a factor ``max(100, 3 sqrt(n))`` (just before a quasi-static failure the sampled
  rate reaches about sqrt(t_f / dt) times that mean: 17 at 300 samples, 140 at 20 000),
* its slip increment exceeds ``_NOISE_FACTOR`` times the slip's noise (a single noisy sample
  cannot pass; the noise taken as at least 1e-6 of the slip's range, so that a simulated
  record without noise does not read its first creep out of rest as a run-away), and
* the layer keeps running away: over the next ``_SUSTAINED`` intervals (at least
  ``_SHOWN`` of them must be in the record) the median rate stays that high, within the next
  ``_AHEAD`` samples it gains more than all the slip before, and it never comes back below
  the interval's midpoint. (A staircase's step moves a quasi-static layer by a jump that can
  exceed all the slip before it near the peak, but the layer then holds still.)

The first such interval ``(t_i, t_(i+1))`` is the observed failure; the forecast then uses
the samples up to t_i only.
"""

import math
from dataclasses import dataclass

import numpy as np

from granflow.forecast._inputs import rough_noise

__all__ = ["ObservedFailure", "find_failure"]

_RATE_FACTOR = 100.0
_NOISE_FACTOR = 20.0
_AHEAD = 50  # samples
_SUSTAINED = 10  # intervals
_SHOWN = 3  # intervals after a failure the record must hold to show it


@dataclass(frozen=True)
class ObservedFailure:
    """Where a record shows its failure.

    Attributes
    ----------
    index : int
        The last sample before the failure (the forecast uses samples up to it).
    window : tuple of float
        (last sample before, first sample after) [s]: the failure lies between.
    time : float
        The failure time [s]: the middle of ``window``.
    force : float
        The imposed force there [N] (the force column interpolated at ``time``).
    """

    index: int
    window: tuple
    time: float
    force: float


def find_failure(t, slip, force):
    """The :class:`ObservedFailure` of a record (time [s], slip [m], force [N]; finite, time
    increasing), or None where the layer has not failed."""
    if t.size < 3:
        return None
    step = np.diff(slip)
    rate = step / np.diff(t)
    # the slip's noise, at least a millionth of its range: a record without noise (a
    # simulation) otherwise reads its first creep out of rest as a run-away
    noise = max(rough_noise(slip), 1e-6 * float(np.ptp(slip)))
    so_far = slip[:-1] - np.minimum.accumulate(slip)[:-1]
    elapsed = np.maximum(t[:-1] - t[0], np.diff(t))
    mean_rate = np.maximum(so_far, noise) / elapsed
    factor = max(_RATE_FACTOR, 3.0 * math.sqrt(t.size))
    candidates = np.flatnonzero((rate > factor * mean_rate) & (step > _NOISE_FACTOR * noise))
    for i in candidates:
        following = rate[i + 1 : i + 1 + _SUSTAINED]
        if following.size < _SHOWN or not np.median(following) > factor * mean_rate[i]:
            continue
        ahead = slip[i + 1 : min(i + 1 + _AHEAD, slip.size)]
        middle = slip[i] + 0.5 * step[i]
        runs_away = ahead[-1] - slip[i] > max(so_far[i], _NOISE_FACTOR * noise)
        if (runs_away or i + 1 + _AHEAD >= slip.size) and np.all(slip[i + 1 :] >= middle):
            window = (float(t[i]), float(t[i + 1]))
            time = 0.5 * (window[0] + window[1])
            level = float(np.interp(time, t, force))
            return ObservedFailure(int(i), window, time, level if math.isfinite(level) else 0.0)
    return None
