"""A force-controlled record that already shows its failure: where the layer started to flow.

Quasi-statically the slip before failure is bounded (it reaches x_peak - x0 at most, tens of
micrometres), and at failure the layer flows: its slip runs away at a rate far above
anything it showed before. A sample interval is the failure when

* its slip rate exceeds ``_RATE_FACTOR`` times the record's mean rate before it (the slip so
  far over the time so far; just before a quasi-static failure the sampled rate reaches about
  sqrt(t_f / dt) times that mean, 17 at 300 samples, 140 at 20 000),
* its slip increment exceeds the whole slip before it and ``_NOISE_FACTOR`` times the slip's
  noise (a single noisy sample cannot pass), and
* the slip does not come back: every later sample stays above the midpoint of the jump.

The first such interval ``(t_i, t_(i+1))`` is the observed failure; the forecast then uses
the samples up to t_i only.
"""

import math
from dataclasses import dataclass

import numpy as np

from granflow.forecast._inputs import rough_noise

__all__ = ["ObservedFailure", "find_failure"]

_RATE_FACTOR = 1000.0
_NOISE_FACTOR = 20.0


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
    dt = np.diff(t)
    rate = step / dt
    noise = rough_noise(slip)
    so_far = slip[:-1] - np.minimum.accumulate(slip)[:-1]
    elapsed = np.maximum(t[:-1] - t[0], dt)
    mean_rate = np.maximum(so_far, noise) / elapsed
    candidates = np.flatnonzero(
        (rate > _RATE_FACTOR * mean_rate) & (step > so_far) & (step > _NOISE_FACTOR * noise)
    )
    for i in candidates:
        middle = slip[i] + 0.5 * step[i]
        if np.all(slip[i + 1 :] >= middle):
            window = (float(t[i]), float(t[i + 1]))
            time = 0.5 * (window[0] + window[1])
            level = float(np.interp(time, t, force))
            return ObservedFailure(int(i), window, time, level if math.isfinite(level) else 0.0)
    return None
