"""The segments of an experiment: imposed velocity, hold, imposed force, ramps, switches.

A :class:`Protocol` is a sequence of segments (:mod:`granflow.model.segments`, each
validated when it is made, re-exported here). All quantities are in SI units (m/s, s, N,
N/s).

A protocol can be written and read as YAML; values there are plain numbers in SI units or
strings with a unit (``"0.86 um/s"``, ``"80 s"``, ``"0.05 mN/s"``):

.. code-block:: yaml

    segments:
      - velocity: {velocity: 0.86 um/s, duration: 80 s}
      - switch_to_force: {duration: 60 s, factor: 1.01}

Each segment may also be written in the long form ``{type: velocity, velocity: ..., ...}``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from granflow.errors import InvalidParameterError, InvalidProtocolError
from granflow.model.segments import (
    SEGMENT_TYPES,
    Force,
    ForcePiece,
    ForceRamp,
    ForceSteps,
    ForceTable,
    Hold,
    RatePiece,
    Segment,
    SwitchToForce,
    Velocity,
    VelocitySteps,
    VelocityTable,
)
from granflow.model.units import parse_quantity, si_unit

if TYPE_CHECKING:
    from granflow._typing import PathLike
    from granflow.model.segments import Segment

__all__ = [
    "SEGMENT_TYPES",
    "Force",
    "ForcePiece",
    "ForceRamp",
    "ForceSteps",
    "ForceTable",
    "Hold",
    "Protocol",
    "RatePiece",
    "Segment",
    "SwitchToForce",
    "Velocity",
    "VelocitySteps",
    "VelocityTable",
]

#: The quantity of :data:`granflow.model.units.QUANTITIES` of each field that YAML may give
#: with a unit (its SI unit is looked up there).
_FIELD_QUANTITIES = {
    "velocity": "velocity",
    "velocities": "velocity",
    "duration": "duration",
    "step_duration": "duration",
    "time": "time",
    "ramp": "duration",
    "level": "level",
    "levels": "level",
    "force": "force",
    "start": "force",
    "rate": "rate",
    "factor": "factor",
}


def _quantity(value, unit, where):
    """A number, or a string with a unit, as a float in the SI unit."""
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
        name = _FIELD_QUANTITIES.get(key)
        unit = None if name is None else si_unit(name)
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

    def __init__(self, segments: Iterable[Segment]) -> None:
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
    def duration(self) -> float:
        """Total duration [s]."""
        return math.fsum(segment.duration for segment in self.segments)

    @property
    def max_velocity(self) -> float:
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
    def first_velocity(self) -> float | None:
        """The first positive imposed velocity [m/s], or None if the protocol imposes none."""
        for segment in self.segments:
            if segment.control == "rate":
                for piece in segment.pieces():
                    if max(piece.start, piece.end) > 0:
                        return piece.start if piece.start > 0 else piece.end
        return None

    def to_dict(self) -> dict[str, Any]:
        """``{"segments": [segment.to_dict(), ...]}`` in SI units."""
        return {"segments": [segment.to_dict() for segment in self.segments]}

    @classmethod
    def from_dict(cls, mapping: Mapping[str, Any]) -> Protocol:
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

    def to_yaml(self) -> str:
        """The protocol as YAML text (SI units)."""
        import yaml

        return yaml.safe_dump(self.to_dict(), sort_keys=False)

    @classmethod
    def from_yaml(cls, text: str, source: str = "<string>") -> Protocol:
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
    def load(cls, path: PathLike) -> Protocol:
        """Read a protocol from a YAML file."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise InvalidProtocolError(f"{path}: cannot read the protocol ({exc})") from None
        return cls.from_yaml(text, source=str(path))

    def dump(self, path: PathLike) -> None:
        """Write the protocol to a YAML file."""
        Path(path).write_text(self.to_yaml(), encoding="utf-8")
