"""The compiled equations of every ODE granflow integrates, for :mod:`~granflow.simulation.ode`.

Each system is a ``kind`` (an int) with a parameter vector ``p`` (float64) and a state ``y``;
:func:`rhs`, :func:`jacobian` and :func:`events` dispatch on the kind, so that the one compiled
integrator serves every system and stays cached on disk (a function passed as an argument
would make Numba compile the integrator again in every process).

``SLIDE`` and ``STUCK``: the dynamic aging-rejuvenation slider (SPEC §2), ``y = (x, v, F, s)``
(aging coordinate [m], velocity [m/s], friction state [N], spring extension [m]) over one
linear piece of the drive, sliding (``m dv/dt = drive - friction - c v``) or stuck (v = 0).
Its events: failure (v rises through v_fail), stop (v falls through v_stop) and unstick (the
drive's force exceeds the strength ``F + c v_stop``).

``RATE_STATE``: the rate-and-state spring-slider, ``y = (mu - mu0, theta_1 .. theta_n, slip)``
(the friction measured from mu0, so that its tolerance is on the scale of a), over
one linear piece of the load-point velocity; its event: a friction peak (v falls through the
load-point velocity).
"""

import math

import numba

__all__ = [
    "EVENTS",
    "LAWS",
    "RATE_STATE",
    "SLIDE",
    "SLIDER_PARAMETERS",
    "STUCK",
    "compiled",
    "events",
    "jacobian",
    "rhs",
    "rsf_velocity",
]

#: Compile options of every integrator loop: cached on disk, plain IEEE arithmetic (no fused
#: operations, so that a result does not depend on how a loop was vectorised).
compiled = numba.njit(cache=True, error_model="numpy", nogil=True)

SLIDE, STUCK, RATE_STATE = 0, 1, 2
#: Event functions per system (unused slots are inactive).
EVENTS = 3
#: The rate-and-state laws by name, with their code in the parameter vector.
LAWS = {"aging": 0, "slip": 1, "prz": 2, "nagata": 3}

# -- the slider's parameter vector
A, ALPHA, FD, MASS, DAMPING, STIFFNESS, RATE, TIME_CLOCK = 0, 1, 2, 3, 4, 5, 6, 7
TAU_SHIFT, T_START, START, SLOPE, AMPLITUDE, V_REF, V_FAIL, V_STOP = 8, 9, 10, 11, 12, 13, 14, 15
#: Length of the slider's parameter vector.
SLIDER_PARAMETERS = 16

# -- the rate-and-state parameter vector: 9 numbers, then (b, Dc, law, c) per state
MU0, RSF_A, RSF_V_REF, RSF_K, ETA, RSF_T_START, RSF_START, RSF_SLOPE, N_STATES = range(9)
STATE_BASE = 9


# ---------------------------------------------------------------- the direct effect


@compiled
def _direct(amplitude, v_ref, v, F):
    """A asinh(v / (2 v_ref) exp(F/A)) without overflow, and its derivatives d/dv, d/dF."""
    log_scale = F / amplitude - math.log(2.0 * v_ref)
    if v <= 0.0:
        return 0.0, amplitude * math.exp(min(log_scale, 700.0)), 0.0
    log_q = math.log(v) + log_scale
    if log_q > 0.0:
        value = amplitude * (log_q + math.log1p(math.sqrt(1.0 + math.exp(-2.0 * log_q))))
        share = 1.0 / math.sqrt(1.0 + math.exp(-2.0 * log_q))
    else:
        q = math.exp(log_q)
        value = amplitude * math.asinh(q)
        share = q / math.sqrt(1.0 + q * q)
    return value, amplitude * share / v, share


# ---------------------------------------------------------------- the slider


@compiled
def slider_drive_force(t, y, p):
    """The force the drive exerts [N]: K s through the spring, else the imposed force."""
    if p[RATE] != 0.0:
        return p[STIFFNESS] * y[3]
    return p[START] + p[SLOPE] * (t - p[T_START])


