"""The segments of an experiment: imposed velocity, hold, imposed force, ramps, switches.

Each segment is a frozen dataclass validated when it is made; errors name the segment, the
field and its unit. Segments are either rate-controlled (the drive imposes the sliding
velocity) or force-controlled (the drive imposes the shear force and the layer decides
whether it sticks, slides or fails). A segment cuts itself into pieces along which the
imposed quantity changes linearly (:class:`RatePiece`, :class:`ForcePiece`): what a stepper
of :mod:`granflow.simulation.driver` advances through. All quantities are in SI units
(m/s, s, N, N/s).
"""

from dataclasses import dataclass, fields

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidParameterError, InvalidProtocolError

__all__ = [
    "SEGMENT_TYPES",
    "Force",
    "ForcePiece",
    "ForceRamp",
    "ForceSteps",
    "ForceTable",
    "Hold",
    "RatePiece",
    "Segment",
    "SwitchToForce",
    "Velocity",
    "VelocitySteps",
    "VelocityTable",
]


@dataclass(frozen=True, slots=True)
class RatePiece:
    """Imposed velocity going linearly from ``start`` to ``end`` [m/s] over ``duration`` [s]."""

    start: float
    end: float
    duration: float
    hold: bool = False
    reset: bool = False


@dataclass(frozen=True, slots=True)
class ForcePiece:
    """Imposed force going linearly from ``start`` to ``end`` [N] over ``duration`` [s].

    The force jumps to ``start`` when the piece begins.
    """

    start: float
    end: float
    duration: float

    @property
    def rate(self):
        return (self.end - self.start) / self.duration


def _wrap(segment, name, function, *args):
    """Run a _validate check and turn its error into InvalidProtocolError naming the segment."""
    if args[0] is None:
        raise InvalidProtocolError(f"{segment}: {name} is missing")
    try:
        return function(args[0], name, *args[1:])
    except InvalidParameterError as exc:
        raise InvalidProtocolError(f"{segment}: {exc}") from None


def _positive(segment, value, name, unit):
    return _wrap(segment, name, check.positive, value, unit)


def _non_negative(segment, value, name, unit):
    return _wrap(segment, name, check.non_negative, value, unit)


def _real(segment, value, name, unit):
    return _wrap(segment, name, check.real_scalar, value, unit)


def _values(segment, values, name, unit, *, non_negative=True, positive=False):
    """A validated read-only 1-D tuple of finite floats (non-empty)."""
    if values is None:
        raise InvalidProtocolError(f"{segment}: {name} is missing")
    if isinstance(values, str | bytes):
        raise InvalidProtocolError(f"{segment}: {name} must be a list of numbers, got {values!r}")
    try:
        array = check.real_array(values, name, unit)
    except InvalidParameterError as exc:
        raise InvalidProtocolError(f"{segment}: {exc}") from None
    if array.ndim != 1 or array.size == 0:
        raise InvalidProtocolError(f"{segment}: {name} must be a non-empty list of numbers")
    lowest = float(array.min())
    if positive and lowest <= 0:
        raise InvalidProtocolError(f"{segment}: {name} must be positive, got {lowest:g} {unit}")
    if non_negative and lowest < 0:
        raise InvalidProtocolError(f"{segment}: {name} must be non-negative, got {lowest:g} {unit}")
    return tuple(float(v) for v in array)


def _table(segment, time, values, name, unit):
    """Validated (time, values) of a table: times start at 0 and increase strictly."""
    times = _values(segment, time, "time", "s")
    levels = _values(segment, values, name, unit)
    if len(times) != len(levels):
        raise InvalidProtocolError(
            f"{segment}: time and {name} must have the same length, got {len(times)} and "
            f"{len(levels)}"
        )
    if len(times) < 2:
        raise InvalidProtocolError(f"{segment}: a table needs at least two rows")
    if times[0] != 0:
        raise InvalidProtocolError(
            f"{segment}: the first time must be 0 (the start of the segment), got {times[0]:g} s"
        )
    steps = np.diff(times)
    if np.any(steps <= 0):
        index = int(np.argmax(steps <= 0)) + 1
        raise InvalidProtocolError(
            f"{segment}: times must increase, but time[{index}] = {times[index]:g} s follows "
            f"{times[index - 1]:g} s"
        )
    return times, levels


class Segment:
    """Base of every protocol segment (a frozen dataclass with a ``duration`` [s]).

    ``control`` is ``"rate"`` (the velocity is imposed) or ``"force"`` (the force is).
    """

    __slots__ = ()
    control = "rate"
    type_name = ""

    def to_dict(self):
        """JSON- and YAML-safe mapping, ``{"type": ..., field: value, ...}`` in SI units."""
        out = {"type": self.type_name}
        for item in fields(self):
            value = getattr(self, item.name)
            out[item.name] = list(value) if isinstance(value, tuple) else value
        return out


