"""What a simulation returns: the recorded arrays, its events and its segments.

Every type here is frozen, has a JSON-safe ``to_dict()`` and a ``from_dict()`` that inverts
it. Non-finite numbers are written as None; the only one a run records is the infinite
velocity of a quasi-static failure, which ``from_dict`` reads back as +inf (NaN elsewhere).
Every result says which clock its times and slips are on (:class:`Origin`, the one-clock
rule of :mod:`granflow.simulation`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.model.params import Params
from granflow.model.units import si_unit
from granflow.simulation.events import (
    ORIGINS,
    Event,
    Origin,
    SegmentRecord,
    json_number,
    number_or,
)
from granflow.simulation.options import DirectEffect, check_choice
from granflow.simulation.protocol import Protocol

if TYPE_CHECKING:
    import pandas as pd

    from granflow.model.run import Run

__all__ = [
    "ARRAYS",
    "ARRAY_QUANTITIES",
    "ORIGINS",
    "Event",
    "Origin",
    "SegmentRecord",
    "SimulationResult",
]

#: The recorded arrays of a run, in the order of :meth:`SimulationResult.to_frame`.
ARRAYS = ("t", "slip", "velocity", "force", "state", "age", "displacement", "segment")
#: The quantity of :data:`granflow.model.units.QUANTITIES` of each array with a unit (the
#: result's age is a time since preparation, not the aging coordinate of the model).
ARRAY_QUANTITIES = {
    "t": "t",
    "slip": "slip",
    "velocity": "velocity",
    "force": "force",
    "state": "state",
    "age": "time",
    "displacement": "displacement",
}


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """The outcome of :func:`simulate`.

    Attributes
    ----------
    t : numpy.ndarray
        Time since the start of the protocol [s] (repeated at a jump: a sudden slip, a reset):
        the record's clock. A start-up of a fresh layer at v begins at x0 / v (``origin``).
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
        Total slip since the start of the protocol [m], never reset (x0 where a start-up
        enters the model).
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
        clock, method, t0, mass, damping, stiffness, v_fail, v_stop, direct_effect, and the
        numerics (rtol, solver, max_evaluations, max_transitions, max_wall: None when there
        was no wall-clock limit).
    origin : Origin
        Which clock the times and displacements are on, and where the model takes over.
    work : mapping
        The work done, counted: ``evaluations`` (right-hand sides) and ``transitions``
        (stick-slip phases); the bounds on it are in ``options``.
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
    options: Mapping[str, Any] = field(default_factory=dict)
    origin: Origin = None  # type: ignore[assignment]  # __post_init__ sets the default
    work: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        for name in ARRAYS:
            getattr(self, name).flags.writeable = False
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))
        object.__setattr__(self, "work", MappingProxyType(dict(self.work)))
        if self.origin is None:  # the clock before the one-clock rule: the model from t = 0
            object.__setattr__(self, "origin", Origin("rest", None, 0.0, self.params.x0))

    def __repr__(self):
        outcome = "failed" if self.failed else ("ok" if self.success else "aborted")
        return (
            f"SimulationResult({self.options['method']}, clock={self.options['clock']!r}, "
            f"{len(self.t)} points, {len(self.events)} events, {outcome})"
        )

    def events_of(self, kind: str) -> tuple[Event, ...]:
        """The events of one kind, in time order."""
        return tuple(event for event in self.events if event.kind == kind)

    def instants(self) -> np.ndarray:
        """A mask of the rows that are the last at their time: one row per instant.

        At an event or a segment's end the arrays hold the state before and after the same
        instant (a switch imposes its force at once; a quasi-static failure sets the
        velocity to inf), so their time repeats there. A record keeps the state the layer
        is in from that instant on, as an instrument samples it.
        """
        keep = np.ones(self.t.size, dtype=bool)
        keep[:-1] = self.t[1:] != self.t[:-1]
        return keep

    def to_frame(self, one_row_per_instant: bool = False) -> pd.DataFrame:
        """A pandas DataFrame of the arrays; ``attrs`` holds events, segments and options.

        Parameters
        ----------
        one_row_per_instant : bool
            Keep only the last row of each time (:meth:`instants`), so that the time
            increases strictly, as in a record (``granflow simulate -o`` writes it so).
        """
        import pandas as pd

        rows = self.instants() if one_row_per_instant else slice(None)
        frame = pd.DataFrame({name: getattr(self, name)[rows] for name in ARRAYS})
        frame.attrs["events"] = [event.to_dict() for event in self.events]
        frame.attrs["segments"] = [record.to_dict() for record in self.segments]
        frame.attrs["options"] = self.to_dict()["options"]
        frame.attrs["units"] = {
            name: si_unit(quantity) for name, quantity in ARRAY_QUANTITIES.items()
        }
        return frame

    def to_run(self, origin: str = "record") -> Run:
        """The simulated data as a :class:`granflow.Run`: what a rheometer would record.

        Parameters
        ----------
        origin : {"record", "model"}
            ``"record"`` (default): t and slip as recorded, 0 at the start of the protocol
            (``t`` and ``displacement``); a start-up of a fresh layer at v begins at
            t = x0 / v with slip x0, so that :func:`granflow.fit` reads it as it is.
            ``"model"``: shifted onto the model's coordinates by :attr:`origin` (time minus
            the start of shear, slip plus the slip offset; from rest, the age t0 + t), for a
            protocol that begins with a rest or from rest.

        Returns
        -------
        Run
            One row per instant (:meth:`instants`: where an event repeats a time, the state
            from that instant on), so that its time increases strictly as in a record.
            ``meta`` holds ``source`` ("simulation"), ``method``, ``clock``, ``origin``
            (the :class:`Origin` kind, or "model"), ``model_start`` [s] and ``slip_offset``
            [m] (what to add to the slip to get the model's coordinate), and for a
            start-up ``shear_start`` [s]; shifted, ``time_shift`` [s] and ``slip_shift``
            [m] (what was added).
        """
        from granflow.model.run import Run

        check_choice(origin, "origin", ("record", "model"))
        control = "stress" if any(s.control == "force" for s in self.protocol) else "rate"
        start = self.origin
        meta = {"source": "simulation", "method": self.options["method"]}
        meta["clock"] = self.options["clock"]
        t, slip = self.t, self.displacement
        if origin == "model":
            if start.kind == "shear":
                shift = start.shear_start
            else:
                shift = start.model_start - self.options["t0"]
            t, slip = t - shift, slip + start.slip_offset
            meta.update(origin="model", time_shift=-shift, slip_shift=start.slip_offset)  # type: ignore[operator]
        else:
            meta.update(
                origin=start.kind, model_start=start.model_start, slip_offset=start.slip_offset
            )
            if start.shear_start is not None:
                meta["shear_start"] = start.shear_start
        keep = self.instants()
        return Run(
            t=t[keep],
            slip=slip[keep],
            velocity=self.velocity[keep],
            force=self.force[keep],
            control=control,
            meta=meta,
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe mapping (non-finite numbers become None)."""
        options = {}
        for key, value in self.options.items():
            options[key] = value.to_dict() if isinstance(value, DirectEffect) else value
        arrays = {
            name: [json_number(v) for v in getattr(self, name).tolist()]
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
                {k: (json_number(v) if isinstance(v, float) else v) for k, v in e.to_dict().items()}
                for e in self.events
            ],
            "segments": [record.to_dict() for record in self.segments],
            "origin": self.origin.to_dict(),
            "work": dict(self.work),
            **arrays,
        }

    @classmethod
    def from_dict(cls, mapping: Mapping[str, Any]) -> SimulationResult:
        """Inverse of :meth:`to_dict`: the result, with its params, protocol and options.

        A mapping written before results stated their origin (no ``"origin"``) was on the
        old clock: the model from t = 0 at the slip x0 + displacement (an origin ``"rest"``).
        """
        options = dict(mapping["options"])
        if options.get("direct_effect") is not None:
            options["direct_effect"] = DirectEffect.from_dict(options["direct_effect"])
        arrays = {
            name: np.array(
                [number_or(v, math.inf if name == "velocity" else math.nan) for v in mapping[name]],
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
            origin=None if "origin" not in mapping else Origin.from_dict(mapping["origin"]),  # type: ignore[arg-type]
            work=mapping.get("work", {}),
        )

    def _layer_outcome(self) -> str:
        """What the layer did, in words with display units: failed (when, at what force),
        stopped, or neither."""
        from granflow._format import format_number

        if self.failure is not None:
            return (
                f"fails at t = {format_number(self.failure.time)} s, force "
                f"{format_number(self.failure.force, 1e3)} mN"
            )
        stops = [event for event in self.events if event.kind == "stop"]
        if stops:
            return f"stops at t = {format_number(stops[-1].time)} s (no failure)"
        return "no failure"

    def _summary_rows(self) -> list[tuple[str, str]]:
        """The rows of the summary (display units, the digits a reader needs)."""
        from granflow._format import display_text, format_number

        opts = self.options
        rows = [
            ("layer", self._layer_outcome()),
            (
                "simulation",
                ("completed" if self.success else "stopped early")
                + f": {display_text(self.message)}",
            ),
            ("method", str(opts["method"])),
            ("clock", str(opts["clock"])),
            ("origin", self.origin.describe()),
            ("segments", f"{len(self.segments)} of {len(self.protocol)}"),
            (
                "time",
                f"{format_number(self.t[-1])} s of {format_number(self.protocol.duration)} s",
            ),
            ("v_fail", f"{format_number(opts['v_fail'], 1e6)} µm/s"),
        ]
        if opts["method"] == "dynamic":
            rows.append(
                (
                    "drive",
                    f"mass {format_number(opts['mass'])} kg, damping "
                    f"{format_number(opts['damping'])} N s/m"
                    + (
                        f", stiffness {format_number(opts['stiffness'])} N/m"
                        if opts["stiffness"] is not None
                        else ""
                    ),
                )
            )
        if opts["direct_effect"] is not None:
            effect = opts["direct_effect"]
            rows.append(
                (
                    "direct effect",
                    f"A {format_number(effect.amplitude, 1e3)} mN, v_ref "
                    f"{format_number(effect.velocity, 1e6)} µm/s",
                )
            )
        if self.work:
            rows.append(
                (
                    "work",
                    f"{self.work['evaluations']} evaluations, "
                    f"{self.work['transitions']} transitions (counted)",
                )
            )
        if opts.get("max_wall") is not None:
            rows.append(("max_wall", f"{format_number(opts['max_wall'])} s (a wall-clock limit)"))
        return rows

    def _repr_html_(self) -> str:
        """An HTML card built from the fields (Jupyter): what the layer did, the run, its
        events and its segments as tables, every number in display units (s, µm, mN)."""
        from granflow._format import format_number
        from granflow._html import heading, result_html, table

        events = [
            (
                event.kind,
                format_number(event.time, significant=5),
                format_number(event.slip, 1e6, 5),
                format_number(event.force, 1e3, 5),
                event.segment + 1,
                event.message,
            )
            for event in self.events
        ]
        segments = [
            (
                record.index + 1,
                record.kind,
                record.control,
                f"{format_number(record.start_time)} – {format_number(record.end_time)}",
                f"{format_number(record.start_force, 1e3)} → "
                f"{format_number(record.end_force, 1e3)}",
                record.outcome,
            )
            for record in self.segments
        ]
        return result_html(
            f"SimulationResult ({self.options['method']}, {len(self.t)} points): the layer "
            f"{self._layer_outcome()}",
            [
                table(self._summary_rows()),
                heading(f"Events ({len(events)})"),
                table(
                    events,
                    header=("event", "t [s]", "slip x [µm]", "force [mN]", "segment", ""),
                    numeric=(1, 2, 3, 4),
                ),
                heading("Segments"),
                table(
                    segments,
                    header=("", "segment", "control", "t [s]", "force [mN]", "outcome"),
                    numeric=(0,),
                ),
            ],
        )

    def report(self) -> str:
        """A plain-text summary in the manner of lmfit's fit report (display units)."""
        opts = self.options
        lines = [
            "[[Simulation]]",
            f"    layer      = {self._layer_outcome()}",
            f"    method     = {opts['method']}",
            f"    clock      = {opts['clock']}",
            f"    origin     = {self.origin.describe()}",
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
        lines.append(f"    v_fail     = {opts['v_fail'] * 1e6:.6g} µm/s")
        if self.work:
            lines.append(
                f"    work       = {self.work['evaluations']} evaluations, "
                f"{self.work['transitions']} transitions (counted)"
            )
        if opts.get("max_wall") is not None:
            lines.append(f"    max_wall   = {opts['max_wall']:.6g} s (a wall-clock limit)")
        if opts["direct_effect"] is not None:
            effect = opts["direct_effect"]
            lines.append(
                f"    direct     = A {effect.amplitude * 1e3:.6g} mN, v_ref "
                f"{effect.velocity * 1e6:.6g} µm/s"
            )
        lines.append("[[Events]]")
        if not self.events:
            lines.append("    (none)")
        for event in self.events:
            lines.append(
                f"    {event.kind:<8} t = {event.time:<12.7g} s  slip = "
                f"{event.slip * 1e6:<12.7g} µm  force = {event.force * 1e3:.7g} mN"
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
