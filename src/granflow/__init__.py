"""granflow: the onset of dense granular flow (the aging-rejuvenation model of Farain & Bonn).

Model evaluation, simulation of rheometer protocols, fits with uncertainties, instrument
readers and campaign reports. Every quantity is in SI units (N, m, s, 1/m).
"""

from granflow.analysis import AnalysisResult, analyze
from granflow.campaign import Campaign
from granflow.compare import ModelComparison, compare_models
from granflow.creep import CurveFitResult, fit_creep
from granflow.errors import (
    ConvergenceWarning,
    FileFormatError,
    FitError,
    GranflowError,
    InvalidDataError,
    InvalidParameterError,
    InvalidProtocolError,
)
from granflow.fitting import FitResult, fit, fit_many
from granflow.geometry import Annulus
from granflow.io import read, read_runs
from granflow.joint import (
    AmontonsResult,
    CollapseResult,
    JointFitResult,
    PreparationSpread,
    fit_amontons,
    fit_joint,
    preparation_spread,
    velocity_collapse,
)
from granflow.mcmc import PosteriorResult, sample_posterior
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
    "AmontonsResult",
    "AnalysisResult",
    "Annulus",
    "Campaign",
    "CollapseResult",
    "ConvergenceWarning",
    "CurveFitResult",
    "DirectEffect",
    "Event",
    "FileFormatError",
    "FitError",
    "FitResult",
    "Force",
    "ForceRamp",
    "ForceSteps",
    "ForceTable",
    "GranflowError",
    "Hold",
    "InvalidDataError",
    "InvalidParameterError",
    "InvalidProtocolError",
    "JointFitResult",
    "MaterialConstants",
    "ModelComparison",
    "NoPeakError",
    "Params",
    "Peak",
    "PosteriorResult",
    "PreparationSpread",
    "Protocol",
    "Run",
    "SimulationResult",
    "StabilityMap",
    "SwitchToForce",
    "Velocity",
    "VelocitySteps",
    "VelocityTable",
    "__version__",
    "analyze",
    "compare_models",
    "fit",
    "fit_amontons",
    "fit_creep",
    "fit_joint",
    "fit_many",
    "friction_aging",
    "friction_asymptote",
    "friction_slip",
    "friction_slip_jacobian",
    "friction_time",
    "has_peak",
    "initial_force",
    "peak",
    "preparation_spread",
    "read",
    "read_runs",
    "rhs_slip",
    "rhs_time",
    "sample_posterior",
    "scaled_ei",
    "scaled_ei_diff",
    "simulate",
    "stability_map",
    "steady_state",
    "velocity_collapse",
]
