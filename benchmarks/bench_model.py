"""Eq. 3 on 1e6 points: granflow's kernel against the naive scipy.special.expi formula.

Run by hand from the repository root: ``python benchmarks/bench_model.py``. Prints the best of
several repeats for each method, side by side in one run, and their ratio.
"""

import os
import platform
import time

import numpy as np
import scipy
import scipy.special as sc

import granflow as gf
from granflow._threads import get_num_threads, set_num_threads

POINTS = 1_000_000
REPEATS = 7
A, K, T0, FD, VELOCITY = 3.31e-3, 0.036, 0.23, 10e-3, 0.86e-6


def naive_eq3(t):
    """Eq. 3 as one would write it from the paper, on scipy.special.expi."""
    return A * np.exp(-K * t) * (sc.expi(K * t) - sc.expi(K * T0)) + FD * (1 - np.exp(-K * t))


def best_time(function, *args):
    function(*args)  # warm-up (and, for granflow, loading the cached compiled kernel)
    timings = []
    for _ in range(REPEATS):
        start = time.perf_counter()
        function(*args)
        timings.append(time.perf_counter() - start)
    return min(timings)


def main():
    rng = np.random.default_rng(2024)
    # Measured curves are time series (sorted); shuffled inputs defeat branch prediction in
    # the kernel's region selection and show the worst case. Beyond k t ~ 709 the naive
    # formula overflows (inf * 0 = NaN), so the log grid stops at 1e4 s (k t = 360).
    uniform = rng.uniform(T0, 1000.0, POINTS)
    logarithmic = np.exp(rng.uniform(np.log(T0), np.log(1e4), POINTS))
    times = {
        "sorted uniform t in [t0, 1000 s] (a measured start-up)": np.sort(uniform),
        "shuffled uniform t in [t0, 1000 s]": uniform,
        "sorted log-uniform t in [t0, 1e4 s]": np.sort(logarithmic),
        "shuffled log-uniform t in [t0, 1e4 s]": logarithmic,
    }
    params = gf.Params.from_time_domain(a=A, k=K, t0=T0, Fd=FD, velocity=VELOCITY)
    start = time.perf_counter()
    gf.friction_time(1.0, params, VELOCITY)
    print(f"first call (import-time compile or cache load): {time.perf_counter() - start:.3f} s")
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, NumPy {np.__version__}, SciPy {scipy.__version__}"
    )
    for label, t in times.items():
        naive = best_time(naive_eq3, t)
        fast = best_time(gf.friction_time, t, params, VELOCITY)
        threads = get_num_threads()
        set_num_threads(1)
        serial = best_time(gf.friction_time, t, params, VELOCITY)
        set_num_threads(threads)
        exp_only = best_time(np.exp, t)
        worst = np.max(np.abs(gf.friction_time(t, params, VELOCITY) / naive_eq3(t) - 1))
        print(f"\n{label}, {POINTS:.0e} points, best of {REPEATS}:")
        print(f"  np.exp alone                     {exp_only * 1e3:8.2f} ms")
        print(f"  Eq. 3 with scipy.special.expi    {naive * 1e3:8.2f} ms")
        print(f"  granflow.friction_time, 1 thread {serial * 1e3:8.2f} ms")
        print(f"  granflow.friction_time, {threads} threads{fast * 1e3:8.2f} ms")
        print(
            f"  speed-up {naive / fast:6.1f}x ({naive / serial:.1f}x on one thread);  "
            f"cost per thread {serial / exp_only:4.1f}x np.exp;  "
            f"largest relative difference {worst:.1e}"
        )


if __name__ == "__main__":
    main()
