"""The segments of an experiment: imposed velocity, hold, imposed force, ramps, switches.

A :class:`Protocol` is a sequence of segments, each validated when it is made. Segments are
either rate-controlled (the drive imposes the sliding velocity) or force-controlled (the
drive imposes the shear force and the layer decides whether it sticks, slides or fails).
All quantities are in SI units (m/s, s, N, N/s).

A protocol can be written and read as YAML; values there are plain numbers in SI units or
strings with a unit (``"0.86 um/s"``, ``"80 s"``, ``"0.05 mN/s"``):

.. code-block:: yaml

    segments:
      - velocity: {velocity: 0.86 um/s, duration: 80 s}
      - switch_to_force: {duration: 60 s, factor: 1.01}

Each segment may also be written in the long form ``{type: velocity, velocity: ..., ...}``.
"""

import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidParameterError, InvalidProtocolError

__all__ = [
    "SEGMENT_TYPES",
    "Force",
    "ForceRamp",
    "ForceSteps",
    "ForceTable",
    "Hold",
    "Protocol",
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

    def pieces(self):
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
    def duration(self):
        return self.step_duration * len(self.velocities)

    def pieces(self):
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
    def duration(self):
        return self.time[-1]

    def pieces(self):
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

    def pieces(self):
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

    def pieces(self, current):
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

    def pieces(self, current):
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
    def duration(self):
        return self.step_duration * len(self.levels)

    def pieces(self, current):
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
    def duration(self):
        return self.time[-1]

    def pieces(self, current):
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

    def target(self, current):
        """The imposed force [N] after a switch at the force ``current`` [N]."""
        return self.level if self.level is not None else self.factor * current

    def pieces(self, current):
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

#: The SI unit of each field that YAML may give with a unit.
_FIELD_UNITS = {
    "velocity": "m/s",
    "velocities": "m/s",
    "duration": "s",
    "step_duration": "s",
    "time": "s",
    "ramp": "s",
    "level": "N",
    "levels": "N",
    "force": "N",
    "start": "N",
    "rate": "N/s",
    "factor": "",
}


def _quantity(value, unit, where):
    """A number, or a string with a unit, as a float in the SI unit."""
    from granflow.model.units import parse_quantity

    if isinstance(value, bool):
        raise InvalidProtocolError(f"{where} must be a number, got {value!r}")
    if isinstance(value, int | float):
        return float(value)
    if isinstance(value, str):
        try:
            return parse_quantity(value, unit or "dimensionless", where)
        except InvalidParameterError as exc:
            raise InvalidProtocolError(str(exc)) from None
    raise InvalidProtocolError(f"{where} must be a number or a quantity, got {value!r}")


def _segment_from_mapping(item, index):
    """One segment from its YAML/JSON form (short or long)."""
    where = f"segment {index + 1}"
    if not isinstance(item, dict):
        raise InvalidProtocolError(f"{where} must be a mapping, got {item!r}")
    if "type" in item:
        kind = item["type"]
        options = {key: value for key, value in item.items() if key != "type"}
    elif len(item) == 1:
        ((kind, options),) = item.items()
        options = {} if options is None else options
    else:
        raise InvalidProtocolError(
            f"{where}: give the segment as {{type: NAME, ...}} or {{NAME: {{...}}}}, got keys "
            f"{sorted(item)}"
        )
    cls = SEGMENT_TYPES.get(kind)
    if cls is None:
        known = ", ".join(SEGMENT_TYPES)
        raise InvalidProtocolError(f"{where}: unknown segment type {kind!r} (known: {known})")
    where = f"{where} ({kind})"
    if not isinstance(options, dict):
        raise InvalidProtocolError(f"{where}: options must be a mapping, got {options!r}")
    allowed = {item.name for item in fields(cls)}
    unknown = sorted(set(options) - allowed)
    if unknown:
        raise InvalidProtocolError(
            f"{where}: unknown option(s) {', '.join(unknown)} "
            f"(allowed: {', '.join(sorted(allowed))})"
        )
    values = {}
    for key, value in options.items():
        unit = _FIELD_UNITS.get(key)
        if value is None or unit is None:
            values[key] = value
        elif isinstance(value, list | tuple):
            values[key] = [
                _quantity(entry, unit, f"{where}: {key}[{i}]") for i, entry in enumerate(value)
            ]
        else:
            values[key] = _quantity(value, unit, f"{where}: {key}")
    try:
        return cls(**values)
    except InvalidProtocolError as exc:
        raise InvalidProtocolError(f"{where}: {exc}") from None


@dataclass(frozen=True, slots=True)
class Protocol:
    """A sequence of segments: the imposed history of one experiment.

    Parameters
    ----------
    segments : sequence of Segment
        :class:`Velocity`, :class:`VelocitySteps`, :class:`VelocityTable`, :class:`Hold`,
        :class:`Force`, :class:`ForceRamp`, :class:`ForceSteps`, :class:`ForceTable`,
        :class:`SwitchToForce`; at least one.

    Examples
    --------
    >>> from granflow import ForceRamp, Protocol
    >>> ramp = Protocol([ForceRamp(rate=0.05e-3, duration=400.0)])
    >>> ramp.duration, ramp.max_velocity
    (400.0, 0.0)
    >>> print(ramp.to_yaml().strip())
    segments:
    - type: force_ramp
      rate: 5.0e-05
      duration: 400.0
      start: null
    """

    segments: tuple

    def __init__(self, segments):
        if isinstance(segments, Segment):
            segments = [segments]
        try:
            items = tuple(segments)
        except TypeError:
            raise InvalidProtocolError(
                f"a Protocol needs a list of segments, got {type(segments).__name__}"
            ) from None
        if not items:
            raise InvalidProtocolError("a Protocol needs at least one segment")
        for index, item in enumerate(items):
            if not isinstance(item, Segment):
                raise InvalidProtocolError(
                    f"segment {index + 1} must be a granflow segment (Velocity, Hold, Force, ...),"
                    f" got {type(item).__name__}"
                )
        object.__setattr__(self, "segments", items)

    def __len__(self):
        return len(self.segments)

    def __iter__(self):
        return iter(self.segments)

    def __getitem__(self, index):
        return self.segments[index]

    def __repr__(self):
        kinds = ", ".join(type(s).__name__ for s in self.segments)
        return f"Protocol({len(self)} segments: {kinds}; {self.duration:g} s)"

    @property
    def duration(self):
        """Total duration [s]."""
        return math.fsum(segment.duration for segment in self.segments)

    @property
    def max_velocity(self):
        """Largest imposed velocity [m/s] of the rate-controlled segments (0 if none)."""
        return max(
            (
                max(piece.start, piece.end)
                for segment in self.segments
                if segment.control == "rate"
                for piece in segment.pieces()
            ),
            default=0.0,
        )

    @property
    def first_velocity(self):
        """The first positive imposed velocity [m/s], or None if the protocol imposes none."""
        for segment in self.segments:
            if segment.control == "rate":
                for piece in segment.pieces():
                    if max(piece.start, piece.end) > 0:
                        return piece.start if piece.start > 0 else piece.end
        return None

    def to_dict(self):
        """``{"segments": [segment.to_dict(), ...]}`` in SI units."""
        return {"segments": [segment.to_dict() for segment in self.segments]}

    @classmethod
    def from_dict(cls, mapping):
        """Build from ``{"segments": [...]}`` or a bare list of segment mappings.

        Values are numbers in SI units or strings with a unit ("0.86 um/s").
        """
        items = mapping.get("segments") if isinstance(mapping, dict) else mapping
        if isinstance(mapping, dict) and "segments" not in mapping:
            raise InvalidProtocolError("a protocol mapping needs a 'segments' list")
        if not isinstance(items, list):
            raise InvalidProtocolError(
                f"the protocol's segments must be a list, got {type(items).__name__}"
            )
        return cls([_segment_from_mapping(item, i) for i, item in enumerate(items)])

    def to_yaml(self):
        """The protocol as YAML text (SI units)."""
        import yaml

        return yaml.safe_dump(self.to_dict(), sort_keys=False)

    @classmethod
    def from_yaml(cls, text, source="<string>"):
        """Parse YAML text; errors name ``source``."""
        import yaml

        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise InvalidProtocolError(f"{source}: not valid YAML ({exc})") from None
        try:
            return cls.from_dict(data)
        except InvalidProtocolError as exc:
            raise InvalidProtocolError(f"{source}: {exc}") from None

    @classmethod
    def load(cls, path):
        """Read a protocol from a YAML file."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise InvalidProtocolError(f"{path}: cannot read the protocol ({exc})") from None
        return cls.from_yaml(text, source=str(path))

    def dump(self, path):
        """Write the protocol to a YAML file."""
        Path(path).write_text(self.to_yaml(), encoding="utf-8")
