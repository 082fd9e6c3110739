"""Experiments under any imposed history: protocols, the simulator and stability maps.

``segments`` (rate or force control, cut into linear pieces) and ``protocol`` (a sequence of
them, YAML with units); ``driver`` (:func:`simulate`, picking a stepper from ``METHODS``:
``quasistatic`` or ``dynamic``, over ``stepper``, ``state``, ``curve`` and ``direct``);
``options`` (frozen, checked option objects) and ``results`` (the result, its events and
segments); ``stability`` (which switches fail, over a grid). Stands on :mod:`granflow.model`.

**One clock** (SPEC §1; the rule every result follows). The protocol's time is the record's
time: t = 0 when the protocol starts, and the displacement is the slip since then.

* *A start-up of the prepared layer* (a fresh layer, or one re-prepared by
  ``Hold(reset=True)``, driven at a velocity v) is described by the model once it has slipped
  x0 since the start of shear, at t = t0 = x0 / v (Eq. 3 with the paper's initial condition;
  its rejuvenation term vanishes at t = 0). A simulated start-up's first point is therefore
  at t = t0 with displacement x0; its peak event is at ``peak(params, velocity=v).time``;
  its ``to_run()`` is the record a rheometer would write, and :func:`granflow.fit` reads it
  as it is (the record's time is the model's t, its slip the model's x). Nothing is
  recorded before t0: the model does not describe the elastic loading there.
* *The prepared layer loaded from rest* (a force ramp, a creep, a staircase, a drive
  accelerating from 0, or a rest that ages it under the time clock) is described from the
  start: t and displacement start at 0, the model's slip coordinate is x0 + displacement and
  its age (time clock) t0 + t.

A switch, a rest or a second start-up happens at the protocol's time (the paper's switch at
t = 80 s is at 80 s of the record, slip 80 s x v). A rest before a start-up delays the start
of shear (under the slip clock the layer does not change at rest). Every
:class:`~granflow.simulation.results.SimulationResult` states which of the two applies and
where the model takes over (``origin``); ``to_run(origin="model")`` shifts a record onto the
model's coordinates explicitly, for one whose first point is not the start of shear.

A bare number is in SI units; every physical argument also takes a string with a unit
("0.86 um/s") or a pint quantity. The work of a run is bounded by counting it (evaluations,
stick-slip transitions); a wall-clock limit is off unless asked for.
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "protocol": [
            "Force",
            "ForceRamp",
            "ForceSteps",
            "ForceTable",
            "Hold",
            "Protocol",
            "SwitchToForce",
            "Velocity",
            "VelocitySteps",
            "VelocityTable",
        ],
        "options": ["Aging", "DirectEffect", "Drive", "Numerics"],
        "results": ["Event", "Origin", "SegmentRecord", "SimulationResult"],
        "driver": ["METHODS", "simulate"],
        "stability": ["StabilityMap", "stability_map"],
    },
)
