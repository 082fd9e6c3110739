"""Calibration study of the failure forecasts (issue 15): >= 200 seeds of simulated ramps and
staircases, cut at lead times of 50 %, 25 % and 10 % of the time to failure; the median
absolute error of t_f and the coverage of the 90 % intervals for the model-based forecast,
the inverse-velocity method (Fukuzono) and Voight's law with alpha fitted; and the time per
forecast of each method side by side.

Run from the repository root: ``python benchmarks/bench_forecast.py [SEEDS] [PROCESSES]``.
"""

import sys
import time
from concurrent.futures import ProcessPoolExecutor

from granflow.forecast.calibration import METHODS, calibrate, summarise


def _table(outcomes, seeds, elapsed, processes):
    table = summarise(outcomes)
    print(f"{seeds} seeds, {len(outcomes)} forecasts in {elapsed:.0f} s ({processes} processes)")
    print(
        f"| protocol | lead | {' | '.join(f'{m}: median error [s], coverage' for m in METHODS)} |"
    )
    for protocol in ("ramp", "steps"):
        for lead in (0.5, 0.25, 0.1):
            cells = []
            for method in METHODS:
                error, coverage, _ = table[(protocol, lead, method)]
                cells.append(f"{error:.3g}, {coverage:.0%}")
            print(f"| {protocol} | {lead:.0%} | {' | '.join(cells)} |", flush=True)


def main(seeds=200, processes=1, chunk=20):
    """The study over ``seeds`` seeds, its table printed after every ``chunk`` seeds."""
    started, outcomes = time.perf_counter(), []
    with ProcessPoolExecutor(processes) as pool:
        for first in range(0, seeds, chunk):
            outcomes += calibrate(range(first, min(first + chunk, seeds)), executor=pool)
            done = min(first + chunk, seeds)
            _table(outcomes, done, time.perf_counter() - started, processes)


if __name__ == "__main__":
    main(*(int(arg) for arg in sys.argv[1:3]))
