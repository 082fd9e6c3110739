"""A friction record for a rate-and-state fit: its data, its windows, its starting values.

:func:`record_data` takes arrays, a :class:`~granflow.Run` or a record object; the fit
windows (:func:`fit_windows`) are the given ones or one per velocity step; the starting
values (:func:`step_estimates`, :func:`hold_estimates`) are read from the data: the friction
just before a step is mu0, the change of steady-state friction over ln(v2 / v1) is a - b,
the extreme right after the step over ln(v2 / v1) is a (the direct effect), the slip over
which the friction relaxes from that extreme to 1/e of the way to its new steady state is Dc,
and the rise towards the extreme gives the stiffness.
"""

import itertools
import math

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidDataError, InvalidParameterError
from granflow.fitting.rsf_forward import History, Window
from granflow.simulation.protocol import Protocol

__all__ = ["fit_record", "fit_windows", "hold_estimates", "record_data", "step_estimates"]


def record_data(t, friction, protocol):
    """(t [s], friction [-], protocol, meta, windows) from arrays, a Run, or a record.

    A record is any object with ``t``, ``friction`` and ``protocol`` (a
    :class:`~granflow.io.VelocityStepRecord`, a slide-hold-slide record); its ``windows``
    [s] (None where it has none) are the fit windows it brings, and its ``meta`` its
    metadata.
    """
    from granflow.model.run import Run

    meta, windows = {}, None
    if all(hasattr(t, name) for name in ("t", "friction", "protocol")):  # a record
        record = t
        if isinstance(friction, Protocol) and protocol is None:
            protocol, friction = friction, None
        if friction is not None:
            raise InvalidParameterError("give a record or (t, friction), not both")
        protocol = record.protocol if protocol is None else protocol
        windows = getattr(record, "windows", None)
        meta = dict(getattr(record, "meta", {}) or {})
        t, friction = record.t, record.friction
    if isinstance(t, Run):
        run = t
        if isinstance(friction, Protocol) and protocol is None:
            protocol, friction = friction, None
        if friction is not None:
            raise InvalidParameterError("give a Run or (t, friction), not both")
        load = run.meta.get("normal_load")
        friction = run.force / load if load else run.force
        meta = {"source": run.meta.get("source")}
        t = run.t
    if protocol is None:
        raise InvalidParameterError("protocol is missing: the load-point velocity history")
    t = check.real_array(t, "t", "s").ravel()
    friction = check.real_array(friction, "friction", "").ravel()
    if t.shape != friction.shape:
        raise InvalidDataError(f"t and friction differ in length: {t.size} and {friction.size}")
    if np.any(np.diff(t) <= 0):
        index = int(np.argmax(np.diff(t) <= 0))
        raise InvalidDataError(f"t must increase strictly, but t[{index + 1}] <= t[{index}]")
    if not isinstance(protocol, Protocol):
        protocol = Protocol(protocol)
    return t, friction, protocol, meta, windows


def fit_windows(t, pieces, windows):
    """(first, stop, start time [s]) of each fit window over the times ``t`` [s] and the
    protocol's ``pieces``: the given ``windows`` [s] (the simulation starts at the window's
    start, steady sliding there), or by default one per step or hold, cut half-way between
    them (a hold counts from its start to the re-slide), each simulated from the record's
    start (steady sliding there: a cut half-way between steps is not, where the slip since
    the last step is a few Dc)."""
    if windows is not None:
        out = []
        for number, (lo, hi) in enumerate(windows, start=1):
            inside = np.flatnonzero((t >= lo) & (t <= hi))
            if inside.size < 10:
                raise InvalidParameterError(
                    f"window {number} ({lo:g} .. {hi:g} s) holds {inside.size} points; "
                    "a fit needs at least 10"
                )
            out.append((int(inside[0]), int(inside[-1]) + 1, max(float(lo), 0.0)))
        return out
    events = _events(pieces)
    cuts = [t[0]] + [0.5 * (e1[1] + e2[0]) for e1, e2 in itertools.pairwise(events)] + [t[-1]]
    out = []
    for lo, hi in itertools.pairwise(cuts):
        inside = np.flatnonzero((t >= lo) & (t <= hi if hi == t[-1] else t < hi))
        out.append((int(inside[0]), int(inside[-1]) + 1, float(t[0])))
    return out


