"""Slide-hold-slide records: slide, stop the load point for a hold, slide again.

The classic friction-healing experiment: the peak friction on re-sliding grows with the log
of the hold time. A record is a table in the format of the velocity-step records
(:func:`granflow.io.velocity_steps.parse_friction_table`: time, load-point displacement,
friction, units in the header); :func:`parse_slide_hold_slide` converts it to SI and finds
the holds in the load-point displacement (:func:`find_holds`: flat stretches, where the load
point moves slower than a fraction of the sliding velocity), or takes them as
``step_times=`` (each hold's start and end). The load-point history becomes a
:class:`~granflow.Protocol` of :class:`~granflow.Velocity` and :class:`~granflow.Hold`
segments, and each hold a fit window (``windows``) that :func:`granflow.rsf.fit` uses.

Examples
--------
>>> rows = [(t, t if t < 40 else (40 if t < 60 else t - 20)) for t in range(100)]
>>> text = "Time(s)\\tDispl(microns)\\tFriction\\n" + "".join(
...     f"{t}\\t{x}\\t0.6\\n" for t, x in rows)
>>> record = parse_slide_hold_slide(text)
>>> [round(h, 3) for h in record.hold_times], [round(s, 3) for s in record.hold_starts]
([20.0], [40.0])
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from granflow.errors import FileFormatError, InvalidDataError, InvalidParameterError
from granflow.io.velocity_steps import parse_friction_table
from granflow.model.protocol import Protocol
from granflow.model.segments import Hold, Velocity

__all__ = [
    "SlideHoldSlideRecord",
    "find_holds",
    "parse_slide_hold_slide",
    "read_slide_hold_slide",
]

#: A window starts this share of the slide before its hold (the rest is its steady sliding).
STEADY_SHARE = 0.25


@dataclass(frozen=True, eq=False)
class SlideHoldSlideRecord:
    """A slide-hold-slide record in SI units, with its holds and fit windows.

    Attributes
    ----------
    t : numpy.ndarray
        Time since the first row [s].
    friction : numpy.ndarray
        Friction coefficient [-].
    load_point : numpy.ndarray
        Load-point displacement since the first row [m] (also as ``displacement``).
    normal_stress : numpy.ndarray or None
        Normal stress [Pa] where the file has it.
    protocol : Protocol
        The load-point history from t = 0: :class:`~granflow.Velocity` for each slide,
        :class:`~granflow.Hold` for each hold.
    hold_starts, hold_ends : tuple of float
        When each hold begins and ends [s].
    velocities : tuple of float
        The load-point velocity of each slide [m/s] (one more than the holds, or as many
        where the record starts or ends in a hold).
    windows : tuple of (float, float)
        One fit window per hold [s]: from the last quarter of the slide before the hold
        (steady sliding) to where the next window starts (or the record's end), so that the
        windows cover the whole re-slide and no point twice.
    time_offset : float
        The file's first time [s].
    meta : dict
        ``source``, the columns read, ``problems``.
    """

    t: np.ndarray
    friction: np.ndarray
    load_point: np.ndarray
    normal_stress: np.ndarray | None
    protocol: Any
    hold_starts: tuple
    hold_ends: tuple
    velocities: tuple
    windows: tuple
    time_offset: float = 0.0
    meta: dict = field(default_factory=dict)

    @property
    def hold_times(self) -> tuple:
        """The duration of each hold [s]."""
        return tuple(e - s for s, e in zip(self.hold_starts, self.hold_ends, strict=True))

    @property
    def displacement(self) -> np.ndarray:
        """The load-point displacement [m] (the name velocity-step records use)."""
        return self.load_point

    def __repr__(self) -> str:
        holds = ", ".join(f"{h:.3g}" for h in self.hold_times)
        return f"SlideHoldSlideRecord({self.t.size} points, holds {holds} s)"


def _local_slopes(t, x, half):
    """The slope of the least-squares line through each point and its ``half`` neighbours
    on either side [m/s] (fewer at the ends)."""
    n = t.size
    tc = t - t[0]
    sums = np.zeros((5, n + 1))
    sums[:, 1:] = np.cumsum(np.vstack([np.ones(n), tc, x, tc * tc, tc * x]), axis=1)
    index = np.arange(n)
    lo = np.maximum(index - half, 0)
    hi = np.minimum(index + half + 1, n)
    count, st, sx, stt, stx = sums[:, hi] - sums[:, lo]
    ctt = stt - st * st / count
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ctt > 0, (stx - st * sx / count) / ctt, 0.0)


def _line(t, x):
    if t.size < 2:
        raise InvalidDataError("a slide needs at least two points")
    slope, intercept = np.polyfit(t, x, 1)
    return float(slope), float(intercept)


def _noise(t, x):
    """The displacement's point-to-point noise [m]: each point against the chord of its
    neighbours (1.4826 × the median absolute deviation, over √1.5)."""
    w = (t[1:-1] - t[:-2]) / (t[2:] - t[:-2])
    chord = x[1:-1] - ((1 - w) * x[:-2] + w * x[2:])
    return float(1.4826 * np.median(np.abs(chord - np.median(chord))) / np.sqrt(1.5))


def _sliding_velocity(slopes):
    top = np.percentile(slopes, 95)
    if not top > 0:
        raise InvalidDataError("the load point never slides: no slide to hold from")
    return float(np.median(slopes[slopes > 0.5 * top]))


def _half_window(t, x, fraction):
    """Neighbours on either side in each point's velocity: the fewest whose slope noise
    (σ √(12 / (m (m² − 1))) / Δt over m points) stays below a quarter of ``fraction`` × the
    sliding velocity (found with a window of a hundredth of the record)."""
    sliding = _sliding_velocity(_local_slopes(t, x, max(1, t.size // 200)))
    step = float(np.median(np.diff(t)))
    target = 0.25 * fraction * sliding * step / max(_noise(t, x), 1e-300)
    m = 3
    while m < t.size // 4 and np.sqrt(12.0 / (m * (m * m - 1.0))) > target:
        m += 2
    return (m - 1) // 2


def find_holds(t, load_point, *, fraction=0.05):
    """The holds of a load-point displacement record: its flat stretches.

    Each point's velocity is the slope of the least-squares line through it and its
    neighbours, as many as the displacement's noise needs (:func:`_half_window`: one on either
    side for a clean record); the sliding velocity is the median of those above half the 95th
    percentile; a hold is a run of at least two points slower than ``fraction`` times it. Each
    hold's start and end are where the lines of the slides before and after it cross the
    hold's level (the median displacement within it), so they do not depend on the sampling.

    Parameters
    ----------
    t : array_like
        Time [s], increasing.
    load_point : array_like
        Load-point displacement [m].
    fraction : float
        A point is at rest where it moves slower than this share of the sliding velocity
        (a velocity step down by more than 1 / ``fraction`` would read as a hold).

    Returns
    -------
    list of (float, float)
        The start and end [s] of each hold, in order.
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(load_point, dtype=float)
    if not 0 < fraction < 1:
        raise InvalidParameterError(f"fraction must lie between 0 and 1, got {fraction!r}")
    half = _half_window(t, x, fraction)
    slopes = _local_slopes(t, x, half)
    rest = np.abs(slopes) < fraction * _sliding_velocity(slopes)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], rest.astype(int), [0]])))
    runs = [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    runs = [(a, b) for a, b in runs if b - a >= 2]
    holds = []
    for number, (a, b) in enumerate(runs):
        level = float(np.median(x[a:b]))
        start, end = float(t[a]), float(t[b - 1])
        before = runs[number - 1][1] + half if number else 0
        if a - half - before >= 3:
            slope, intercept = _line(t[before : a - half - 1], x[before : a - half - 1])
            start = (level - intercept) / slope if slope > 0 else start
        after = runs[number + 1][0] - half if number + 1 < len(runs) else t.size
        if after - b - half >= 3:
            slope, intercept = _line(t[b + half + 1 : after], x[b + half + 1 : after])
            end = (level - intercept) / slope if slope > 0 else end
        start = min(max(start, float(t[max(a - half - 1, 0)])), float(t[a]))
        end = max(min(end, float(t[min(b + half, t.size - 1)])), float(t[b - 1]))
        holds.append((start, end))
    return holds


def _holds_given(step_times, t):
    times = [float(s) for s in step_times]
    if len(times) % 2 or not times:
        raise InvalidParameterError(
            f"step_times must give each hold's start and end (an even count), got {len(times)}"
        )
    if any(not np.isfinite(s) for s in times) or any(b <= a for a, b in itertools.pairwise(times)):
        raise InvalidParameterError(
            f"step_times must be finite and strictly increasing [s], got {times}"
        )
    if times[0] < 0 or times[-1] > t[-1]:
        raise InvalidParameterError(f"step_times must lie inside the record, 0 .. {t[-1]:g} s")
    return list(zip(times[::2], times[1::2], strict=True))


def _protocol(pieces):
    """The Protocol of (velocity, duration) pieces (0: a hold)."""
    return Protocol([Hold(d) if v == 0 else Velocity(v, d) for v, d in pieces])


def _slides(t, x, holds, source):
    """(velocity, duration) of each piece and the velocity of each slide."""
    edges = [0.0]
    for start, end in holds:
        edges += [start, end]
    edges.append(float(t[-1]))
    pieces, velocities = [], []
    for number, (lo, hi) in enumerate(itertools.pairwise(edges)):
        if hi <= lo:
            continue
        if number % 2:
            pieces.append((0.0, hi - lo))
            continue
        inside = (t >= lo) & (t <= hi)
        if inside.sum() < 2:
            raise FileFormatError(
                f"{source}: the slide from {lo:g} to {hi:g} s holds fewer than two rows"
            )
        velocity = _line(t[inside], x[inside])[0]
        if not velocity > 0:
            raise FileFormatError(
                f"{source}: the load point does not advance in the slide from {lo:g} to "
                f"{hi:g} s (velocity {velocity:.3g} m/s)"
            )
        pieces.append((velocity, hi - lo))
        velocities.append(velocity)
    return pieces, velocities


def _windows(holds, end):
    """One window per hold, from the last ``STEADY_SHARE`` of the slide before it to the
    next window's start (the last to ``end``)."""
    starts = []
    previous = 0.0
    for start, stop in holds:
        starts.append(start - STEADY_SHARE * (start - previous))
        previous = stop
    return tuple((s, starts[i + 1] if i + 1 < len(starts) else end) for i, s in enumerate(starts))


def parse_slide_hold_slide(
    text: str,
    source: str = "<text>",
    *,
    step_times: Sequence[float] | None = None,
    fraction: float = 0.05,
) -> SlideHoldSlideRecord:
    """Parse a slide-hold-slide table (decoded text) into a :class:`SlideHoldSlideRecord`.

    Parameters
    ----------
    text : str
        One header line of column names with units (``Time(s)``, ``Displ(microns)``,
        ``Friction``), then tab-, comma- or space-separated rows.
    source : str
        The file name, for error messages.
    step_times : sequence of float, optional
        Each hold's start and end [s, from the first row], in order (``[start1, end1,
        start2, end2, ...]``); default: found in the load-point displacement
        (:func:`find_holds`).
    fraction : float
        Automatic detection: a point is at rest where the load point moves slower than this
        share of the sliding velocity.

    Raises
    ------
    FileFormatError
        A table the velocity-step reader refuses (naming the line and column), a record
        without a hold, a hold at the record's start, or a slide where the load point does
        not advance.
    InvalidParameterError
        ``step_times`` not pairs of increasing times inside the record.
    """
    table = parse_friction_table(text, source)
    t, x = table.t, table.displacement
    if step_times is None:
        holds = find_holds(t, x, fraction=fraction)
        if not holds:
            raise FileFormatError(
                f"{source}: line {table.last_line}: no hold found: the load point never "
                f"stops for two rows (slower than {fraction:g} of the sliding velocity); "
                "give step_times to name the holds"
            )
    else:
        holds = _holds_given(step_times, t)
    if holds[0][0] <= t[0]:
        raise FileFormatError(
            f"{source}: line 2: the record starts in a hold: no steady sliding before it"
        )
    pieces, velocities = _slides(t, x, holds, source)
    return SlideHoldSlideRecord(
        t=t,
        friction=table.friction,
        load_point=x,
        normal_stress=table.normal_stress,
        protocol=_protocol(pieces),
        hold_starts=tuple(s for s, _ in holds),
        hold_ends=tuple(e for _, e in holds),
        velocities=tuple(velocities),
        windows=_windows(holds, float(t[-1])),
        time_offset=table.time_offset,
        meta={"source": source, "columns": table.columns, "problems": list(table.problems)},
    )


def read_slide_hold_slide(
    path: str | os.PathLike[str],
    *,
    step_times: Sequence[float] | None = None,
    fraction: float = 0.05,
) -> SlideHoldSlideRecord:
    """Read a slide-hold-slide record file; see :func:`parse_slide_hold_slide`.

    Examples
    --------
    >>> from granflow import rsf
    >>> record = rsf.read_slide_hold_slide("shs.txt")  # doctest: +SKIP
    >>> record.hold_times  # doctest: +SKIP
    (1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0)
    """
    from granflow.io import _buffer

    path = Path(path)
    buffer = _buffer.load(path)
    text = buffer.text(0, len(buffer.data))
    return parse_slide_hold_slide(text, str(path), step_times=step_times, fraction=fraction)
