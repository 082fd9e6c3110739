"""The ground floor: the model of Farain & Bonn and the quantities it is written in.

``params`` (Params, MaterialConstants), ``special`` (the scaled exponential-integral kernel
and its mpmath-generated tables), ``friction`` (Eq. 3 in slip and time, its Jacobian, the
peak, limits and right-hand sides), ``geometry`` (the annular contact), ``units`` (the one
unit table), ``run`` (a record of force against time and slip, measured or simulated) and
``segments`` and ``protocol`` (an experiment's imposed history, which the readers and the
simulator share; re-exported by :mod:`granflow.simulation`).
Nothing here imports from the rest of granflow.
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "params": ["MaterialConstants", "Params"],
        "special": ["scaled_ei", "scaled_ei_diff"],
        "friction": [
            "NoPeakError",
            "Peak",
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
            "steady_state",
        ],
        "geometry": ["Annulus"],
        "run": ["Run"],
        "units": ["parse_quantity", "to_si"],
    },
)