def _events(pieces):
    """(begin, end) [s] of each velocity step (begin = end) and each hold (its start and its
    re-slide) of the protocol's ``pieces``."""
    velocity = pieces[:, 2]
    ends = velocity + pieces[:, 3] * (pieces[:, 1] - pieces[:, 0])
    events, hold_start = [], None
    for i in range(1, len(pieces)):
        if not abs(velocity[i] - ends[i - 1]) > 1e-3 * max(abs(velocity[i]), abs(ends[i - 1])):
            continue
        if velocity[i] == 0:
            hold_start = pieces[i, 0]
        elif ends[i - 1] == 0 and hold_start is not None:
            events.append((hold_start, pieces[i, 0]))
            hold_start = None
        else:
            events.append((pieces[i, 0], pieces[i, 0]))
    return events


def _smooth(y, width):
    if width <= 1:
        return y
    kernel = np.ones(width) / width
    padded = np.concatenate([np.full(width // 2, y[0]), y, np.full(width - 1 - width // 2, y[-1])])
    return np.convolve(padded, kernel, mode="valid")


def step_estimates(window, y):
    """Starting values (mu0, (a, b, Dc [m], k [1/m])) read from the largest velocity step of
    one window (``y``: its friction [-]); the second is None where it holds no step."""
    pieces = window.pieces
    tail = y[-max(5, y.size // 10) :]
    if len(pieces) < 2:
        return float(np.median(y[: max(5, y.size // 10)])), None
    ends = pieces[:, 2] + pieces[:, 3] * (pieces[:, 1] - pieces[:, 0])
    # the steps since the window's own start (one sharing its run starts at its data)
    since = window.local[0] if window.history is not None else 0.0
    ratios = [
        abs(math.log(pieces[i, 2] / ends[i - 1]))
        if pieces[i, 0] >= since and pieces[i, 2] > 0 and ends[i - 1] > 0
        else 0.0
        for i in range(1, len(pieces))
    ]
    if not max(ratios) > 0:
        return float(np.median(y[: max(5, y.size // 10)])), None
    j = 1 + int(np.argmax(ratios))
    s, v1, v2 = pieces[j, 0], ends[j - 1], pieces[j, 2]
    local = window.local
    before = y[local < s]
    after = y[local >= s]
    t_after = local[local >= s] - s
    if after.size < 10 or v1 <= 0 or v2 <= 0:
        return float(np.median(y[: max(5, y.size // 10)])), None
    # a start-up (no data before the step): friction starts from steady sliding at v1
    mu_before = float(np.median(before[-max(3, before.size // 5) :])) if before.size else y[0]
    mu_after = (
        float(np.median(tail))
        if j == len(pieces) - 1
        else float(np.median(after[-max(5, after.size // 10) :]))
    )
    log_ratio = math.log(v2 / v1)
    a_minus_b = (mu_after - mu_before) / log_ratio
    smooth = _smooth(after, max(1, after.size // 100))
    half = smooth[: max(3, smooth.size // 2)]
    sign = 1.0 if log_ratio > 0 else -1.0
    peak_index = int(np.argmax(sign * half))
    peak = float(half[peak_index])
    direct = (peak - mu_before) / log_ratio
    a = max(direct, abs(a_minus_b), 1e-5)
    b = a - a_minus_b
    # evolution distance: from the extreme to 1/e of the way to the new steady state
    span = peak - mu_after
    later = np.flatnonzero(np.abs(smooth[peak_index:] - mu_after) < abs(span) / math.e)
    duration = t_after[-1] - t_after[peak_index]
    if later.size and abs(span) > 0:
        relax = t_after[peak_index + later[0]] - t_after[peak_index]
    else:
        relax = duration / 5
    Dc = v2 * max(relax, duration / 1000, 1e-12)
    # stiffness: friction rises at k (v2 - v1) until the slider catches up
    rise = np.flatnonzero(
        sign * (smooth[: peak_index + 1] - mu_before) > 0.5 * abs(peak - mu_before)
    )
    t_half = t_after[rise[0]] if rise.size and t_after[rise[0]] > 0 else max(t_after[1], 1e-12)
    k = 0.5 * abs(peak - mu_before) / (abs(v2 - v1) * t_half)
    k = max(k, 10 * abs(b - a) / Dc if b > a else 0.0, 1e-12)
    # mu0 is the steady friction at the velocity where the simulation starts
    mu0 = mu_before - a_minus_b * math.log(v1 / window.v_ref) if window.v_ref > 0 else mu_before
    return mu0, (a, b, Dc, k)


def hold_estimates(window, y):
    """Starting values (mu0, (a, b, Dc [m], k [1/m])) read from the longest hold of one
    window (``y``: its friction [-]), where it has no velocity step; the second is None where
    it holds no hold followed by sliding.

    The friction relaxes by about ``a ln(1 + t_h / t_c)`` over a hold of ``t_h``, rises at
    ``k v`` on re-sliding at v and peaks about ``b ln(t_h v / Dc)`` above its steady level,
    which it regains over a slip of about Dc.
    """
    pieces, local = window.pieces, window.local
    since = local[0] if window.history is not None else 0.0
    holds = [
        i
        for i in range(1, len(pieces) - 1)
        if pieces[i, 0] >= since
        and pieces[i, 2] == 0
        and pieces[i, 3] == 0
        and pieces[i + 1, 2] > 0
    ]
    if not holds:
        return None
    i = max(holds, key=lambda j: pieces[j, 1] - pieces[j, 0])
    start, end, v = pieces[i, 0], pieces[i, 1], pieces[i + 1, 2]
    before, after = y[local < start], y[local >= end]
    t_after = local[local >= end] - end
    if before.size < 3 or after.size < 10:
        return None
    mu_before = float(np.median(before[-max(3, before.size // 5) :]))
    mu_after = float(np.median(after[-max(5, after.size // 10) :]))
    smooth = _smooth(after, max(1, after.size // 100))
    half = smooth[: max(3, smooth.size // 2)]
    peak_index = int(np.argmax(half))
    peak, low = float(half[peak_index]), float(smooth[0])
    rise = np.flatnonzero(smooth[: peak_index + 1] - low > 0.5 * (peak - low))
    t_half = t_after[rise[0]] if rise.size and t_after[rise[0]] > 0 else max(t_after[1], 1e-12)
    k = max(0.5 * (peak - low) / (v * t_half), 1e-12)
    span = peak - mu_after
    later = np.flatnonzero(np.abs(smooth[peak_index:] - mu_after) < abs(span) / math.e)
    relax = t_after[peak_index + later[0]] - t_after[peak_index] if later.size else t_after[-1] / 5
    Dc = v * max(relax, t_after[-1] / 1000, 1e-12)
    duration = end - start
    drop = max(mu_before - low, 1e-6)
    a = drop / max(math.log1p(duration * k * v / max(drop, 1e-6)), 1.0)
    b = max(peak - mu_before, 1e-6) / max(math.log(duration * v / Dc), 1.0)
    mu0 = (
        mu_before - (a - b) * math.log(pieces[i - 1, 2] / window.v_ref)
        if window.v_ref > 0
        else mu_before
    )
    return mu0, (a, b, Dc, k)


def fit_record(t, pieces, laws, ranges, shared):
    """The fit windows as :class:`Window` objects; with ``shared``, the windows start their
    simulation at one time and share it (:class:`History`)."""
    record = [Window(t[lo:hi], pieces, laws, start) for lo, hi, start in ranges]
    if any(w.v_ref <= 0 for w in record):
        raise InvalidDataError(
            "a window starts at rest: no steady state to start from (start it in steady "
            "sliding before the hold)"
        )
    if shared and len(record) > 1:
        history = History(record)
        for window in record:
            window.history = history
    return record
