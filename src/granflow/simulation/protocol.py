"""The protocol the simulator runs: :class:`Protocol` and its segments, defined in
:mod:`granflow.model.protocol` (the readers of :mod:`granflow.io` build protocols too, and
io stands on the model, not on the simulator) and re-exported here, where the simulator's
users look for them."""

from granflow.model.protocol import (
    SEGMENT_TYPES,
    Force,
    ForcePiece,
    ForceRamp,
    ForceSteps,
    ForceTable,
    Hold,
    Protocol,
    RatePiece,
    Segment,
    SwitchToForce,
    Velocity,
    VelocitySteps,
    VelocityTable,
)

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
