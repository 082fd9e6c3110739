"""Parsed intervals to :class:`granflow.Run`: torque -> force, angle -> slip, speed -> velocity."""

import numpy as np

from granflow.io import _columns
from granflow.io._text import fail
from granflow.model.run import Run

__all__ = ["control_mode", "interval_to_run", "runs_from_file"]

_RATE = ("speed", "shear_rate", "angle", "strain")
_STRESS = ("torque", "shear_stress")


def _spread(values):
    """Relative spread of finite values (std / |mean|); inf when there are fewer than two."""
    finite = values[np.isfinite(values)]
    if finite.size < 2:
        return np.inf
    scale = np.abs(finite).mean()
    return float(finite.std() / scale) if scale > 0 else 0.0


def control_mode(interval):
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
    rate = next((q for q in ("speed", "shear_rate") if interval.find(q) is not None), None)
    stress = next((q for q in _STRESS if interval.find(q) is not None), None)
    if rate is None or stress is None:
        return "rate"
    return "stress" if _spread(interval.si(stress)) < _spread(interval.si(rate)) else "rate"


def interval_to_run(interval, geometry, source, ordinal):
    """One Run from one interval, with the geometry's radii (NaN where a column is absent)."""
    time = interval.si("interval_time")
    if time is None:
        time = interval.si("time")
    if time is None:
        names = ", ".join(column.name for column in interval.columns)
        raise fail(source, interval.line, f"interval {ordinal} has no time column (found: {names})")
    nothing = np.full(time.shape, np.nan)
    angle = interval.si("angle")
    if angle is None:
        slip = nothing
    else:
        finite = np.flatnonzero(np.isfinite(angle))
        start = angle[finite[0]] if finite.size else 0.0
        slip = (angle - start) * geometry.mean_radius
    speed = interval.si("speed")
    velocity = nothing if speed is None else speed * (2.0 * np.pi * geometry.mean_radius)
    torque = interval.si("torque")
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
    return Run(
        t=time,
        slip=slip,
        velocity=velocity,
        force=force,
        control=control_mode(interval),
        meta=meta,
    )


def runs_from_file(parsed, geometry):
    """A list of Run, one per interval of a parsed file, in file order."""
    return [
        interval_to_run(interval, geometry, parsed.source, ordinal)
        for ordinal, interval in enumerate(parsed.intervals, start=1)
    ]
