"""What a simulation returns: the recorded arrays, its events and its segments.

Every type here is frozen, has a JSON-safe ``to_dict()`` and a ``from_dict()`` that inverts
it. Non-finite numbers are written as None; the only one a run records is the infinite
velocity of a quasi-static failure, which ``from_dict`` reads back as +inf (NaN elsewhere).
"""

import math
from dataclasses import dataclass, field, fields
from types import MappingProxyType

import numpy as np

from granflow.model.params import Params
from granflow.model.units import si_unit
from granflow.simulation.options import DirectEffect
from granflow.simulation.protocol import Protocol

__all__ = ["ARRAYS", "Event", "SegmentRecord", "SimulationResult"]

#: The recorded arrays of a run, in the order of :meth:`SimulationResult.to_frame`.
ARRAYS = ("t", "slip", "velocity", "force", "state", "age", "displacement", "segment")
#: The quantity of :data:`granflow.model.units.QUANTITIES` of each array with a unit (the
#: result's age is a time since preparation, not the aging coordinate of the model).
_ARRAY_QUANTITIES = {
    "t": "t",
    "slip": "slip",
    "velocity": "velocity",
    "force": "force",
    "state": "state",
    "age": "time",
    "displacement": "displacement",
}


def _json_number(value):
    return float(value) if math.isfinite(value) else None


def _number(value, missing=math.nan):
    """Inverse of _json_number: None is the non-finite ``missing``."""
    return missing if value is None else float(value)


def _fields_of(instance):
    return {item.name: getattr(instance, item.name) for item in fields(instance)}


@dataclass(frozen=True, slots=True)
class Event:
    """Something that happened during a run.

    Attributes
    ----------
    kind : str
        ``"failure"`` (runaway: no stable state ahead, or v above v_fail; ends the run),
        ``"stop"`` (the layer sticks again under an imposed force), ``"slide"`` (it starts to
        slide), ``"peak"`` (a maximum of the friction under an imposed velocity: the
        overshoot) or ``"reset"`` (the sample is re-prepared).
    time : float
        Time [s] since the start of the protocol.
    slip : float
        Aging coordinate x [m] at the event.
    force : float
        Force [N] the drive exerts at the event: the imposed force under force control.
    state : float
        Friction state F [N] of Eq. 2 (the strength) at the event.
    segment : int
        Index of the protocol segment (from 0).
    message : str
        A short explanation.
    """

    kind: str
    time: float
    slip: float
    force: float
    state: float
    segment: int
    message: str = ""

    def to_dict(self):
        return _fields_of(self)

    @classmethod
    def from_dict(cls, mapping):
        """Inverse of :meth:`to_dict` (and of the JSON form in a result's ``to_dict``)."""
        return cls(
            kind=mapping["kind"],
            time=_number(mapping["time"]),
            slip=_number(mapping["slip"]),
            force=_number(mapping["force"]),
            state=_number(mapping["state"]),
            segment=int(mapping["segment"]),
            message=mapping.get("message", ""),
        )


