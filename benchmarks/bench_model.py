"""Eq. 3 on 1e6 points and on one scalar: granflow's kernel against np.exp and the naive formula.

Run by hand from the repository root: ``PYTHONPATH=src python benchmarks/bench_model.py``.
Every row of a table is timed in the same run, the methods interleaved repeat by repeat (the
machine is shared), and the minimum of the repeats is printed with its ratio.

Rows (one thread unless said):

* ``np.exp`` on the same array -- the floor the issue measures against;
* Eq. 3 written with ``scipy.special.expi`` (the naive formula);
* ``kernel.eq3_values`` -- the fused compiled pass (scaled argument, decay term and Ei part
  in one SIMD pass);
* ``kernel.eq3_loop`` after NumPy's ``s`` and ``exp`` (the two-pass kernel it replaces);
* ``granflow.friction_time`` (1 thread and all threads) -- the public function;
* on one scalar: the naive formula on a float64 (``math`` and ``scipy.special.expi``), the
  compiled scalar paths ``kernel.general_value``, ``kernel.eq3_scalar`` and
  ``kernel.eq3_default``, and ``granflow.friction_time(float)`` / ``friction_slip(float)``.
"""

import math
import os
import platform
import time

import numpy as np
import scipy
import scipy.special as sc

import granflow as gf
from granflow._threads import get_num_threads, set_num_threads
from granflow.model import kernel

POINTS = 1_000_000
REPEATS = 15
SCALAR_CALLS = 2000
A, K, T0, FD, VELOCITY = 3.31e-3, 0.036, 0.23, 10e-3, 0.86e-6
PARAMS = gf.Params.from_time_domain(a=A, k=K, t0=T0, Fd=FD, velocity=VELOCITY)


def naive_eq3(t):
    """Eq. 3 as one would write it from the paper, on scipy.special.expi."""
    return A * np.exp(-K * t) * (sc.expi(K * t) - sc.expi(K * T0)) + FD * (1 - np.exp(-K * t))


def fused(t, out):
    """The fused kernel on a time grid (scale = velocity, as friction_time calls it)."""
    p = PARAMS
    lowest = T0 * (1.0 - 1e-12)
    kernel.eq3_values(t, VELOCITY, lowest, T0, p.a, p.alpha, p.Fd, p.x0, 0.0, True, False, out)


def two_pass(t, out):
    """The kernel before: NumPy computes s and the decay term, then the compiled loop."""
    p = PARAMS
    s = p.alpha * (VELOCITY * t)
    decay = np.exp(p.alpha * p.x0 - s)
    lowest = T0 * (1.0 - 1e-12)
    kernel.eq3_loop(t, s, decay, lowest, T0, p.a, p.alpha, p.Fd, p.x0, 0.0, True, False, out)


def interleaved(methods, repeats=REPEATS):
    """Minimum time of each method, the methods run in turn within every repeat."""
    for method in methods.values():
        method()  # warm-up (and loading the cached compiled kernels)
    best = dict.fromkeys(methods, math.inf)
    for _ in range(repeats):
        for name, method in methods.items():
            start = time.perf_counter()
            method()
            best[name] = min(best[name], time.perf_counter() - start)
    return best


def arrays(label, t):
    out = np.empty_like(t)
    threads = get_num_threads()

    def all_threads():
        set_num_threads(threads)
        gf.friction_time(t, PARAMS, VELOCITY)
        set_num_threads(1)

    set_num_threads(1)
    with np.errstate(over="ignore"):
        best = interleaved(
            {
                "np.exp on the same array": lambda: np.exp(t, out=out),
                "Eq. 3 with scipy.special.expi": lambda: naive_eq3(t),
                "kernel.eq3_values (fused)": lambda: fused(t, out),
                "kernel.eq3_loop after NumPy exp": lambda: two_pass(t, out),
                "granflow.friction_time": lambda: gf.friction_time(t, PARAMS, VELOCITY),
                f"granflow.friction_time, {threads} threads": all_threads,
            }
        )
    set_num_threads(threads)
    fused(t, out)
    worst = np.max(np.abs(out / naive_eq3(t) - 1))
    floor = best["np.exp on the same array"]
    print(f"\n{label}, {POINTS:.0e} points, one thread, min of {REPEATS}:")
    for name, seconds in best.items():
        print(f"  {name:38s} {seconds * 1e3:8.2f} ms  {seconds / floor:5.2f}x np.exp")
    print(f"  fused kernel against the expi formula: largest relative difference {worst:.1e}")


def scalars():
    t = 37.5
    p = PARAMS
    s0 = p.alpha * p.x0
    k_t0 = K * T0

    def naive():
        for _ in range(SCALAR_CALLS):
            A * math.exp(-K * t) * (sc.expi(K * t) - sc.expi(k_t0)) + FD * -math.expm1(-K * t)

    def general():
        for _ in range(SCALAR_CALLS):
            kernel.general_value(t, A, K, FD, T0, FD * -math.expm1(-s0))

    def scalar():
        lowest = T0 * (1.0 - 1e-12)
        for _ in range(SCALAR_CALLS):
            kernel.eq3_scalar(t, VELOCITY, lowest, T0, p.a, p.alpha, p.Fd, p.x0, 0.0, True, False)

    def default():
        for _ in range(SCALAR_CALLS):
            kernel.eq3_default(t, VELOCITY, p.a, p.alpha, p.Fd, p.x0)

    def public():
        for _ in range(SCALAR_CALLS):
            gf.friction_time(t, PARAMS, VELOCITY)

    def public_slip():
        x = t * VELOCITY
        for _ in range(SCALAR_CALLS):
            gf.friction_slip(x, PARAMS)

    best = interleaved(
        {
            "naive formula on a float64 (math + expi)": naive,
            "kernel.general_value (the simulator's)": general,
            "kernel.eq3_scalar (the model functions')": scalar,
            "kernel.eq3_default (the defaults' path)": default,
            "granflow.friction_time(float)": public,
            "granflow.friction_slip(float)": public_slip,
        },
        repeats=7,
    )
    floor = best["naive formula on a float64 (math + expi)"]
    print(f"\none scalar t = {t} s, min of 7 x {SCALAR_CALLS} calls:")
    for name, seconds in best.items():
        each = seconds / SCALAR_CALLS
        print(f"  {name:42s} {each * 1e6:7.3f} us  {seconds / floor:5.2f}x the naive formula")


def main():
    start = time.perf_counter()
    gf.friction_time(1.0, PARAMS, VELOCITY)
    print(f"first call (import-time compile or cache load): {time.perf_counter() - start:.3f} s")
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.2f}, Python {platform.python_version()}, "
        f"NumPy {np.__version__}, SciPy {scipy.__version__}"
    )
    rng = np.random.default_rng(2024)
    # Measured curves are time series (sorted); shuffled inputs defeat the kernel's blocks
    # (one table piece, one formula per block) and show the worst case. Beyond k t ~ 709 the
    # naive formula overflows (inf * 0 = NaN), so the log grid stops at 1e4 s (k t = 360).
    uniform = rng.uniform(T0, 1000.0, POINTS)
    logarithmic = np.exp(rng.uniform(np.log(T0), np.log(1e4), POINTS))
    arrays("sorted uniform t in [t0, 1000 s] (a measured start-up)", np.sort(uniform))
    arrays("sorted log-uniform t in [t0, 1e4 s]", np.sort(logarithmic))
    arrays("shuffled uniform t in [t0, 1000 s]", uniform)
    arrays("shuffled log-uniform t in [t0, 1e4 s]", logarithmic)
    scalars()


if __name__ == "__main__":
    main()
