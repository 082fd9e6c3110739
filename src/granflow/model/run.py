"""One measured (or simulated) run: time, slip, velocity and friction force in SI units."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidDataError
from granflow.model.units import si_unit

if TYPE_CHECKING:
    import pandas as pd

    from granflow._typing import ArrayLike

__all__ = ["CONTROL_MODES", "Run"]

CONTROL_MODES = ("rate", "stress")
_COLUMNS = ("t", "slip", "velocity", "force")
_UNITS = {name: si_unit(name) for name in _COLUMNS}


def _column(values, name, length):
    """A read-only float64 copy of one column (NaN allowed: missing values)."""
    try:
        array = np.array(values, dtype=np.float64).ravel()
    except (TypeError, ValueError) as exc:
        raise InvalidDataError(f"Run column {name!r} must be numeric: {exc}") from None
    if length is not None and array.shape[0] != length:
        raise InvalidDataError(
            f"Run column {name!r} has {array.shape[0]} values, but t has {length}"
        )
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class Run:
    """One interval of an experiment, in SI units.

    Parameters
    ----------
    t : array_like
        Time since the start of the interval [s].
    slip : array_like
        Measured slip at the mean contact radius [m], zero at the start of the interval;
        NaN where unknown.
    velocity : array_like
        Sliding velocity [m/s]; NaN where unknown.
    force : array_like
        Friction force [N]; NaN where unknown.
    control : {"rate", "stress"}
        Whether the velocity (rate) or the force (stress) was imposed.
    meta : mapping
        Metadata: ``source`` (file), ``interval``, ``normal_load`` [N], ``velocity`` (nominal,
        [m/s]), ``preparation``, ``rest_time`` [s], ``sample``, and anything else found.
    problems : tuple of str
        Data-quality problems found while reading (a truncated block, non-finite cells, gaps,
        dropped rows, time running backwards), one sentence each; empty when clean.

    Arrays are stored as read-only copies, so a Run never shares memory with the caller.
    """

    t: np.ndarray
    slip: np.ndarray
    velocity: np.ndarray
    force: np.ndarray
    control: str = "rate"
    meta: Mapping[str, Any] = field(default_factory=dict)
    problems: tuple = ()

    def __post_init__(self):
        time = _column(self.t, "t", None)
        object.__setattr__(self, "t", time)
        for name in ("slip", "velocity", "force"):
            object.__setattr__(self, name, _column(getattr(self, name), name, time.shape[0]))
        if self.control not in CONTROL_MODES:
            raise InvalidDataError(f"Run control must be 'rate' or 'stress', got {self.control!r}")
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))
        object.__setattr__(self, "problems", _problems(self.problems))

    def __reduce__(self):
        # MappingProxyType cannot be pickled: rebuild from plain values (for process pools)
        columns = (self.t, self.slip, self.velocity, self.force)
        return (_rebuild, (*columns, self.control, dict(self.meta), self.problems))

    def __len__(self):
        return self.t.shape[0]

    def __repr__(self):
        source = self.meta.get("source", "?")
        interval = self.meta.get("interval", "?")
        return (
            f"Run({len(self)} points, control={self.control!r}, "
            f"source={source!r}, interval={interval!r})"
        )

    @property
    def name(self) -> str:
        """A short label: ``source#interval`` when known."""
        if "name" in self.meta:
            return str(self.meta["name"])
        return f"{self.meta.get('source', 'run')}#{self.meta.get('interval', 0)}"

    @property
    def normal_load(self) -> float | None:
        """Normal load [N] from the metadata, or None."""
        value = self.meta.get("normal_load")
        return None if value is None else float(value)

    @property
    def nominal_velocity(self) -> float | None:
        """Imposed velocity [m/s]: the metadata value, else the median measured velocity."""
        value = self.meta.get("velocity")
        if value is not None:
            return float(value)
        finite = self.velocity[np.isfinite(self.velocity)]
        return float(np.median(finite)) if finite.size else None

    def to_frame(self) -> pd.DataFrame:
        """A tidy pandas DataFrame: columns t, slip, velocity, force (SI), control, and the
        scalar metadata as constant columns; ``frame.attrs['meta']`` keeps the full metadata."""
        import pandas as pd

        frame = pd.DataFrame({name: getattr(self, name) for name in _COLUMNS})
        frame["control"] = self.control
        for key, value in self.meta.items():
            if isinstance(value, str | int | float | bool) or value is None:
                frame[key] = value
        frame.attrs["meta"] = dict(self.meta)
        frame.attrs["units"] = dict(_UNITS)
        frame.attrs["problems"] = list(self.problems)
        return frame

    @classmethod
    def from_frame(cls, frame: pd.DataFrame, meta: Mapping[str, Any] | None = None) -> Run:
        """Build a Run from a frame with columns t, slip, velocity, force (missing -> NaN).

        ``meta`` defaults to ``frame.attrs['meta']``; the ``control`` column (if any) gives the
        control mode; ``frame.attrs['problems']`` (if any) the data-quality problems.
        """
        if "t" not in frame:
            raise InvalidDataError("a Run frame needs a 't' column [s]")
        length = len(frame)
        columns = {
            name: frame[name].to_numpy(dtype=float) if name in frame else np.full(length, np.nan)
            for name in _COLUMNS
        }
        control = str(frame["control"].iloc[0]) if "control" in frame and length else "rate"
        if meta is None:
            meta = dict(frame.attrs.get("meta", {}))
        problems = tuple(frame.attrs.get("problems", ()))
        return cls(control=control, meta=meta, problems=problems, **columns)

    def shifted(self, time: float = 0.0, slip: float = 0.0) -> Run:
        """The same run with its clock moved: ``t - time`` and ``slip - slip``.

        For a record whose first point is not the start of shear (a delay before the motor
        starts, an elastic loading ramp): give the record time [s] at which shearing
        started, and the slip [m] there, so that the new record reads on the one clock
        (t = 0 when shearing starts, as the model's t). granflow never guesses these; the
        shifts are added up in ``meta["time_shift"]`` and ``meta["slip_shift"]``.

        Parameters
        ----------
        time : float or str
            Record time at which shearing started [s] (a number in s or a string with a
            unit, "2.5 s").
        slip : float or str
            Slip at that moment [m].

        Returns
        -------
        Run
        """
        from granflow import _validate as check

        dt = check.real_scalar(time, "time", "s")
        dx = check.real_scalar(slip, "slip", "m")
        meta = dict(self.meta)
        meta["time_shift"] = float(meta.get("time_shift", 0.0)) + dt
        meta["slip_shift"] = float(meta.get("slip_shift", 0.0)) + dx
        return Run(
            t=self.t - dt,
            slip=self.slip - dx,
            velocity=self.velocity,
            force=self.force,
            control=self.control,
            meta=meta,
            problems=self.problems,
        )

    def select(self, mask: ArrayLike) -> Run:
        """A new Run with only the points where ``mask`` is true (same metadata)."""
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != self.t.shape:
            raise InvalidDataError(f"mask has shape {mask.shape}, the run has {self.t.shape}")
        return Run(
            t=self.t[mask],
            slip=self.slip[mask],
            velocity=self.velocity[mask],
            force=self.force[mask],
            control=self.control,
            meta=dict(self.meta),
            problems=self.problems,
        )


def _problems(problems):
    """``problems`` as a tuple of non-empty strings."""
    if isinstance(problems, str):
        problems = (problems,)
    try:
        items = tuple(problems)
    except TypeError:
        raise InvalidDataError(
            f"Run problems must be a sequence of strings, got {type(problems).__name__}"
        ) from None
    for item in items:
        if not isinstance(item, str) or not item.strip():
            raise InvalidDataError(f"Run problems must be non-empty strings, got {item!r}")
    return items


def _rebuild(t, slip, velocity, force, control, meta, problems):
    return Run(
        t=t,
        slip=slip,
        velocity=velocity,
        force=force,
        control=control,
        meta=meta,
        problems=problems,
    )
