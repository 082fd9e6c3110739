"""The segments of an experiment, defined in :mod:`granflow.model.segments` (the readers of
:mod:`granflow.io` build them too, and io stands on the model, not on the simulator) and
re-exported here, where the simulator's users look for them."""

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
