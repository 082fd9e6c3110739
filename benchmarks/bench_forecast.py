"""Calibration study of the failure forecasts (issue 15): >= 200 seeds of simulated ramps and
staircases, cut at lead times of 50 %, 25 % and 10 % of the time to failure; the median
absolute error of t_f and the coverage of the 90 % intervals (of t_f, and of F_peak for the
model) for the model-based forecast, the inverse-velocity method (Fukuzono) and Voight's law
with alpha fitted.

Run from the repository root:
``python benchmarks/bench_forecast.py [SEEDS] [PROCESSES] [FIRST_SEED]``; the table is printed
after every 20 seeds with the machine's load average. ``python benchmarks/bench_forecast.py
peak [SEEDS] [PROCESSES] [FIRST_SEED]`` runs the peak study instead: start-ups cut at 70 % of
their peak time, the coverage of the 90 % interval of F_peak and its width with and without
a prior from the campaign. ``python benchmarks/bench_forecast.py creep [SEEDS] [PROCESSES]
[FIRST_SEED]`` runs the creep study: ramps and staircases simulated with the direct effect
(granflow.simulate), forecast with ``direct_effect=True``. ``python benchmarks/bench_forecast.py
steps [SEEDS] [PROCESSES] [FIRST_SEED]`` runs the quasi-static staircases alone, F_peak half way
between two levels ("steps"), anywhere in its step ("steps anywhere"), and with step heights
scattered by 25 % ("steps irregular"): the coverage of
the interval of whole steps, the probability its steps claim, and the randomised PIT of the
step probabilities. ``python benchmarks/bench_forecast.py league [SEEDS] [PROCESSES]
[FIRST_SEED]`` runs the forecast league of issue 29 (``benchmarks/bench_league.py``): every
method on every family of records, scored as forecasts are scored (``league --from FILE``
redraws its table and figures from saved entries).
"""

import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor


def _calibration():
    """The calibration study's names, imported when a study runs (the league does not need
    them)."""
    from granflow.forecast import calibration

    return calibration


def _table(outcomes, seeds, elapsed, processes):
    METHODS = _calibration().METHODS
    table = _calibration().summarise(outcomes)
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(
        f"{seeds} seeds, {len(outcomes)} forecasts in {elapsed:.0f} s ({processes} processes, "
        f"load average {load})"
    )
    print(
        "| protocol | lead | model: median error, t_f coverage, F_peak coverage, open above | "
        + " | ".join(f"{m}: median error, coverage" for m in METHODS[1:])
        + " |"
    )
    for protocol in ("ramp", "steps"):
        for lead in (0.5, 0.25, 0.1):
            error, coverage, _, force, opened = table[(protocol, lead, "model")]
            cells = [f"{error:.3g} s, {coverage:.0%}, {force:.0%}, {opened:.0%}"]
            for method in METHODS[1:]:
                error, coverage, *_ = table[(protocol, lead, method)]
                cells.append(f"{error:.3g} s, {coverage:.0%}")
            print(f"| {protocol} | {lead:.0%} | {' | '.join(cells)} |", flush=True)


def main(seeds=200, processes=1, first=1000, chunk=20):
    """The study over seeds ``first, ..., first + seeds - 1``, its table printed after every
    ``chunk`` seeds."""
    started, outcomes = time.perf_counter(), []
    with ProcessPoolExecutor(processes) as pool:
        for start in range(first, first + seeds, chunk):
            stop = min(start + chunk, first + seeds)
            outcomes += _calibration().calibrate(range(start, stop), executor=pool)
            _table(outcomes, stop - first, time.perf_counter() - started, processes)


def peak(seeds=200, processes=1, first=2000):
    """The peak study over seeds ``first, ..., first + seeds - 1``."""
    started = time.perf_counter()
    with ProcessPoolExecutor(processes) as pool:
        table = _calibration().peak_study(range(first, first + seeds), executor=pool)
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    elapsed = time.perf_counter() - started
    print(f"{seeds} start-ups in {elapsed:.0f} s ({processes} processes, load average {load})")
    print("| prior | coverage of the 90 % interval | median width | narrower by |")
    for name, (coverage, width, ratio) in table.items():
        print(f"| {name} | {coverage:.1%} | {width * 1e6:.1f} uN | {ratio:.2f}x |")


def creep(seeds=200, processes=1, first=5000, chunk=20):
    """The creep study over seeds ``first, ..., first + seeds - 1``, its table printed after
    every ``chunk`` seeds."""
    started, outcomes = time.perf_counter(), []
    with ProcessPoolExecutor(processes) as pool:
        for start in range(first, first + seeds, chunk):
            stop = min(start + chunk, first + seeds)
            outcomes += _calibration().creep_study(range(start, stop), executor=pool)
            elapsed = time.perf_counter() - started
            load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
            print(
                f"{stop - first} seeds, {len(outcomes)} forecasts in {elapsed:.0f} s "
                f"({processes} processes, load average {load})"
            )
            print(
                "| protocol | lead | median error | t_f coverage | F_peak coverage | open above |"
            )
            table = _calibration().summarise(outcomes)
            leads = _calibration().LEADS
            for protocol, lead in ((p, lead) for p in ("ramp", "steps") for lead in leads):
                error, coverage, _, force, opened = table[(protocol, lead, "model (creep)")]
                print(
                    f"| {protocol} | {lead:.0%} | {error:.3g} s | {coverage:.0%} | {force:.0%} "
                    f"| {opened:.0%} |",
                    flush=True,
                )


def steps(seeds=300, processes=1, first=9000):
    """The quasi-static staircases over seeds ``first, ..., first + seeds - 1``."""
    started = time.perf_counter()
    protocols = ("steps", "steps anywhere", "steps irregular")
    with ProcessPoolExecutor(processes) as pool:
        outcomes = _calibration().calibrate(
            range(first, first + seeds), protocols=protocols, executor=pool
        )
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    elapsed = time.perf_counter() - started
    print(f"{seeds} seeds in {elapsed:.0f} s ({processes} processes, load average {load})")
    print(
        "| staircase | lead | t_f covered | its steps claim | PIT in the central 90 % | "
        "F_peak covered | median error |"
    )
    table = _calibration().summarise(outcomes)
    for protocol in protocols:
        summary = _calibration().step_summary(outcomes, 0.9, protocol)
        for lead, (covered, claimed, pit, count) in summary.items():
            error, _, _, force, _ = table[(protocol, lead, "model")]
            print(
                f"| {protocol} | {lead:.0%} | {covered:.1%} | {claimed:.1%} | {pit:.1%} "
                f"({count}) | {force:.1%} | {error:.3g} s |",
                flush=True,
            )


if __name__ == "__main__":
    if sys.argv[1:2] == ["league"]:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import bench_league

        if sys.argv[2:3] == ["--from"]:
            bench_league.redraw(sys.argv[3])
        else:
            bench_league.main(*(int(arg) for arg in sys.argv[2:5]))
    elif sys.argv[1:2] == ["steps"]:
        steps(*(int(arg) for arg in sys.argv[2:5]))
    elif sys.argv[1:2] == ["creep"]:
        creep(*(int(arg) for arg in sys.argv[2:5]))
    elif sys.argv[1:2] == ["peak"]:
        peak(*(int(arg) for arg in sys.argv[2:5]))
    else:
        main(*(int(arg) for arg in sys.argv[1:4]))
