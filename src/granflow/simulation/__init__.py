"""Experiments under any imposed history: protocols, the simulator and stability maps.

``segments`` (rate or force control, cut into linear pieces) and ``protocol`` (a sequence of
them, YAML with units); ``driver`` (:func:`simulate`, picking a stepper from ``METHODS``:
``quasistatic`` or ``dynamic``, over ``stepper``, ``state``, ``curve`` and ``direct``);
``options`` (frozen, checked option objects) and ``results`` (the result, its events and
segments); ``stability`` (which switches fail, over a grid). Stands on :mod:`granflow.model`.
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
        "results": ["Event", "SegmentRecord", "SimulationResult"],
        "driver": ["METHODS", "simulate"],
        "stability": ["StabilityMap", "stability_map"],
    },
)
