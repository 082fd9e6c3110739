"""granflow: the onset of dense granular flow (the aging-rejuvenation model of Farain & Bonn).

Model evaluation, simulation of rheometer protocols, fits with uncertainties, instrument
readers and campaign reports. Every quantity is in SI units (N, m, s, 1/m).
"""

from granflow.errors import (
    ConvergenceWarning,
    FileFormatError,
    FitError,
    GranflowError,
    InvalidDataError,
    InvalidParameterError,
    InvalidProtocolError,
)
from granflow.geometry import Annulus
from granflow.model import (
    NoPeakError,
    Peak,
    friction_aging,
    friction_asymptote,
    friction_slip,
    friction_slip_jacobian,
    friction_time,
    has_peak,
    initial_force,
    peak,
    rhs_slip,
    rhs_time,
    steady_state,
)
from granflow.params import MaterialConstants, Params
from granflow.protocol import (
    Force,
    ForceRamp,
    ForceSteps,
    ForceTable,
    Hold,
    Protocol,
    SwitchToForce,
    Velocity,
    VelocitySteps,
    VelocityTable,
)
from granflow.run import Run
from granflow.simulate import DirectEffect, Event, SimulationResult, simulate
from granflow.special import scaled_ei, scaled_ei_diff
from granflow.stability import StabilityMap, stability_map

__version__ = "0.1.0"

__all__ = [
    "Annulus",
    "ConvergenceWarning",
    "DirectEffect",
    "Event",
    "FileFormatError",
    "FitError",
    "Force",
    "ForceRamp",
    "ForceSteps",
    "ForceTable",
    "GranflowError",
    "Hold",
    "InvalidDataError",
    "InvalidParameterError",
    "InvalidProtocolError",
    "MaterialConstants",
    "NoPeakError",
    "Params",
    "Peak",
    "Protocol",
    "Run",
    "SimulationResult",
    "StabilityMap",
    "SwitchToForce",
    "Velocity",
    "VelocitySteps",
    "VelocityTable",
    "__version__",
    "friction_aging",
    "friction_asymptote",
    "friction_slip",
    "friction_slip_jacobian",
    "friction_time",
    "has_peak",
    "initial_force",
    "peak",
    "rhs_slip",
    "rhs_time",
    "scaled_ei",
    "scaled_ei_diff",
    "simulate",
    "stability_map",
    "steady_state",
]
