"""Velocity-step records of rock-friction labs: time, load-point displacement, friction.

A record is a delimited table with one header line whose cells carry their unit in
parentheses or brackets (``Time(s)``, ``Displ(microns)``, ``Friction``,
``Effective_Normal_stress(MPa)``); :func:`parse_velocity_steps` converts it to SI, shifts the
time to start at 0 (the file's own start is kept as ``time_offset``) and recovers the
load-point velocity history from the displacement (:func:`segment_velocity`): the record is
cut into straight pieces of displacement against time, the step times found automatically by
binary segmentation (or given as ``step_times=``), and each piece's slope is a
:class:`~granflow.Velocity` segment of the returned :class:`~granflow.Protocol`.

Examples
--------
>>> text = "Time(s)\\tDispl(microns)\\tFriction\\n" + "\\n".join(
...     f"{100 + t}\\t{t if t < 50 else 50 + 10 * (t - 50)}\\t0.6" for t in range(100))
>>> record = parse_velocity_steps(text)
>>> [round(v * 1e6, 6) for v in record.velocities], [round(t, 3) for t in record.step_times]
([1.0, 10.0], [50.0])
"""

from __future__ import annotations

import itertools
import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from granflow.errors import FileFormatError, InvalidDataError
from granflow.model.protocol import Protocol
from granflow.model.segments import Velocity

__all__ = [
    "FrictionTable",
    "VelocityStepRecord",
    "is_velocity_step_file",
    "parse_friction_table",
    "parse_velocity_steps",
    "read_velocity_steps",
    "segment_velocity",
]

_NAME_UNIT = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")
#: Column roles by lower-case name (spaces and underscores removed).
_ROLES = {
    "time": ("time", "t", "times"),
    "displacement": ("displ", "displacement", "lpdisp", "loadpointdisplacement", "disp", "slip"),
    "friction": ("friction", "mu", "frictioncoefficient", "frictioncoeff"),
    "normal_stress": ("normalstress", "effectivenormalstress", "sigman", "effnormalstress"),
}
#: Unit -> factor to SI, per role.
_UNITS = {
    "time": {"s": 1.0, "sec": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0},
    "displacement": {
        "m": 1.0,
        "mm": 1e-3,
        "um": 1e-6,
        "µm": 1e-6,
        "μm": 1e-6,
        "micron": 1e-6,
        "microns": 1e-6,
        "nm": 1e-9,
    },
    "friction": {"": 1.0, "-": 1.0},
    "normal_stress": {"pa": 1.0, "kpa": 1e3, "mpa": 1e6, "gpa": 1e9, "bar": 1e5},
}


@dataclass(frozen=True, eq=False)
class VelocityStepRecord:
    """A velocity-step record in SI units, with its load-point velocity history.

    Attributes
    ----------
    t : numpy.ndarray
        Time since the first row [s].
    displacement : numpy.ndarray
        Load-point displacement since the first row [m].
    friction : numpy.ndarray
        Friction coefficient [-].
    normal_stress : numpy.ndarray or None
        Normal stress [Pa] where the file has it.
    protocol : Protocol
        The load-point velocity history, one :class:`~granflow.Velocity` per piece, from t = 0.
    step_times : tuple of float
        The times of the velocity changes [s] (record time, from 0).
    velocities : tuple of float
        The load-point velocity of each piece [m/s].
    time_offset : float
        The file's first time [s] (its time = ``t + time_offset``).
    meta : dict
        ``source`` and the columns read, with their units.
    """

    t: np.ndarray
    displacement: np.ndarray
    friction: np.ndarray
    normal_stress: np.ndarray | None
    protocol: Protocol
    step_times: tuple
    velocities: tuple
    time_offset: float
    meta: dict = field(default_factory=dict)

    def __repr__(self):
        speeds = " -> ".join(f"{v * 1e6:.3g}" for v in self.velocities)
        return f"VelocityStepRecord({self.t.size} points, {speeds} µm/s)"


def _role(name):
    key = re.sub(r"[\s_\-.]", "", name.lower())
    for role, names in _ROLES.items():
        if key in names:
            return role
    return None


