"""Simulation timings against the naive way, side by side in one run.

The naive way integrates the same equations with ``scipy.integrate.solve_ivp`` (LSODA,
rtol 1e-9): m dv/dt = sigma(t) - F - c v while sliding, dx/dt = v,
dF/dt = v (a/x - alpha (F - Fd)), with sticking handled inside the right-hand side (v = 0 and
sigma <= F: nothing moves), and a terminal event at v_fail. granflow's quasi-static method
needs no integration at all (closed form and root finding); its dynamic method runs on the
compiled integrator (granflow.simulation.ode), once with its default light damping and once
undamped. The rate-and-state benchmark is a 20-step velocity sequence, against solve_ivp
(LSODA, the same rtol) on the same equations, piece by piece. The first call of each compiled
path is made before timing (Numba loads it from its disk cache).

Run by hand from the repository root: ``python benchmarks/bench_simulate.py``; record the
figures in benchmarks/README.md.
"""

import os
import platform
import time

import numpy as np
from scipy.integrate import solve_ivp

import granflow as gf
from granflow import rsf
from granflow.simulation.options import DEFAULT_DAMPING, DEFAULT_MASS

V = 0.86e-6
RAMP_RATE = 0.05e-3
PARAMS = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=V)


def best_time(function, repeats):
    """Best wall time [s] of ``repeats`` calls, and the last result."""
    best, result = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def naive(sigma, t_start, t_end, x, v, F, v_fail, damping=0.0):
    """solve_ivp on the inertial equations, sticking decided in the right-hand side."""
    p = PARAMS
    m = DEFAULT_MASS

    def rhs(t, y):
        x, v, F = y
        drive = sigma(t)
        if v <= 0 and drive <= F:
            return [0.0, 0.0, 0.0]
        return [v, (drive - F - damping * v) / m, v * (p.a / x - p.alpha * (F - p.Fd))]

    def failure(t, y):
        return y[1] - v_fail

    failure.terminal, failure.direction = True, 1
    # absolute tolerances on the scales of the problem (solve_ivp's default, 1e-6, would
    # accept errors larger than the slips and forces themselves)
    atol = [1e-9 * p.x0, 1e-12 * V, 1e-12 * p.Fd]
    solution = solve_ivp(
        rhs, (t_start, t_end), [x, v, F], method="LSODA", rtol=1e-9, atol=atol, events=failure
    )
    return solution.t_events[0][0] if solution.t_events[0].size else None


def bench_ramp(repeats):
    protocol = gf.Protocol([gf.ForceRamp(rate=RAMP_RATE, duration=400.0)])
    quasi, q = best_time(lambda: gf.simulate(PARAMS, protocol), repeats)
    print("stress ramp 0.05 mN/s to failure (blue set, Fd = 10 mN)")
    print(
        f"  granflow quasi-static     {quasi * 1e3:10.3f} ms   fails at t = {q.failure.time:.4f} s"
    )
    for label, damping in (("damped", DEFAULT_DAMPING), ("c = 0", 0.0)):
        dyn, d = best_time(
            lambda damping=damping: gf.simulate(
                PARAMS, protocol, method="dynamic", damping=damping
            ),
            repeats,
        )
        slow, t_fail = best_time(
            lambda damping=damping: naive(
                lambda t: RAMP_RATE * t,
                0.0,
                400.0,
                PARAMS.x0,
                0.0,
                gf.initial_force(PARAMS),
                1e-3,
                damping,
            ),
            1,
        )
        print(f"  naive LSODA, {label:<7}     {slow * 1e3:10.1f} ms   fails at t = {t_fail:.4f}")
        print(
            f"  granflow dynamic, {label:<7}{dyn * 1e3:10.2f} ms   fails at t = "
            f"{d.failure.time:.4f}   ({slow / dyn:,.0f}x faster)"
        )