@dataclass(frozen=True, slots=True)
class Velocity(Segment):
    """Imposed constant sliding velocity.

    Parameters
    ----------
    velocity : float
        Sliding velocity [m/s]; positive (use :class:`Hold` for rest).
    duration : float
        Duration [s]; positive.

    Examples
    --------
    >>> from granflow import Velocity
    >>> Velocity(0.86e-6, 80.0).duration
    80.0
    """

    velocity: float | None = None
    duration: float | None = None
    type_name = "velocity"

    def __post_init__(self):
        name = "Velocity"
        object.__setattr__(self, "velocity", _positive(name, self.velocity, "velocity", "m/s"))
        object.__setattr__(self, "duration", _positive(name, self.duration, "duration", "s"))

    def pieces(self) -> list[RatePiece]:
        return [RatePiece(self.velocity, self.velocity, self.duration)]


@dataclass(frozen=True, slots=True)
class VelocitySteps(Segment):
    """A list of constant velocities, each imposed for ``step_duration``.

    Parameters
    ----------
    velocities : sequence of float
        Sliding velocities [m/s]; non-negative (0 is a rest).
    step_duration : float
        Duration of each step [s]; positive.
    """

    velocities: tuple | None = None
    step_duration: float | None = None
    type_name = "velocity_steps"

    def __post_init__(self):
        name = "VelocitySteps"
        object.__setattr__(self, "velocities", _values(name, self.velocities, "velocities", "m/s"))
        object.__setattr__(
            self, "step_duration", _positive(name, self.step_duration, "step_duration", "s")
        )

    @property
    def duration(self) -> float:
        return self.step_duration * len(self.velocities)

    def pieces(self) -> list[RatePiece]:
        return [RatePiece(v, v, self.step_duration) for v in self.velocities]


@dataclass(frozen=True, slots=True)
class VelocityTable(Segment):
    """Imposed velocity interpolated linearly in a table of times and velocities.

    Parameters
    ----------
    time : sequence of float
        Times from the start of the segment [s]: 0 first, strictly increasing.
    velocity : sequence of float
        Sliding velocity at each time [m/s]; non-negative.
    """

    time: tuple | None = None
    velocity: tuple | None = None
    type_name = "velocity_table"

    def __post_init__(self):
        times, levels = _table("VelocityTable", self.time, self.velocity, "velocity", "m/s")
        object.__setattr__(self, "time", times)
        object.__setattr__(self, "velocity", levels)

    @property
    def duration(self) -> float:
        return self.time[-1]

    def pieces(self) -> list[RatePiece]:
        return [
            RatePiece(self.velocity[i], self.velocity[i + 1], self.time[i + 1] - self.time[i])
            for i in range(len(self.time) - 1)
        ]


@dataclass(frozen=True, slots=True)
class Hold(Segment):
    """Rest: the drive stops (v = 0) for ``duration``.

    The drive is locked, so the force it exerts stays at its value when the hold begins (the
    model has no stress relaxation). Under the time clock the layer keeps aging.

    Parameters
    ----------
    duration : float
        Duration of the rest [s]; positive.
    reset : bool
        Re-prepare the sample at the end of the hold: the aging coordinate goes back to its
        initial value (x0, or t0 under the time clock), the friction state to its initial
        value, and the force to zero. The next start-up shows a fresh overshoot.
    """

    duration: float | None = None
    reset: bool = False
    type_name = "hold"

    def __post_init__(self):
        object.__setattr__(self, "duration", _positive("Hold", self.duration, "duration", "s"))
        if not isinstance(self.reset, bool | np.bool_):
            raise InvalidProtocolError(f"Hold: reset must be true or false, got {self.reset!r}")
        object.__setattr__(self, "reset", bool(self.reset))

    def pieces(self) -> list[RatePiece]:
        return [RatePiece(0.0, 0.0, self.duration, hold=True, reset=self.reset)]


class _ForceSegment(Segment):
    __slots__ = ()
    control = "force"


@dataclass(frozen=True, slots=True)
class Force(_ForceSegment):
    """Imposed constant force (a creep test).

    Parameters
    ----------
    level : float
        Imposed shear force [N]; non-negative.
    duration : float
        Duration [s]; positive.
    """

    level: float | None = None
    duration: float | None = None
    type_name = "force"

    def __post_init__(self):
        object.__setattr__(self, "level", _non_negative("Force", self.level, "level", "N"))
        object.__setattr__(self, "duration", _positive("Force", self.duration, "duration", "s"))

    def pieces(self, current: float) -> list[ForcePiece]:
        return [ForcePiece(self.level, self.level, self.duration)]


@dataclass(frozen=True, slots=True)
class ForceRamp(_ForceSegment):
    """Imposed force rising (or falling) linearly in time (Fig. 3a).

    Parameters
    ----------
    rate : float
        Loading rate [N/s].
    duration : float
        Duration [s]; positive.
    start : float, optional
        Force at the start of the ramp [N]; default the current force (0 on a fresh layer).
        The force must stay non-negative.
    """

    rate: float | None = None
    duration: float | None = None
    start: float | None = None
    type_name = "force_ramp"

    def __post_init__(self):
        name = "ForceRamp"
        object.__setattr__(self, "rate", _real(name, self.rate, "rate", "N/s"))
        object.__setattr__(self, "duration", _positive(name, self.duration, "duration", "s"))
        if self.start is not None:
            object.__setattr__(self, "start", _non_negative(name, self.start, "start", "N"))
            _check_end(name, self.start, self.rate, self.duration)

    def pieces(self, current: float) -> list[ForcePiece]:
        start = current if self.start is None else self.start
        _check_end("ForceRamp", start, self.rate, self.duration)
        return [ForcePiece(start, start + self.rate * self.duration, self.duration)]


