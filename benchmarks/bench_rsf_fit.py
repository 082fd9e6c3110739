"""Rate-and-state fits of velocity steps: coverage over seeds, and speed against PyRSF's way.

Run by hand from the repository root:

    PYTHONPATH=src python benchmarks/bench_rsf_fit.py [--seeds 100] [--speed-only]

1. Coverage: two parameter sets (velocity-weakening, a < b; strengthening, a > b), a step of
   the load point 1 -> 10 µm/s on a spring, Gaussian noise, ``--seeds`` seeds each: the share
   of fits that converge with no initial guess and the share of 95 % intervals of a, b, Dc
   (profile likelihood) that hold the truth.
2. Speed: one velocity-step fit (a, b, Dc, k, mu0 free) by ``granflow.rsf.fit`` with no guess,
   side by side with ``scipy.optimize.curve_fit`` over a ``solve_ivp`` forward model (LSODA,
   rtol 1e-8) started from a good guess (each parameter 10 % off), as PyRSF does.
"""

import argparse
import math
import os
import platform
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import curve_fit

import granflow as gf
from granflow import rsf

V1, V2 = 1e-6, 10e-6
SETS = {
    # mu0, a, b, Dc [m], k [1/m], pre [s], post [s], noise
    "weakening": (0.6, 0.008, 0.012, 20e-6, 2000.0, 40.0, 40.0, 3e-4),
    "strengthening": (0.6, 0.012, 0.007, 50e-6, 1000.0, 40.0, 60.0, 3e-4),
}
DT = 0.1


def synthetic(name, seed):
    """(t, friction, protocol, truth) of one noisy velocity step of set ``name``."""
    mu0, a, b, Dc, k, pre, post, noise = SETS[name]
    model = rsf.RateState(mu0, a, V1, k, [rsf.State(b, Dc, "aging")])
    protocol = gf.Protocol([gf.Velocity(V1, pre), gf.Velocity(V2, post)])
    t = np.arange(0.0, pre + post + 1e-9, DT)
    mu = rsf.simulate(model, protocol, t_eval=t).friction
    mu = mu + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return t, mu, protocol, {"a": a, "b": b, "Dc": Dc}


def coverage(name, seeds):
    converged, covered, elapsed = 0, dict.fromkeys(("a", "b", "Dc"), 0), 0.0
    for seed in range(seeds):
        t, mu, protocol, truth = synthetic(name, seed)
        start = time.perf_counter()
        result = rsf.fit(t, mu, protocol, law="aging")
        elapsed += time.perf_counter() - start
        converged += bool(result.success)
        for key, value in truth.items():
            low, high = result.ci95[key]
            covered[key] += bool(low <= value <= high)
    return converged, covered, elapsed


def rhs(_, y, a, b, Dc, k, v_lp):
    """PyRSF-style spring-slider: y = (mu - mu0, theta); v from the friction law."""
    mu, theta = y
    v = V1 * math.exp((mu - b * math.log(V1 * theta / Dc)) / a)
    return [k * (v_lp - v), 1.0 - v * theta / Dc]


def forward(t, a, b, Dc, k, mu0, pre):
    """Friction at t by solve_ivp, in two pieces (before and after the step)."""
    out = np.empty(t.size)
    y = [0.0, Dc / V1]
    for lo, hi, v in ((0.0, pre, V1), (pre, t[-1], V2)):
        inside = (t >= lo) & (t <= hi) if lo == 0.0 else (t > lo) & (t <= hi)
        solution = solve_ivp(
            rhs,
            (lo, hi),
            y,
            method="LSODA",
            t_eval=t[inside],
            rtol=1e-8,
            atol=1e-12,
            args=(a, b, Dc, k, v),
        )
        out[inside] = solution.y[0]
        y = solution.y[:, -1]
    return out + mu0


def speed(repeats=5):
    name = "weakening"
    mu0, a, b, Dc, k, pre, *_ = SETS[name]
    t, mu, protocol, _ = synthetic(name, 0)
    rsf.fit(t, mu, protocol)  # compile and warm up
    guess = np.array([a, b, Dc, k, mu0]) * np.array([1.1, 0.9, 1.1, 0.9, 1.0])
    ours, wald, theirs = [], [], []
    for _ in range(repeats):
        start = time.perf_counter()
        result = rsf.fit(t, mu, protocol)
        ours.append(time.perf_counter() - start)
        start = time.perf_counter()
        rsf.fit(t, mu, protocol, profile=False)
        wald.append(time.perf_counter() - start)
        start = time.perf_counter()
        popt, _ = curve_fit(
            lambda tt, *p: forward(tt, *p, pre), t, mu, p0=guess, x_scale=guess, method="trf"
        )
        theirs.append(time.perf_counter() - start)
    print(
        f"granflow rsf.fit (no guess, profile intervals): {min(ours):.3f} s;"
        f" a={result.params['a']:.5f} b={result.params['b']:.5f} Dc={result.params['Dc']:.3e}"
    )
    print(
        f"curve_fit + solve_ivp (LSODA) from a good guess: {min(theirs):.3f} s;"
        f" a={popt[0]:.5f} b={popt[1]:.5f} Dc={popt[2]:.3e}"
    )
    print(f"granflow rsf.fit (no guess, Wald intervals as curve_fit): {min(wald):.3f} s")
    print(
        f"ratio: {min(theirs) / min(ours):.1f}x with profile intervals, "
        f"{min(theirs) / min(wald):.1f}x with Wald intervals"
    )


def figure(path):
    """The aging-law fits of the two real records, with residuals, side by side (the data
    from ../shared, or $GRANFLOW_SHARED)."""
    data = os.path.join(os.environ.get("GRANFLOW_SHARED", "../shared"), "data")
    data = os.path.join(data, "rate-state-velocity-steps")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = ("velstep3_TR2_exp013_sepiolite", "velstep4_BRAVA_expb819_basalt")
    fig, axes = plt.subplots(
        2, 2, figsize=(12, 6), sharex="col", gridspec_kw={"height_ratios": [3, 1]}
    )
    for column, name in enumerate(names):
        record = rsf.read_velocity_steps(f"{data}/{name}.txt")
        result = rsf.fit(record, law="aging", correlated_noise=True)
        result.plot(axes=axes[:, column])
        axes[0, column].set_title(f"{name}\n{axes[0, column].get_title()}", fontsize=8)
        print(
            f"{name}: residual RMS {result.residual_rms:.3g} = "
            f"{result.residual_rms / result.noise:.2f} x the scatter; "
            f"a - b = {result.a_minus_b:.4g} +/- {1.96 * result.a_minus_b_stderr:.2g}"
        )
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--speed-only", action="store_true")
    parser.add_argument("--figure", help="also fit the two real records and draw them here (PNG)")
    args = parser.parse_args()
    if args.figure:
        figure(args.figure)
    print(f"{platform.python_version()}, load {os.getloadavg()[0]:.1f}")
    if not args.speed_only:
        for name in SETS:
            converged, covered, elapsed = coverage(name, args.seeds)
            shares = ", ".join(f"{k} {100 * v / args.seeds:.0f} %" for k, v in covered.items())
            print(
                f"{name}: converged {converged}/{args.seeds}; 95 % intervals cover: {shares}; "
                f"{elapsed / args.seeds:.2f} s per fit"
            )
    speed()


if __name__ == "__main__":
    main()