def bench_switch(switch_time, repeats):
    protocol = gf.Protocol([gf.Velocity(V, switch_time), gf.SwitchToForce(60.0, factor=1.01)])
    quasi, q = best_time(lambda: gf.simulate(PARAMS, protocol), repeats)
    dyn, _ = best_time(lambda: gf.simulate(PARAMS, protocol, method="dynamic"), repeats)
    x = V * switch_time  # the one clock: slip V t since shearing started
    F = gf.friction_slip(x, PARAMS)
    slow, _ = best_time(
        lambda: naive(lambda t: 1.01 * F, switch_time, switch_time + 60.0, x, V, F, 1000 * V), 1
    )
    outcome = "fails" if q.failed else "stops"
    print(f"switch to 1.01 x the force at t = {switch_time:g} s ({outcome})")
    print(f"  naive solve_ivp LSODA     {slow * 1e3:10.1f} ms")
    print(f"  granflow quasi-static     {quasi * 1e3:10.3f} ms   ({slow / quasi:,.0f}x faster)")
    print(f"  granflow dynamic          {dyn * 1e3:10.3f} ms   ({slow / dyn:,.1f}x faster)")


def bench_map(jobs, method="quasistatic"):
    points = np.linspace(1.0, 100.0, 100)
    ratios = np.linspace(0.9, 1.2, 100)
    elapsed, smap = best_time(
        lambda: gf.stability_map(PARAMS, points, ratios, velocity=V, jobs=jobs, method=method), 1
    )
    print(f"100 x 100 stability map, {method}, jobs={jobs}")
    print(
        f"  end to end                {elapsed:10.2f} s    "
        f"({int(smap.failed.sum())} failures, {int(smap.stopped.sum())} stops, "
        f"{int((smap.outcome == 'error').sum())} errors)"
    )


RSF_MODEL = rsf.RateState(0.6, 0.005, 1e-6, 3e3, [rsf.State(0.01, 10e-6, "aging")])
RSF_VELOCITIES = [1e-6, 10e-6] * 10


def naive_rsf(step_duration, rtol):
    """solve_ivp (LSODA) on mu, theta of the aging law, one velocity after the other."""
    model = RSF_MODEL
    state = model.states[0]
    a, b, Dc, v_ref, k = model.a, state.b, state.Dc, model.v_ref, model.stiffness
    v0 = RSF_VELOCITIES[0]
    y = np.array([model.steady_state_friction(v0), Dc / v0])
    friction = []
    for index, v_lp in enumerate(RSF_VELOCITIES):

        def rhs(t, y, v_lp=v_lp):
            v = v_ref * np.exp((y[0] - model.mu0 - b * np.log(v_ref * y[1] / Dc)) / a)
            return [k * (v_lp - v), 1.0 - v * y[1] / Dc]

        start = index * step_duration
        sol = solve_ivp(
            rhs,
            (start, start + step_duration),
            y,
            method="LSODA",
            rtol=rtol,
            atol=[1e-3 * rtol * a, 1e-3 * rtol * Dc / 10e-6],
            t_eval=np.linspace(start, start + step_duration, 201),
        )
        y = sol.y[:, -1]
        friction.append(sol.y[0])
    return np.concatenate(friction)


def bench_rsf(repeats):
    step_duration, rtol = 20.0, 1e-10
    protocol = gf.Protocol([gf.VelocitySteps(RSF_VELOCITIES, step_duration)])
    slow, friction = best_time(lambda: naive_rsf(step_duration, rtol), 3)
    print("rate-and-state, 20 velocity steps 1 <-> 10 um/s, aging law, rtol 1e-10")
    print(f"  naive solve_ivp LSODA     {slow * 1e3:10.2f} ms   final mu = {friction[-1]:.10f}")
    for method in ("rodas4", "dop853"):
        fast, result = best_time(
            lambda method=method: rsf.simulate(RSF_MODEL, protocol, rtol=rtol, method=method),
            repeats,
        )
        print(
            f"  granflow rsf, {method:<11} {fast * 1e3:10.2f} ms   final mu = "
            f"{result.friction[-1]:.10f}   ({slow / fast:,.0f}x faster)"
        )


def main():
    print(f"granflow {gf.__version__}, Python {platform.python_version()}, {os.cpu_count()} cores")
    gf.simulate(PARAMS, [gf.Velocity(V, 10.0), gf.SwitchToForce(1.0, factor=1.01)])  # warm up
    bench_ramp(repeats=20)
    bench_switch(80.0, repeats=20)
    bench_switch(10.0, repeats=20)
    for method in ("rodas4", "dop853"):  # warm up
        rsf.simulate(RSF_MODEL, [gf.Velocity(1e-6, 1.0)], method=method)
    bench_rsf(repeats=20)
    bench_map(jobs=2)
    bench_map(jobs=2, method="dynamic")


if __name__ == "__main__":
    main()
