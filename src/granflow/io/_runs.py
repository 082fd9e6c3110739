"""Parsed intervals to :class:`granflow.Run`: torque -> force, angle -> slip, speed -> velocity."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from granflow.io import _columns
from granflow.io._text import fail
from granflow.model.run import Run

if TYPE_CHECKING:
    from granflow.io._file import Interval

__all__ = ["control_mode", "interval_to_run", "runs_from_file"]

_RATE = ("speed", "shear_rate", "angle", "strain")
_STRESS = ("torque", "shear_stress")
#: Columns a Run is made of: their problems (and the block's) travel with the run.
_USED = (
    "interval_time",
    "time",
    "torque",
    "angle",
    "speed",
    "normal_force",
    "slip",
    "force",
    "velocity",
)


def _spread(values):
    """Relative spread of finite values (std / |mean|); inf when there are fewer than two."""
    finite = values[np.isfinite(values)]
    if finite.size < 2:
        return np.inf
    scale = np.abs(finite).mean()
    return float(finite.std() / scale) if scale > 0 else 0.0


def control_mode(interval: Interval) -> str:
    """ "rate" or "stress" for one interval.

    From the metadata when it says (a "Control Mode" entry or a measuring profile that names
    the imposed quantity), otherwise from which quantity the interval holds constant: the
    speed (rate control) or the torque (stress control), compared by relative spread.
    """
    for key in ("control", "profile"):
        value = interval.metadata.get(key)
        if isinstance(value, str):
            mode = _columns.control_from_text(value)
            if mode is not None:
                return mode
    written = interval.find("control")  # granflow's own tables: the mode of each row
    if written is not None:
        modes = {str(cell).strip().lower() for cell in interval.text[written]}
        if "stress" in modes:
            return "stress"
        if "rate" in modes:
            return "rate"
    rate = next((q for q in ("speed", "shear_rate") if interval.find(q) is not None), None)
    stress = next((q for q in _STRESS if interval.find(q) is not None), None)
    if rate is None or stress is None:
        return "rate"
    return "stress" if _spread(interval.si(stress)) < _spread(interval.si(rate)) else "rate"


def run_problems(interval, source, ordinal, file_problems=()):
    """The data-quality sentences of one interval's run, each naming the file and the
    interval: the file's decoding problems and the interval's problems about the columns a
    Run is made of (time, torque, angle, speed, normal force) or about the whole block."""
    name = Path(str(source)).name
    sentences = [f"{name}: {problem}" for problem in file_problems]
    for problem, quantity in zip(interval.problems, interval.problem_quantities, strict=True):
        if quantity is None or quantity in _USED:
            sentences.append(f"{name}, interval {ordinal}: {problem}")
    return tuple(sentences)


def _found(columns):
    """ "found 3 columns: 'Torque', 'Status' and 1 not recognised": the labels granflow knows,
    and how many others (their text is not copied into a message)."""
    known = [repr(column.name) for column in columns if _columns.known_label(column.name)]
    others = len(columns) - len(known)
    parts = [", ".join(known)] if known else []
    if others:
        parts.append(f"{others} not recognised" if known else "none of them recognised")
    noun = "column" if len(columns) == 1 else "columns"
    return f"found {len(columns)} {noun}: {' and '.join(parts)}"


def interval_to_run(interval, geometry, source, ordinal, file_problems=()):
    """One Run from one interval, with the geometry's radii (NaN where a column is absent);
    rows without a time are dropped, and every problem is in ``Run.problems``."""
    time = interval.si("interval_time")
    if time is None:
        time = interval.si("time")
    if time is None:
        raise fail(
            source,
            interval.line,
            f"interval {ordinal} has no time column ({_found(interval.columns)}); expected a "
            "column named like 'Time' or 'Interval Time' in a known language, or one with a "
            "unit of time under a row of [units]",
        )
    nothing = np.full(time.shape, np.nan)
    angle = interval.si("angle")
    slip = interval.si("slip")  # a column mapped as slip [m] wins over the angle
    if slip is None and angle is None:
        slip = nothing
    elif slip is None:
        finite = np.flatnonzero(np.isfinite(angle))
        start = angle[finite[0]] if finite.size else 0.0
        slip = (angle - start) * geometry.mean_radius
    speed = interval.si("speed")
    velocity = interval.si("velocity")  # a sliding velocity [m/s] wins over the speed
    if velocity is None:
        velocity = nothing if speed is None else speed * (2.0 * np.pi * geometry.mean_radius)
    torque = interval.si("torque")
    force = interval.si("force")  # a column mapped as force [N] wins over the torque
    if force is None:
        force = nothing if torque is None else torque / geometry.effective_radius
    meta = {
        key: value
        for key, value in interval.metadata.items()
        if key != "declared_points" and not isinstance(value, list)
    }
    meta.update(
        source=str(source),
        interval=ordinal,
        test=interval.test,
        interval_in_test=interval.number,
        line=interval.line,
    )
    normal = interval.si("normal_force")
    if normal is not None and np.isfinite(normal).any():
        meta["normal_force_median"] = float(np.nanmedian(normal))
    run = Run(
        t=time,
        slip=slip,
        velocity=velocity,
        force=force,
        control=control_mode(interval),
        meta=meta,
        problems=run_problems(interval, source, ordinal, file_problems),
    )
    timed = np.isfinite(run.t)
    return run if timed.all() else run.select(timed)


def runs_from_file(parsed, geometry):
    """A list of Run, one per interval of a parsed file, in file order."""
    file_problems = [problem for problem in parsed.problems if not problem.startswith("skipped")]
    file_problems = [problem for problem in file_problems if not problem.startswith("ignored")]
    return [
        interval_to_run(interval, geometry, parsed.source, ordinal, file_problems)
        for ordinal, interval in enumerate(parsed.intervals, start=1)
    ]