def _check_end(name, start, rate, duration):
    end = start + rate * duration
    if end < 0:
        raise InvalidProtocolError(
            f"{name}: the force would fall below zero ({start:g} N + {rate:g} N/s x "
            f"{duration:g} s = {end:g} N)"
        )


@dataclass(frozen=True, slots=True)
class ForceSteps(_ForceSegment):
    """A staircase of constant forces, each imposed for ``step_duration`` (Fig. 3a).

    Parameters
    ----------
    levels : sequence of float
        Imposed forces [N]; non-negative.
    step_duration : float
        Duration of each step [s]; positive.
    """

    levels: tuple | None = None
    step_duration: float | None = None
    type_name = "force_steps"

    def __post_init__(self):
        name = "ForceSteps"
        object.__setattr__(self, "levels", _values(name, self.levels, "levels", "N"))
        object.__setattr__(
            self, "step_duration", _positive(name, self.step_duration, "step_duration", "s")
        )

    @property
    def duration(self) -> float:
        return self.step_duration * len(self.levels)

    def pieces(self, current: float) -> list[ForcePiece]:
        return [ForcePiece(level, level, self.step_duration) for level in self.levels]


@dataclass(frozen=True, slots=True)
class ForceTable(_ForceSegment):
    """Imposed force interpolated linearly in a table of times and forces.

    Parameters
    ----------
    time : sequence of float
        Times from the start of the segment [s]: 0 first, strictly increasing.
    force : sequence of float
        Imposed force at each time [N]; non-negative.
    """

    time: tuple | None = None
    force: tuple | None = None
    type_name = "force_table"

    def __post_init__(self):
        times, levels = _table("ForceTable", self.time, self.force, "force", "N")
        object.__setattr__(self, "time", times)
        object.__setattr__(self, "force", levels)

    @property
    def duration(self) -> float:
        return self.time[-1]

    def pieces(self, current: float) -> list[ForcePiece]:
        return [
            ForcePiece(self.force[i], self.force[i + 1], self.time[i + 1] - self.time[i])
            for i in range(len(self.time) - 1)
        ]


@dataclass(frozen=True, slots=True)
class SwitchToForce(_ForceSegment):
    """Switch from rate to force control and hold the force (Fig. 3c).

    The imposed force is ``factor`` times the force at the moment of the switch, or the given
    ``level``; exactly one of the two must be given.

    Parameters
    ----------
    duration : float
        Duration under force control [s]; positive.
    factor : float, optional
        Ratio of the imposed force to the current force [-]; positive.
    level : float, optional
        Imposed force [N]; non-negative.
    ramp : float
        Time [s] over which the force goes linearly from the current force to its new value
        (0, the default, is a sudden step); at most ``duration``.

    Examples
    --------
    >>> from granflow import Protocol, SwitchToForce, Velocity
    >>> Protocol([Velocity(0.86e-6, 80.0), SwitchToForce(60.0, factor=1.01)]).duration
    140.0
    """

    duration: float | None = None
    factor: float | None = None
    level: float | None = None
    ramp: float = 0.0
    type_name = "switch_to_force"

    def __post_init__(self):
        name = "SwitchToForce"
        object.__setattr__(self, "duration", _positive(name, self.duration, "duration", "s"))
        if (self.factor is None) == (self.level is None):
            raise InvalidProtocolError(
                f"{name}: give exactly one of factor (times the current force) or level [N]"
            )
        if self.factor is not None:
            object.__setattr__(self, "factor", _positive(name, self.factor, "factor", ""))
        else:
            object.__setattr__(self, "level", _non_negative(name, self.level, "level", "N"))
        ramp = _non_negative(name, self.ramp, "ramp", "s")
        if ramp > self.duration:
            raise InvalidProtocolError(
                f"{name}: ramp must not exceed the duration {self.duration:g} s, got {ramp:g} s"
            )
        object.__setattr__(self, "ramp", ramp)

    def target(self, current: float) -> float:
        """The imposed force [N] after a switch at the force ``current`` [N]."""
        return self.level if self.level is not None else self.factor * current

    def pieces(self, current: float) -> list[ForcePiece]:
        target = self.target(current)
        if self.ramp == 0:
            return [ForcePiece(target, target, self.duration)]
        pieces = [ForcePiece(current, target, self.ramp)]
        if self.duration > self.ramp:
            pieces.append(ForcePiece(target, target, self.duration - self.ramp))
        return pieces


#: Segment classes by their name in YAML and in ``to_dict``.
SEGMENT_TYPES = {
    cls.type_name: cls
    for cls in (
        Velocity,
        VelocitySteps,
        VelocityTable,
        Hold,
        Force,
        ForceRamp,
        ForceSteps,
        ForceTable,
        SwitchToForce,
    )
}