def _first_line(path):
    """The first line of a file in its own encoding (BOMs, UTF-16 by its NULs, UTF-8, else
    cp1252), read from its first 64 KiB."""
    from granflow.io._buffer import encoding_of

    with open(path, "rb") as handle:
        head = handle.read(1 << 16)
    encoding = encoding_of(head) or "utf-8"
    if encoding.startswith("utf-16"):
        head = head[: len(head) - len(head) % 2]
    text = head.decode(encoding, errors="replace").lstrip("\ufeff")
    return text.splitlines()[0] if text.strip() else ""


def is_velocity_step_file(path):
    """Whether ``path`` is a velocity-step table: a first line naming time, displacement and
    friction columns (``Time(s)``, ``Displ(microns)``, ``Friction``), in any encoding the
    readers know."""
    try:
        header = _first_line(path)
    except OSError:
        return False
    delimiter = "\t" if "\t" in header else ("," if "," in header else None)
    roles = set()
    for cell in header.strip().split(delimiter):
        match = _NAME_UNIT.match(cell.strip())
        roles.add(_role(match["name"] if match else cell.strip()))
    return {"time", "displacement", "friction"} <= roles


def parse_velocity_steps(
    text: str,
    source: str = "<text>",
    *,
    step_times: Sequence[float] | None = None,
    min_change: float = 0.2,
) -> VelocityStepRecord:
    """Parse a velocity-step table (decoded text) into a :class:`VelocityStepRecord`.

    Parameters
    ----------
    text : str
        One header line of column names with units, then tab-, comma- or space-separated rows.
    source : str
        The file name, for error messages.
    step_times : sequence of float, optional
        The times of the velocity steps [s, from the first row]; default: found
        automatically (:func:`segment_velocity`).
    min_change : float
        Smallest relative velocity change taken for a step (automatic detection).

    Raises
    ------
    FileFormatError
        No header, no time, displacement or friction column, an unknown unit, or a cell that
        is not a number (naming the line and column).
    """
    table = parse_friction_table(text, source)
    t, displacement, last = table.t, table.displacement, table.last_line
    try:
        breaks, velocities = segment_velocity(
            t, displacement, step_times=step_times, min_change=min_change
        )
    except InvalidDataError as exc:
        if step_times is not None:  # the caller's step times, not the file
            raise
        # too few rows for two pieces: the record ends too soon
        raise FileFormatError(f"{source}: line {last}: {exc}") from None
    edges = [0.0, *breaks, float(t[-1])]
    protocol = Protocol(
        [
            Velocity(v, end - start)
            for v, start, end in zip(velocities, edges, edges[1:], strict=False)
        ]
    )
    return VelocityStepRecord(
        t=t,
        displacement=displacement,
        friction=table.friction,
        normal_stress=table.normal_stress,
        protocol=protocol,
        step_times=tuple(breaks),
        velocities=tuple(velocities),
        time_offset=table.time_offset,
        meta={"source": source, "columns": table.columns, "problems": list(table.problems)},
    )


@dataclass(frozen=True, eq=False)
class FrictionTable:
    """The columns of a friction table in SI units (what :func:`parse_friction_table` reads).

    Attributes
    ----------
    t : numpy.ndarray
        Time since the first row [s].
    displacement : numpy.ndarray
        Load-point displacement since the first row [m].
    friction : numpy.ndarray
        Friction coefficient [-].
    normal_stress : numpy.ndarray or None
        Normal stress [Pa] where the file has it.
    time_offset : float
        The file's first time [s].
    columns : dict
        The header cell read for each role.
    problems : tuple of str
        What was left out, one sentence each (a last line cut short).
    last_line : int
        The number of the file's last line read (for error messages).
    """

    t: np.ndarray
    displacement: np.ndarray
    friction: np.ndarray
    normal_stress: np.ndarray | None
    time_offset: float
    columns: dict
    problems: tuple
    last_line: int


