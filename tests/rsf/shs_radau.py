"""A small slide-hold-slide record for the tests, from an independent solver (not granflow's).

scipy's Radau on the spring-slider, written from the equations alone (a copy of the
generator ``tools/slide_hold_slide_synthetic.py``, smaller: five holds):

    dmu/dt = k (v_lp - v),   mu = mu0 + a ln(v / v0) + b ln(v0 theta / Dc)
    aging: dtheta/dt = 1 - v theta / Dc;   slip: dtheta/dt = -(v theta / Dc) ln(v theta / Dc)
"""

import functools
import math

import numpy as np
from scipy.integrate import solve_ivp

#: mu0, a, b, Dc [m], k [1/m], v0 = the sliding velocity [m/s].
TRUTH = {"mu0": 0.6, "a": 0.01, "b": 0.015, "Dc": 5e-6, "k": 3e3, "v0": 10e-6}
HOLDS = (1.0, 3.0, 10.0, 30.0, 100.0)
SLIDE = 150e-6  # 30 Dc: back to steady sliding after every peak
RATE = 10.0  # samples per second


@functools.cache
def record(law="aging", holds=HOLDS):
    """(t [s], load point [m], friction [-], hold starts [s]) without noise (computed once
    per law and holds, then shared)."""
    p = TRUTH

    a, b, dc, k = p["a"], p["b"], p["Dc"], p["k"]

    def slip_rate(y):
        return p["v0"] * math.exp(
            (y[0] - p["mu0"] - b * math.log(p["v0"] * math.exp(y[1]) / dc)) / a
        )

    def rhs(_t, y, v_lp):
        v, theta = slip_rate(y), math.exp(y[1])
        omega = v * theta / dc
        dpsi = (1.0 - omega) / theta if law == "aging" else -(v / dc) * math.log(omega)
        return [k * (v_lp - v), dpsi]

    def jac(_t, y, _v_lp):  # by hand: dv/dmu = v/a, dv/dpsi = -(b/a) v
        v, theta = slip_rate(y), math.exp(y[1])
        if law == "aging":
            row = [-v / (a * dc), -1.0 / theta + b * v / (a * dc)]
        else:
            log_omega = math.log(v * theta / dc)
            row = [-v / (a * dc) * (log_omega + 1.0), -(v / dc) * (1.0 - b / a - b / a * log_omega)]
        return [[-k * v / a, k * b * v / a], row]

    v = p["v0"]
    y = np.array([p["mu0"], math.log(p["Dc"] / v)])
    pieces = [(v, SLIDE / v)]
    for hold in holds:
        pieces += [(0.0, hold), (v, SLIDE / v)]
    t, x, mu, starts, clock, position = [0.0], [0.0], [y[0]], [], 0.0, 0.0
    for v_lp, duration in pieces:
        if v_lp == 0.0:
            starts.append(clock)
        local = np.linspace(0.0, duration, round(duration * RATE) + 1)[1:]
        sol = solve_ivp(
            rhs,
            (0.0, duration),
            y,
            method="Radau",
            t_eval=local,
            args=(v_lp,),
            jac=jac,
            rtol=1e-8,
            atol=[1e-11, 1e-8],
        )
        assert sol.success, sol.message
        t.extend(clock + sol.t)
        x.extend(position + v_lp * sol.t)
        mu.extend(sol.y[0])
        y = sol.y[:, -1]
        clock += duration
        position += v_lp * duration
    return np.array(t), np.array(x), np.array(mu), np.array(starts)


def table(t, x, mu, offset=500.0):
    """The reader's format: ``Time(s)``, ``Displ(microns)``, ``Friction``, tab-separated."""
    rows = "".join(
        f"{offset + a:.6f}\t{b * 1e6:.6f}\t{c:.8f}\n" for a, b, c in zip(t, x, mu, strict=True)
    )
    return "Time(s)\tDispl(microns)\tFriction\n" + rows
