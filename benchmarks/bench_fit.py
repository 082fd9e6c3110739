"""Fitting speed: granflow.fit (no initial guess) against scipy's curve_fit on Eq. 3 with expi.

Run by hand from the repository root:

    PYTHONPATH=src python benchmarks/bench_fit.py [--batch 1000] [--jobs 2]

1. 4000-point curves (the paper's blue set, Fd = 10 mN) at 0.05 and 0.1 mN noise, 20 noise
   seeds each: granflow.fit with no initial guess (profile-likelihood intervals included,
   and without them), side by side with ``scipy.optimize.curve_fit`` on Eq. 3 written with
   ``scipy.special.expi`` and started from a good guess (each parameter 10 % off the truth).
   The three methods run in turn within every repeat (the machine is shared); each curve
   counts with the minimum of its repeats, and the table gives the median over the curves.
2. A batch of 1000 such curves (different seeds) fitted with granflow.fit_many over 2 processes.
"""

import argparse
import math
import os
import platform
import statistics
import time
import warnings

import numpy as np
from scipy.optimize import curve_fit
from scipy.special import expi

import granflow

VELOCITY = 0.86e-6
TRUTH = granflow.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=VELOCITY)


def curve(seed, points=4000, noise=0.05e-3):
    t = np.linspace(TRUTH.t0(VELOCITY), 600.0, points)
    force = granflow.friction_time(t, TRUTH, VELOCITY)
    return t, force + np.random.default_rng(seed).normal(0, noise, points)


def eq3_expi(t, a, k, Fd, t0):
    """Eq. 3 as a user would write it: a e^{-kt} [Ei(kt) - Ei(k t0)] + Fd (1 - e^{-kt})."""
    return a * np.exp(-k * t) * (expi(k * t) - expi(k * t0)) + Fd * (1 - np.exp(-k * t))


def single(repeats, seeds=20):
    """Median over ``seeds`` noisy curves of each method's minimum over ``repeats`` runs,
    the methods interleaved, at 0.05 and 0.1 mN noise."""
    truth = np.array([3.31e-3, 0.036, 10e-3, 0.23])
    guess = truth * np.array([1.1, 0.9, 1.1, 0.9])
    granflow.fit(curve(0), domain="time")  # compile and warm up

    def baseline(t, force):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            popt, _ = curve_fit(eq3_expi, t, force, p0=guess, maxfev=20000)
        return popt

    methods = {
        "granflow.fit, no guess, profile intervals": lambda c: granflow.fit(c, domain="time"),
        "granflow.fit, no guess, Wald intervals": lambda c: granflow.fit(
            c, domain="time", profile=False
        ),
        "curve_fit + expi, good guess": lambda c: baseline(*c),
    }
    clocks = {"wall": time.perf_counter, "cpu": time.process_time}
    for noise in (0.05e-3, 0.1e-3):
        times = {(name, clock): [] for name in methods for clock in clocks}
        for seed in range(seeds):
            data = curve(seed, noise=noise)
            best = dict.fromkeys(times, math.inf)
            for _ in range(repeats):
                for name, method in methods.items():
                    wall, cpu = time.perf_counter(), time.process_time()
                    method(data)
                    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
                    best[name, "wall"] = min(best[name, "wall"], wall)
                    best[name, "cpu"] = min(best[name, "cpu"], cpu)
            for key, seconds in best.items():
                times[key].append(seconds)
        print(
            f"one 4000-point fit at {noise * 1e3:g} mN noise, median over {seeds} curves of "
            f"the minimum of {repeats} interleaved runs (load average {os.getloadavg()[0]:.1f}); "
            "wall clock, and CPU time of the process (fairer on a loaded machine, where a long "
            "run is preempted more often than a short one):"
        )
        for clock in clocks:
            floor = statistics.median(times["curve_fit + expi, good guess", clock])
            for name in methods:
                median = statistics.median(times[name, clock])
                print(
                    f"  {clock:4s} {name:42s} {median * 1e3:7.2f} ms  "
                    f"{floor / median:5.1f}x curve_fit"
                )
    full = granflow.fit(curve(1), domain="time")
    popt = baseline(*curve(1))
    print(
        "  agreement (seed 1): k {:.6g} vs {:.6g}, t0 {:.6g} vs {:.6g}".format(
            full.params["k"], popt[1], full.params["t0"], popt[3]
        )
    )


def batch(count, jobs):
    curves = [curve(seed) for seed in range(count)]
    granflow.fit_many(curves[:jobs], jobs=jobs)  # start-up, compile in the workers
    start = time.perf_counter()
    results = granflow.fit_many(curves, jobs=jobs)
    elapsed = time.perf_counter() - start
    converged = sum(r.success for r in results)
    print(
        f"{count} fits of 4000 points over {jobs} processes: {elapsed:.2f} s "
        f"({elapsed / count * 1e3:.2f} ms per fit, {converged}/{count} converged)"
    )
    start = time.perf_counter()
    granflow.fit_many(curves[:100], jobs=1)
    serial = (time.perf_counter() - start) / 100
    print(
        f"  in one process: {serial * 1e3:.2f} ms per fit (parallel speed-up "
        f"{serial * count / elapsed:.2f} on {jobs} processes)"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=1000)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, load average {os.getloadavg()[0]:.2f}"
    )
    single(args.repeats)
    if args.batch:
        batch(args.batch, args.jobs)


if __name__ == "__main__":
    main()