def parse_friction_table(text: str, source: str = "<text>") -> FrictionTable:
    """Read the columns of a friction table (decoded text): time, load-point displacement,
    friction and optionally normal stress, in SI, time and displacement from 0.

    The table format of :func:`parse_velocity_steps` (and of the slide-hold-slide reader,
    :func:`granflow.io.slide_hold_slide.parse_slide_hold_slide`).

    Raises
    ------
    FileFormatError
        No header, no time, displacement or friction column, an unknown unit, fewer than 10
        rows, a cell that is not a number or not finite, or a time that does not increase
        (naming the line and column).
    """
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise FileFormatError(f"{source}: line 1: expected a header of column names, got nothing")
    problems = []
    if not text.endswith(("\n", "\r")) and len(lines) > 1:
        problems.append(
            f"line {len(lines)}, the last of the file, has no line end: the file looks cut "
            "short there, so that row was left out (its last number may be incomplete)"
        )
        lines = lines[:-1]
    delimiter = "\t" if "\t" in lines[0] else ("," if "," in lines[0] else None)
    header = [cell.strip() for cell in lines[0].split(delimiter)]
    columns, units, found = _header_columns(header, source)
    rows = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split(delimiter)
        while cells and not cells[-1].strip():
            cells.pop()
        if len(cells) > len(header):
            raise FileFormatError(
                f"{source}: line {number}: {len(cells)} cells where the header has "
                f"{len(header)} columns"
            )
        try:
            rows.append([float(cells[columns[role]]) for role in columns])
        except IndexError:
            raise FileFormatError(
                f"{source}: line {number}: {len(cells)} cells where the header has "
                f"{len(header)} columns"
            ) from None
        except ValueError:
            role = next(role for role in columns if not _is_number(cells[columns[role]]))
            raise FileFormatError(
                f"{source}: line {number}: column {columns[role] + 1} ({found[role]!r}) holds "
                "a cell that is not a number"
            ) from None
    last = len(lines)  # the file's last line read
    if len(rows) < 10:
        raise FileFormatError(
            f"{source}: line {last}: needs at least 10 rows of data, got {len(rows)}"
        )
    data = np.array(rows) * np.array([units[role] for role in columns])
    values = dict(zip(columns, data.T, strict=True))
    t = values["time"]
    bad = np.flatnonzero(~np.isfinite(data).all(axis=1))
    if bad.size:
        raise FileFormatError(f"{source}: line {bad[0] + 2}: a value is not finite")
    if np.any(np.diff(t) <= 0):
        index = int(np.argmax(np.diff(t) <= 0))
        raise FileFormatError(f"{source}: line {index + 3}: time does not increase")
    offset = float(t[0])
    return FrictionTable(
        t=t - offset,
        displacement=values["displacement"] - values["displacement"][0],
        friction=values["friction"],
        normal_stress=values.get("normal_stress"),
        time_offset=offset,
        columns=found,
        problems=tuple(problems),
        last_line=last,
    )


def _is_number(cell):
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _header_columns(header, source):
    """({role: column index}, {role: factor to SI}, {role: header cell}) of a header line;
    an unknown unit or a missing column is an error that names what granflow recognised and
    nothing else of the file."""
    columns, units, found = {}, {}, {}
    for index, cell in enumerate(header):
        match = _NAME_UNIT.match(cell)
        name, unit = (match["name"], match["unit"].strip()) if match else (cell, "")
        role = _role(name)
        if role is None or role in columns:
            continue
        factors = _UNITS[role]
        factor = factors.get(unit.lower(), factors.get(unit))
        if factor is None:
            raise FileFormatError(
                f"{source}: line 1: column {index + 1} ({name.strip()!r}): its unit is not one "
                f"granflow knows for {role} (known: {', '.join(repr(u) for u in factors)})"
            )
        columns[role], units[role], found[role] = index, factor, cell
    for role in ("time", "displacement", "friction"):
        if role not in columns:
            recognised = ", ".join(repr(cell) for cell in found.values()) or "none recognised"
            raise FileFormatError(
                f"{source}: line 1: no {role} column among its {len(header)} columns "
                f"({recognised}); expected e.g. 'Time(s)', 'Displ(microns)', 'Friction'"
            )
    return columns, units, found


def read_velocity_steps(
    path: str | os.PathLike[str],
    *,
    step_times: Sequence[float] | None = None,
    min_change: float = 0.2,
) -> VelocityStepRecord:
    """Read a velocity-step record file; see :func:`parse_velocity_steps`."""
    from granflow.io import _buffer

    path = Path(path)
    buffer = _buffer.load(path)
    text = buffer.text(0, len(buffer.data))
    return parse_velocity_steps(text, str(path), step_times=step_times, min_change=min_change)


def _line_sse(S, lo, hi):
    """Residual sum of squares of the least-squares line over points lo..hi-1 (cumulative
    sums S of 1, t, y, t^2, t y, y^2)."""
    n, st, sy, stt, sty, syy = S[:, hi] - S[:, lo]
    ctt = stt - st * st / n
    cty = sty - st * sy / n
    cyy = syy - sy * sy / n
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ctt > 0, cyy - cty * cty / ctt, cyy)


