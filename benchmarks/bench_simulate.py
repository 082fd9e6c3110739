"""Simulation timings against the naive way, side by side in one run.

The naive way integrates the same equations with ``scipy.integrate.solve_ivp`` (LSODA,
rtol 1e-9): m dv/dt = sigma(t) - F while sliding, dx/dt = v, dF/dt = v (a/x - alpha (F - Fd)),
with sticking handled inside the right-hand side (v = 0 and sigma <= F: nothing moves), and a
terminal event at v_fail. granflow's quasi-static method needs no integration at all (closed
form and root finding); its dynamic method integrates with events, once with its default
light damping and once undamped, as the naive equations are.

Run by hand from the repository root: ``python benchmarks/bench_simulate.py``; record the
figures in benchmarks/README.md.
"""

import os
import platform
import time

import numpy as np
from scipy.integrate import solve_ivp

import granflow as gf
from granflow.simulation.options import DEFAULT_MASS

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


def naive(sigma, t_start, t_end, x, v, F, v_fail):
    """solve_ivp on the inertial equations, sticking decided in the right-hand side."""
    p = PARAMS
    m = DEFAULT_MASS

    def rhs(t, y):
        x, v, F = y
        drive = sigma(t)
        if v <= 0 and drive <= F:
            return [0.0, 0.0, 0.0]
        return [v, (drive - F) / m, v * (p.a / x - p.alpha * (F - p.Fd))]

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
    # a busy machine must not abort the slow undamped run at the default max_wall (60 s)
    unbounded = {"method": "dynamic", "max_wall": 3600.0}
    dyn, d = best_time(lambda: gf.simulate(PARAMS, protocol, **unbounded), 1)
    bare, b = best_time(lambda: gf.simulate(PARAMS, protocol, damping=0.0, **unbounded), 1)
    slow, t_fail = best_time(
        lambda: naive(
            lambda t: RAMP_RATE * t, 0.0, 400.0, PARAMS.x0, 0.0, gf.initial_force(PARAMS), 1e-3
        ),
        1,
    )
    print("stress ramp 0.05 mN/s to failure (blue set, Fd = 10 mN)")
    print(f"  naive solve_ivp LSODA     {slow * 1e3:10.1f} ms   fails at t = {t_fail:.4f} s")
    print(
        f"  granflow quasi-static     {quasi * 1e3:10.3f} ms   fails at t = "
        f"{q.failure.time:.4f} s   ({slow / quasi:,.0f}x faster)"
    )
    print(
        f"  granflow dynamic          {dyn * 1e3:10.1f} ms   fails at t = "
        f"{d.failure.time:.4f} s   ({slow / dyn:,.1f}x faster)"
    )
    print(
        f"  granflow dynamic, c = 0   {bare * 1e3:10.1f} ms   fails at t = "
        f"{b.failure.time:.4f} s   ({slow / bare:,.1f}x faster)"
    )


def bench_switch(switch_time, repeats):
    protocol = gf.Protocol([gf.Velocity(V, switch_time), gf.SwitchToForce(60.0, factor=1.01)])
    quasi, q = best_time(lambda: gf.simulate(PARAMS, protocol), repeats)
    dyn, _ = best_time(lambda: gf.simulate(PARAMS, protocol, method="dynamic"), repeats)
    x = PARAMS.x0 + V * switch_time
    F = gf.friction_slip(x, PARAMS)
    slow, _ = best_time(
        lambda: naive(lambda t: 1.01 * F, switch_time, switch_time + 60.0, x, V, F, 1000 * V), 1
    )
    outcome = "fails" if q.failed else "stops"
    print(f"switch to 1.01 x the force at t = {switch_time:g} s ({outcome})")
    print(f"  naive solve_ivp LSODA     {slow * 1e3:10.1f} ms")
    print(f"  granflow quasi-static     {quasi * 1e3:10.3f} ms   ({slow / quasi:,.0f}x faster)")
    print(f"  granflow dynamic          {dyn * 1e3:10.3f} ms   ({slow / dyn:,.1f}x faster)")


def bench_map(jobs):
    points = np.linspace(1.0, 100.0, 100)
    ratios = np.linspace(0.9, 1.2, 100)
    elapsed, smap = best_time(
        lambda: gf.stability_map(PARAMS, points, ratios, velocity=V, jobs=jobs), 1
    )
    print(f"100 x 100 stability map, quasi-static, jobs={jobs}")
    print(
        f"  end to end                {elapsed:10.2f} s    "
        f"({int(smap.failed.sum())} failures, {int(smap.stopped.sum())} stops)"
    )


def main():
    print(f"granflow {gf.__version__}, Python {platform.python_version()}, {os.cpu_count()} cores")
    gf.simulate(PARAMS, [gf.Velocity(V, 10.0), gf.SwitchToForce(1.0, factor=1.01)])  # warm up
    bench_ramp(repeats=20)
    bench_switch(80.0, repeats=20)
    bench_switch(10.0, repeats=20)
    bench_map(jobs=2)


if __name__ == "__main__":
    main()