@compiled
def _slider_rhs(t, y, p, sliding, out):
    rate = p[RATE] != 0.0
    drive_velocity = p[START] + p[SLOPE] * (t - p[T_START]) if rate else 0.0
    out[0] = 0.0
    out[1] = 0.0
    out[3] = drive_velocity if rate else 0.0
    if not sliding:
        out[2] = p[A] / (t + p[TAU_SHIFT]) if p[TIME_CLOCK] != 0.0 else 0.0
        return
    x, v, F = y[0], y[1], y[2]
    if p[TIME_CLOCK] != 0.0:
        out[2] = p[A] / (t + p[TAU_SHIFT]) - p[ALPHA] * v * (F - p[FD])
    else:
        out[2] = v * (p[A] / x - p[ALPHA] * (F - p[FD]))
    friction = F if p[AMPLITUDE] == 0.0 else _direct(p[AMPLITUDE], p[V_REF], v, F)[0]
    out[0] = v
    out[1] = (slider_drive_force(t, y, p) - friction - p[DAMPING] * v) / p[MASS]
    out[3] = drive_velocity - v if rate else 0.0


@compiled
def _slider_jacobian(t, y, p, sliding, jac, dt):
    rate = p[RATE] != 0.0
    jac[:, :] = 0.0
    time_clock = p[TIME_CLOCK] != 0.0
    dt[0] = 0.0
    dt[1] = 0.0 if rate else p[SLOPE] / p[MASS]
    dt[2] = -p[A] / (t + p[TAU_SHIFT]) ** 2 if time_clock else 0.0
    dt[3] = p[SLOPE] if rate else 0.0
    if not sliding:
        dt[1] = 0.0
        return
    x, v, F = y[0], y[1], y[2]
    if p[AMPLITUDE] == 0.0:
        d_friction_dv, d_friction_dF = 0.0, 1.0
    else:
        _, d_friction_dv, d_friction_dF = _direct(p[AMPLITUDE], p[V_REF], v, F)
    m = p[MASS]
    jac[0, 1] = 1.0
    jac[1, 1] = -(d_friction_dv + p[DAMPING]) / m
    jac[1, 2] = -d_friction_dF / m
    if rate:
        jac[1, 3] = p[STIFFNESS] / m
        jac[3, 1] = -1.0
    if time_clock:
        jac[2, 1] = -p[ALPHA] * (F - p[FD])
    else:
        jac[2, 0] = -v * p[A] / (x * x)
        jac[2, 1] = p[A] / x - p[ALPHA] * (F - p[FD])
    jac[2, 2] = -p[ALPHA] * v


@compiled
def _slider_events(t, y, p, g):
    g[0] = y[1] - p[V_FAIL]
    g[1] = y[1] - p[V_STOP]
    g[2] = slider_drive_force(t, y, p) - y[2] - p[DAMPING] * p[V_STOP]


# ---------------------------------------------------------------- rate and state


@compiled
def _load_point_velocity(t, p):
    return p[RSF_START] + p[RSF_SLOPE] * (t - p[RSF_T_START])


@compiled
def _state_scale(p, i):
    """Dc, or 2 Dc for the PRZ law (its friction term is b ln(v_ref theta / (2 Dc)))."""
    base = STATE_BASE + 4 * i
    return 2.0 * p[base + 1] if p[base + 2] == 2.0 else p[base + 1]


@compiled
def rsf_velocity(t, y, p):
    """The slider's velocity [m/s] and dv/dmu (0 for a rigid load point).

    Solves ``a ln(v / v_ref) + eta v = mu - mu0 - sum b_i ln(v_ref theta_i / Dc_i)`` (Newton
    on ln v, monotone since the left side is convex and increasing in ln v).
    """
    if p[RSF_K] == 0.0:
        return _load_point_velocity(t, p), 0.0
    a, v_ref, eta = p[RSF_A], p[RSF_V_REF], p[ETA]
    rest = y[0]
    for i in range(int(p[N_STATES])):
        rest -= p[STATE_BASE + 4 * i] * math.log(v_ref * y[1 + i] / _state_scale(p, i))
    log_v = math.log(v_ref) + rest / a
    if eta > 0.0:
        target = rest + a * math.log(v_ref)
        log_v = min(log_v, math.log(max(rest, a) / eta))  # start right of the root
        for _ in range(100):
            v = math.exp(log_v)
            step = (a * log_v + eta * v - target) / (a + eta * v)
            log_v -= step
            if abs(step) <= 1e-15 * max(1.0, abs(log_v)):
                break
    v = math.exp(log_v)
    return v, 1.0 / (a / v + eta)