def _line(t, y):
    slope, intercept = np.polyfit(t, y, 1)
    return float(slope), float(intercept)


def _merge(t, x, indices, min_change):
    """The breaks left once neighbours whose whole-piece velocities differ by less than
    ``min_change`` are joined (a ramp of the actuator into a step is no step of its own)."""
    while indices:
        edges = [0, *indices, t.size]
        speeds = [_line(t[a:b], x[a:b])[0] for a, b in itertools.pairwise(edges)]
        changes = [
            abs(v2 - v1) / max(abs(v1), abs(v2), 1e-300) for v1, v2 in itertools.pairwise(speeds)
        ]
        smallest = int(np.argmin(changes))
        if changes[smallest] > min_change:
            break
        del indices[smallest]
    return indices


def segment_velocity(t, displacement, *, step_times=None, min_change=0.2, min_points=20):
    """Piecewise-linear segmentation of a load-point displacement record.

    Parameters
    ----------
    t : array_like
        Time [s], increasing.
    displacement : array_like
        Load-point displacement [m].
    step_times : sequence of float, optional
        The step times [s]; default: found by binary segmentation: the piece is split where
        two straight lines fit best, as long as the split lowers the residual sum of squares
        by more than ``25 ln(n)`` times the displacement's point-to-point variance and the
        two slopes differ by more than ``min_change`` relative to the larger.
    min_change : float
        Smallest relative velocity change taken for a step.
    min_points : int
        Fewest points in a piece.

    Returns
    -------
    (list of float, list of float)
        The step times [s] (where neighbouring lines cross, clipped to the pieces) and the
        velocity of each piece [m/s] (one more than the steps).
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(displacement, dtype=float)
    if t.shape != x.shape or t.size < 2 * min_points:
        raise InvalidDataError(
            f"segmentation needs t and displacement of one length >= {2 * min_points}"
        )
    if step_times is None:
        # point-to-point noise: each point against the chord of its neighbours
        w = (t[1:-1] - t[:-2]) / (t[2:] - t[:-2])
        chord = x[1:-1] - ((1 - w) * x[:-2] + w * x[2:])
        sigma2 = (1.4826 * np.median(np.abs(chord - np.median(chord)))) ** 2 / 1.5
        tc = t - t[0]
        S = np.zeros((6, t.size + 1))
        S[:, 1:] = np.cumsum(np.vstack([np.ones_like(tc), tc, x, tc * tc, tc * x, x * x]), axis=1)
        indices = []
        stack = [(0, t.size)]
        while stack:
            lo, hi = stack.pop()
            if hi - lo < 2 * min_points:
                continue
            k = np.arange(lo + min_points, hi - min_points + 1)
            split = _line_sse(S, np.full_like(k, lo), k) + _line_sse(S, k, np.full_like(k, hi))
            best = int(k[np.argmin(split)])
            gain = float(_line_sse(S, lo, hi) - split.min())
            v1 = _line(t[lo:best], x[lo:best])[0]
            v2 = _line(t[best:hi], x[best:hi])[0]
            change = abs(v2 - v1) / max(abs(v1), abs(v2), 1e-300)
            if gain > 25 * math.log(hi - lo) * max(sigma2, 1e-300) and change > min_change:
                indices.append(best)
                stack += [(lo, best), (best, hi)]
        indices = _merge(t, x, sorted(indices), min_change)
    else:
        times = sorted(float(s) for s in step_times)
        if any(not (t[0] < s < t[-1]) for s in times):
            raise InvalidDataError(f"step_times must lie inside the record, 0 .. {t[-1]:g} s")
        indices = [int(np.searchsorted(t, s)) for s in times]
    edges = [0, *indices, t.size]
    lines = [_line(t[a:b], x[a:b]) for a, b in itertools.pairwise(edges)]
    velocities = [slope for slope, _ in lines]
    if step_times is not None:
        return [float(s) for s in sorted(step_times)], velocities
    breaks = []
    for (s1, c1), (s2, c2), index in zip(lines, lines[1:], indices, strict=False):
        crossing = (c1 - c2) / (s2 - s1) if s2 != s1 else t[index]
        breaks.append(float(min(max(crossing, t[index - 1]), t[index])))
    return breaks, velocities
