"""An independent rate-and-state spring-slider for the tests: scipy's Radau on the equations
written out by hand (friction and the logarithms of the states as unknowns), piece by piece
of a piecewise-constant load-point velocity. Nothing of granflow's is used.

``dmu/dt = k (v_lp - v)``, ``mu = mu0 + a ln(v / v0) + sum_i b_i ln(v0 theta_i / L_i)`` with
``L_i = Dc_i`` (``2 Dc_i`` for prz) solved for v; aging ``dtheta/dt = 1 - v theta / Dc``, slip
``dtheta/dt = -(v theta / Dc) ln(v theta / Dc)``, prz ``dtheta/dt = 1 - (v theta / (2 Dc))^2``.
"""

import math

import numpy as np
from scipy.integrate import solve_ivp


def slider_friction(mu0, a, v0, k, states, segments, t, rtol=1e-10, v_start=None):
    """Friction [-] at the times ``t`` [s] (from 0), the slider starting in steady sliding at
    ``v_start`` (default the first segment's velocity; the friction there is the steady one).

    ``states``: (b, Dc [m], law) per state; ``segments``: (velocity [m/s], duration [s]).
    """
    laws = [law for _, _, law in states]
    b = [float(s[0]) for s in states]
    Dc = [float(s[1]) for s in states]
    L = [(2.0 if law == "prz" else 1.0) * dc for dc, law in zip(Dc, laws, strict=True)]
    v_start = segments[0][0] if v_start is None else v_start
    log_theta = [math.log(length / v_start) for length in L]
    # friction at steady sliding at v_start: the state terms are b_i ln(v0 / v_start)
    mu = mu0 + (a - sum(b)) * math.log(v_start / v0)
    # mu - mu0 - sum b_i ln(v0 theta_i / L_i) = a ln(v / v0), with ln theta_i as unknowns
    offset = mu0 + sum(b_i * (math.log(v0) - math.log(l_i)) for b_i, l_i in zip(b, L, strict=True))
    pairs = list(enumerate(zip(laws, b, Dc, strict=True), start=1))

    def rhs(_, y, v_lp):
        state_terms = sum(b_i * y[i] for i, (_, b_i, _) in pairs)
        v = v0 * math.exp((y[0] - offset - state_terms) / a)
        out = [k * (v_lp - v)]
        for i, (law, _, dc) in pairs:
            theta = math.exp(y[i])
            if law == "aging":
                out.append(1.0 / theta - v / dc)
            elif law == "slip":
                out.append(-(v / dc) * math.log(v * theta / dc))
            else:
                out.append(1.0 / theta - (v / (2.0 * dc)) ** 2 * theta)
        return out

    t = np.asarray(t, dtype=float)
    result = np.full(t.size, np.nan)
    y = np.array([mu, *log_theta])
    start = 0.0
    for velocity, duration in segments:
        stop = start + duration
        sol = solve_ivp(
            rhs,
            (start, stop),
            y,
            method="Radau",
            rtol=rtol,
            atol=1e-2 * rtol,
            args=(velocity,),
            dense_output=True,
        )
        if not sol.success:
            raise RuntimeError(sol.message)
        inside = (t >= start) & (t <= stop)
        if np.any(inside):
            result[inside] = sol.sol(t[inside])[0]
        y = sol.y[:, -1]
        start = stop
    return result