@compiled
def _law(code, v, theta, Dc, c_over_b, mu_rate, k):
    """d theta/dt of one state, and its derivatives d/dv and d/dtheta at fixed mu_rate."""
    if code == 0.0:  # aging
        return 1.0 - v * theta / Dc, -theta / Dc, -v / Dc
    if code == 1.0:  # slip
        z = v * theta / Dc
        slope = -(math.log(z) + 1.0)
        return -z * math.log(z), slope * theta / Dc, slope * v / Dc
    if code == 2.0:  # prz
        z = v * theta / (2.0 * Dc)
        return 1.0 - z * z, -z * theta / Dc, -z * v / Dc
    # nagata: the friction rate mu_rate = k (v_lp - v) enters through c / b
    value = 1.0 - v * theta / Dc - c_over_b * theta * mu_rate
    return value, -theta / Dc + c_over_b * theta * k, -v / Dc - c_over_b * mu_rate


@compiled
def _rsf_rhs(t, y, p, out):
    n = int(p[N_STATES])
    v, _ = rsf_velocity(t, y, p)
    k = p[RSF_K]
    mu_rate = k * (_load_point_velocity(t, p) - v)
    out[0] = mu_rate
    for i in range(n):
        base = STATE_BASE + 4 * i
        c_over_b = p[base + 3] / p[base]
        out[1 + i] = _law(p[base + 2], v, y[1 + i], p[base + 1], c_over_b, mu_rate, k)[0]
    out[n + 1] = v


@compiled
def _rsf_jacobian(t, y, p, jac, dt):
    n = int(p[N_STATES])
    jac[:, :] = 0.0
    v, dv_dmu = rsf_velocity(t, y, p)
    k = p[RSF_K]
    slope = p[RSF_SLOPE]
    rigid = k == 0.0
    mu_rate = k * (_load_point_velocity(t, p) - v)
    # dv/dy_j: mu, then each theta
    jac[0, 0] = -k * dv_dmu
    jac[n + 1, 0] = dv_dmu
    dt[0] = k * slope
    dt[n + 1] = slope if rigid else 0.0
    for j in range(0 if rigid else n):
        dv = dv_dmu * p[STATE_BASE + 4 * j] / y[1 + j]
        jac[0, 1 + j] = k * dv
        jac[n + 1, 1 + j] = -dv
    for i in range(n):
        base = STATE_BASE + 4 * i
        c_over_b = p[base + 3] / p[base]
        # law_v includes the friction rate's dependence on v (nagata); mu_rate depends on
        # mu and theta through v only, and on t through the load point (d/dt = k slope)
        _, law_v, law_theta = _law(p[base + 2], v, y[1 + i], p[base + 1], c_over_b, mu_rate, k)
        jac[1 + i, 0] = law_v * dv_dmu
        for j in range(n):
            jac[1 + i, 1 + j] = law_v * jac[n + 1, 1 + j]
        jac[1 + i, 1 + i] += law_theta
        through_rate = -c_over_b * y[1 + i] * k * slope if p[base + 2] == 3.0 else 0.0
        dt[1 + i] = (law_v * slope if rigid else 0.0) + through_rate


@compiled
def _rsf_events(t, y, p, g):
    v, _ = rsf_velocity(t, y, p)
    g[0] = _load_point_velocity(t, p) - v
    g[1] = 0.0
    g[2] = 0.0


# ---------------------------------------------------------------- dispatch


@compiled
def rhs(kind, t, y, p, out):
    """dy/dt of system ``kind`` into ``out``."""
    if kind == RATE_STATE:
        _rsf_rhs(t, y, p, out)
    else:
        _slider_rhs(t, y, p, kind == SLIDE, out)


@compiled
def jacobian(kind, t, y, p, jac, dt):
    """d(dy/dt)/dy into ``jac`` and d(dy/dt)/dt into ``dt``."""
    if kind == RATE_STATE:
        _rsf_jacobian(t, y, p, jac, dt)
    else:
        _slider_jacobian(t, y, p, kind == SLIDE, jac, dt)


@compiled
def events(kind, t, y, p, g):
    """The :data:`EVENTS` event functions of system ``kind`` into ``g``."""
    if kind == RATE_STATE:
        _rsf_events(t, y, p, g)
    else:
        _slider_events(t, y, p, g)
