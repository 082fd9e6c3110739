"""One side of bench_forecast.py's side-by-side runs: forecast a saved set of records with
whichever granflow is on the path, and save what each forecast said and its CPU time.

``python benchmarks/forecast_side.py RECORDS.npz OUT.npz [--once]`` (run by bench_forecast.py,
once with this checkout's granflow and once with a checkout of the code at the start of issue
27 on PYTHONPATH; ``--once`` forecasts each record once, untimed warm-up left out, for the
agreement, which needs the answers and not the time). Each record ``k`` of the file holds
``t_k``, ``slip_k``, ``force_k``, ``until_k`` and ``kind_k`` ("failure", "creep" or "peak",
with ``velocity_k`` for the last).
"""

import sys
import time

import numpy as np

import granflow as gf


def forecast(kind, record):
    until = float(record["until"])
    if kind == "peak":
        return gf.forecast_peak(
            (record["t"], record["force"]), velocity=float(record["velocity"]), until=until
        )
    creep = True if kind == "creep" else None
    return gf.forecast_failure(
        record["t"], record["slip"], record["force"], until=until, direct_effect=creep
    )


def main(source, target, once=False):
    data = np.load(source)
    count = int(data["count"])
    rows = []
    for k in range(count):
        record = {name: data[f"{name}_{k}"] for name in ("t", "slip", "force", "until", "velocity")}
        kind = str(data[f"kind_{k}"])
        if not once:
            forecast(kind, record)  # compiled code and caches warm
        started = time.process_time()
        repeats = 0
        while True:
            result = forecast(kind, record)
            repeats += 1
            if once or repeats >= 3 or time.process_time() - started > 2.0:
                break
        cpu = (time.process_time() - started) / repeats
        point = np.nan if result.time is None else result.time
        rows.append([cpu, point, *result.time_interval, *result.force_interval])
    np.savez(target, rows=np.array(rows, dtype=float))


if __name__ == "__main__":
    main(*sys.argv[1:3], once="--once" in sys.argv[3:])
