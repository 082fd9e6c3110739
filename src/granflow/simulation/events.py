"""The parts of a simulation's record: its events, its clock (:class:`Origin`) and its
segments, each frozen with a JSON-safe ``to_dict()`` and a ``from_dict()`` that inverts it
(:mod:`granflow._codec`; non-finite numbers written as None, read back as NaN)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from granflow._codec import Codec

__all__ = [
    "ORIGINS",
    "Event",
    "Origin",
    "SegmentRecord",
    "json_number",
    "number_or",
]


#: The kinds of :class:`Origin`: how the record's clock and displacement relate to the model.
ORIGINS = {
    "shear": "a start-up of the prepared layer: t and displacement count from the start of the "
    "protocol; the model takes over once the layer has slipped x0 since the start of shear",
    "rest": "the prepared layer loaded from rest: t and displacement count from the start of "
    "the protocol; the model's slip coordinate is x0 + displacement",
}


def json_number(value):
    return float(value) if math.isfinite(value) else None


def number_or(value, missing=math.nan):
    """Inverse of json_number: None is the non-finite ``missing``."""
    return missing if value is None else float(value)


@dataclass(frozen=True, slots=True, eq=False)
class Event(Codec):
    """Something that happened during a run.

    Attributes
    ----------
    kind : str
        ``"failure"`` (runaway: no stable state ahead, or v above v_fail; ends the run),
        ``"stop"`` (the layer sticks again under an imposed force), ``"slide"`` (it starts to
        slide), ``"peak"`` (a maximum of the friction under an imposed velocity: the
        overshoot) or ``"reset"`` (the sample is re-prepared).
    time : float
        Time [s] since the start of the protocol (the record's clock, as ``t``).
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

    KEEP_INFINITIES = False

    kind: str
    time: float
    slip: float
    force: float
    state: float
    segment: int
    message: str = ""


@dataclass(frozen=True, slots=True, eq=False)
class Origin(Codec):
    """Where a result's clock and displacement start, and where the model takes over.

    Times are always the record's time, 0 when the protocol starts; displacements the slip
    since then. Until a re-preparation (a ``reset`` event) the model's coordinates follow:
    its time t (Eq. 3) is ``t - shear_start`` and its slip ``displacement + slip_offset``.

    Attributes
    ----------
    kind : {"shear", "rest"}
        ``"shear"``: a start-up of the prepared layer at velocity v, which the model
        describes from ``t = shear_start + x0 / v`` on, at displacement x0 (the paper's
        clock: with ``shear_start = 0`` the record's time is the model's t and the
        displacement its slip x; ``fit`` reads such a record as it is). ``"rest"``: the
        prepared layer loaded from rest (a force, a drive accelerating from 0, a rest that
        ages it), which the model describes from ``model_start`` on, at the slip
        coordinate x0 + displacement and (time clock) the age t0 + t - model_start.
    shear_start : float or None
        Record time when shearing started [s] (``"shear"``; 0 unless the protocol begins
        with a rest); None for ``"rest"``.
    model_start : float
        Record time where the model takes over [s].
    slip_offset : float
        The model's slip coordinate minus the displacement [m]: 0 for ``"shear"``, x0 for
        ``"rest"``.
    """

    KEEP_INFINITIES = False

    kind: str
    shear_start: float | None
    model_start: float
    slip_offset: float

    def describe(self):
        """One line: where t and the displacement start and where the model takes over."""
        if self.kind == "shear":
            return (
                f"start of shear at t = {self.shear_start:.6g} s; the model takes over at "
                f"t = {self.model_start:.6g} s (model time = t - {self.shear_start:.6g} s, "
                f"slip = displacement + {self.slip_offset * 1e6:.6g} µm)"
            )
        return (
            f"rest at t = {self.model_start:.6g} s; the model describes the layer from there "
            f"(slip = displacement + {self.slip_offset * 1e6:.6g} µm)"
        )


@dataclass(frozen=True, slots=True, eq=False)
class SegmentRecord(Codec):
    """Bookkeeping of one protocol segment in a run (times [s], slips [m], forces [N])."""

    KEEP_INFINITIES = False

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
