"""The quasi-static slip of a layer under a held force, found independently of granflow's own
inversion of the rising branch (granflow.forecast.branch): brentq on friction_slip."""

import numpy as np
from scipy.optimize import brentq

import granflow as gf


def branch_slip(force, params):
    """Slip [m] (x - x0) on the rising branch of F(x) under the force held so far, the running
    maximum of ``force`` [N]: 0 below F(x0), else the root of F(x) = force between x0 and the
    peak's slip (brentq, each distinct force solved once)."""
    held = np.maximum.accumulate(np.asarray(force, dtype=float))
    peak_slip = gf.peak(params).slip
    start = gf.friction_slip(params.x0, params)
    slips = {
        s: 0.0
        if s <= start
        else brentq(lambda z, s=s: gf.friction_slip(z, params) - s, params.x0, peak_slip)
        - params.x0
        for s in np.unique(held)
    }
    return np.array([slips[s] for s in held])