@dataclass(frozen=True, slots=True)
class SegmentRecord:
    """Bookkeeping of one protocol segment in a run (times [s], slips [m], forces [N])."""

    index: int
    kind: str
    control: str
    start_time: float
    end_time: float
    start_slip: float
    end_slip: float
    start_force: float
    end_force: float
    outcome: str

    def to_dict(self):
        return _fields_of(self)

    @classmethod
    def from_dict(cls, mapping):
        """Inverse of :meth:`to_dict`."""
        return cls(**{item.name: mapping[item.name] for item in fields(cls)})


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """The outcome of :func:`simulate`.

    Attributes
    ----------
    t : numpy.ndarray
        Time since the start of the protocol [s] (repeated at a jump: a sudden slip, a reset).
    slip : numpy.ndarray
        Aging coordinate x [m] (x0 on a fresh layer; back to x0 after ``Hold(reset=True)``).
    velocity : numpy.ndarray
        Sliding velocity [m/s] (inf at a quasi-static failure).
    force : numpy.ndarray
        Force the drive exerts on the layer [N]: the imposed force under force control, the
        friction (plus the direct effect) under a rigid imposed velocity, K s with a spring.
    state : numpy.ndarray
        Friction state F of Eq. 2 [N]: the strength of the layer.
    age : numpy.ndarray
        Time since preparation [s] (t0 + t on a fresh layer): the time clock's coordinate.
    displacement : numpy.ndarray
        Total slip since the start of the protocol [m], never reset.
    segment : numpy.ndarray
        Index of the protocol segment of each point (int).
    events : tuple of Event
        In time order.
    segments : tuple of SegmentRecord
        One per segment that was run.
    failed : bool
        Whether the layer failed.
    failure : Event or None
        The failure event.
    success : bool
        False if the run could not be completed (integration failure, work bound reached).
    message : str
        What happened, in words.
    params : Params
    protocol : Protocol
    options : mapping
        clock, method, t0, mass, damping, stiffness, v_fail, v_stop, direct_effect.
    """

    t: np.ndarray
    slip: np.ndarray
    velocity: np.ndarray
    force: np.ndarray
    state: np.ndarray
    age: np.ndarray
    displacement: np.ndarray
    segment: np.ndarray
    events: tuple
    segments: tuple
    failed: bool
    failure: Event | None
    success: bool
    message: str
    params: Params
    protocol: Protocol
    options: MappingProxyType = field(default_factory=dict)

    def __post_init__(self):
        for name in ARRAYS:
            getattr(self, name).flags.writeable = False
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))

    def __repr__(self):
        outcome = "failed" if self.failed else ("ok" if self.success else "aborted")
        return (
            f"SimulationResult({self.options['method']}, clock={self.options['clock']!r}, "
            f"{len(self.t)} points, {len(self.events)} events, {outcome})"
        )

    def events_of(self, kind):
        """The events of one kind, in time order."""
        return tuple(event for event in self.events if event.kind == kind)

    def to_frame(self):
        """A pandas DataFrame of the arrays; ``attrs`` holds events, segments and options."""
        import pandas as pd

        frame = pd.DataFrame({name: getattr(self, name) for name in ARRAYS})
        frame.attrs["events"] = [event.to_dict() for event in self.events]
        frame.attrs["segments"] = [record.to_dict() for record in self.segments]
        frame.attrs["options"] = self.to_dict()["options"]
        frame.attrs["units"] = {
            name: si_unit(quantity) for name, quantity in _ARRAY_QUANTITIES.items()
        }
        return frame

    def to_run(self):
        """The simulated data as a :class:`granflow.Run` (slip measured from the start).

        Time and slip start at zero at the initial state, as a rheometer would record them.
        :func:`granflow.fit` reads a run the paper's way instead (its abscissa is the model's
        own coordinate, which starts at x0 = v t0): to fit a simulated start-up, shift it
        first, e.g. ``Run(t + x0 / v, slip + x0, ...)``, or fit the fitted x0 as an offset.
        """
        from granflow.model.run import Run

        control = "stress" if any(s.control == "force" for s in self.protocol) else "rate"
        return Run(
            t=self.t,
            slip=self.displacement,
            velocity=self.velocity,
            force=self.force,
            control=control,
            meta={
                "source": "simulation",
                "method": self.options["method"],
                "clock": self.options["clock"],
            },
        )

    def to_dict(self):
        """JSON-safe mapping (non-finite numbers become None)."""
        options = {}
        for key, value in self.options.items():
            options[key] = value.to_dict() if isinstance(value, DirectEffect) else value
        arrays = {
            name: [_json_number(v) for v in getattr(self, name).tolist()]
            for name in ARRAYS
            if name != "segment"
        }
        arrays["segment"] = self.segment.tolist()
        return {
            "params": self.params.to_dict(),
            "protocol": self.protocol.to_dict(),
            "options": options,
            "success": self.success,
            "failed": self.failed,
            "message": self.message,
            "failure": None if self.failure is None else self.failure.to_dict(),
            "events": [
                {
                    k: (_json_number(v) if isinstance(v, float) else v)
                    for k, v in e.to_dict().items()
                }
                for e in self.events
            ],
            "segments": [record.to_dict() for record in self.segments],
            **arrays,
        }

    @classmethod
    def from_dict(cls, mapping):
        """Inverse of :meth:`to_dict`: the result, with its params, protocol and options."""
        options = dict(mapping["options"])
        if options.get("direct_effect") is not None:
            options["direct_effect"] = DirectEffect.from_dict(options["direct_effect"])
        arrays = {
            name: np.array(
                [_number(v, math.inf if name == "velocity" else math.nan) for v in mapping[name]],
                dtype=float,
            )
            for name in ARRAYS
            if name != "segment"
        }
        arrays["segment"] = np.array(mapping["segment"], dtype=np.int64)
        failure = mapping["failure"]
        return cls(
            **arrays,
            events=tuple(Event.from_dict(item) for item in mapping["events"]),
            segments=tuple(SegmentRecord.from_dict(item) for item in mapping["segments"]),
            failed=bool(mapping["failed"]),
            failure=None if failure is None else Event.from_dict(failure),
            success=bool(mapping["success"]),
            message=mapping["message"],
            params=Params(**mapping["params"]),
            protocol=Protocol.from_dict(mapping["protocol"]),
            options=options,
        )

    def report(self):
        """A plain-text summary in the manner of lmfit's fit report (display units)."""
        opts = self.options
        lines = [
            "[[Simulation]]",
            f"    method     = {opts['method']}",
            f"    clock      = {opts['clock']}",
            f"    segments   = {len(self.segments)} of {len(self.protocol)}",
            f"    time       = {self.t[-1]:.6g} s of {self.protocol.duration:.6g} s",
            f"    success    = {self.success}",
            f"    message    = {self.message}",
        ]
        if opts["method"] == "dynamic":
            lines.append(
                f"    mass       = {opts['mass']:.6g} kg, damping = {opts['damping']:.6g} N s/m"
            )
            if opts["stiffness"] is not None:
                lines.append(f"    stiffness  = {opts['stiffness']:.6g} N/m")
        lines.append(f"    v_fail     = {opts['v_fail'] * 1e6:.6g} um/s")
        if opts["direct_effect"] is not None:
            effect = opts["direct_effect"]
            lines.append(
                f"    direct     = A {effect.amplitude * 1e3:.6g} mN, v_ref "
                f"{effect.velocity * 1e6:.6g} um/s"
            )
        lines.append("[[Events]]")
        if not self.events:
            lines.append("    (none)")
        for event in self.events:
            lines.append(
                f"    {event.kind:<8} t = {event.time:<12.7g} s  slip = "
                f"{event.slip * 1e6:<12.7g} um  force = {event.force * 1e3:.7g} mN"
            )
        lines.append("[[Segments]]")
        for record in self.segments:
            lines.append(
                f"    {record.index + 1:>3} {record.kind:<14} {record.control:<5} "
                f"t = {record.start_time:.6g}..{record.end_time:.6g} s  "
                f"force {record.start_force * 1e3:.6g} -> {record.end_force * 1e3:.6g} mN  "
                f"{record.outcome}"
            )
        return "\n".join(lines)
