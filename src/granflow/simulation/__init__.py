"""Experiments under any imposed history: protocols, the simulator and stability maps.

``protocol`` (segments under rate or force control, YAML with units), ``driver``
(:func:`simulate`, its result and events) and ``stability`` (which switches fail, over a
grid). Stands on :mod:`granflow.model`.
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
        "driver": ["DirectEffect", "Event", "SimulationResult", "simulate"],
        "stability": ["StabilityMap", "stability_map"],
    },
)
