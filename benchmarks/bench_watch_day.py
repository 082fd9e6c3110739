"""A day of 10 Hz data (issue 30, point 7): does ``granflow watch`` keep its memory and its
update cost flat as the record grows?

Part 1, in process: the watch's engine holds a record of N rows of a stress ramp sampled at
10 Hz, cut at 90 % of its time to failure (each N its own ramps, five of them, so that every
forecast is of the same stage of a record: the last tenth before failure), then takes one
more second of data (10 rows) and re-forecasts; the CPU time of that update at N = 1e3,
1e4, 1e5 and 8.64e5 rows (the last a day), with the pooled record (the watch's default,
``max_points=2048``) and with every sample kept (up to 1e5 rows: the cost the pooling
removes).

Part 2, two processes: a writer appends the day's export (RheoCompass, UTF-16 with its BOM,
864 000 rows) in pieces of 64 KiB, a day in a few minutes, while ``granflow watch FILE --log
... --until-end`` follows it; the watch's memory is sampled twice a second: resident set
(RSS, the shared libraries included) and unique set (USS, what the process alone holds), at
the first forecast and at their peaks.

Run from the repository root: ``nice -n 10 python benchmarks/bench_watch_day.py [SECONDS]``
(SECONDS: how long the writer takes for the day; default 240); ``... 240 follow`` runs part 2
alone, ``... 240 cost`` part 1 alone, keeping the other's saved figures.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DAY = 86_400.0
RATE = 10.0  # Hz
SIZES = (1_000, 10_000, 100_000, 864_000)


def ramp(rows, cut, seed=0):
    """A stress ramp sampled at 10 Hz whose first ``rows`` rows are ``cut`` of its time to
    failure: (t, slip, force) of those rows."""
    import granflow as gf
    from granflow.forecast.synthetic import ramp_record
    from granflow.model.friction import peak

    params = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
    top = peak(params)
    duration = rows / RATE / cut
    t, slip, force, _ = ramp_record(
        params,
        top.force / duration,
        noise=0.01 * (top.slip - params.x0),
        force_noise=3e-4 * top.force,
        seed=[rows, seed],
        dt=1.0 / RATE,
    )
    return t[:rows], slip[:rows], force[:rows]


def update_cost(t, slip, force, size, max_points, repeats=5):
    """CPU seconds of one update (10 new rows, then the forecast) with ``size`` rows held."""
    from granflow.io.follow import Rows
    from granflow.watch.engine import Settings, Watch

    watch = Watch(Settings(max_points=max_points), lambda record: None)

    def feed(part):
        zeros = np.zeros(part.stop - part.start)
        watch.take([Rows("day", 1, "ramp", "stress", t[part], slip[part], zeros, force[part])])
        watch.forecast()

    feed(slice(0, size - 10 * repeats))
    costs = []
    for k in range(repeats):
        start = size - 10 * (repeats - k)
        begin = time.process_time()
        feed(slice(start, start + 10))
        costs.append(time.process_time() - begin)
    return float(np.median(costs))


def part_one(seeds=5):
    """The update cost at each size: median and range over ``seeds`` ramps (a forecast's
    cost depends on its record far more than on its length), and with every sample kept
    on the first of them."""
    print(
        f"update cost (10 new rows + the forecast), CPU ms, median of 5 updates; "
        f"pooled: median [range] over {seeds} ramps"
    )
    print(f"{'rows held':>10} {'pooled (2048)':>22} {'every sample':>14}")
    rows = []
    for size in SIZES:
        pooled = []
        for seed in range(seeds):
            t, slip, force = ramp(size, 0.9, seed)
            pooled.append(1e3 * update_cost(t, slip, force, size, 2048))
            if seed == 0:
                every = update_cost(t, slip, force, size, 10**9) if size <= 100_000 else None
        text = "-" if every is None else f"{1e3 * every:.0f}"
        spread = f"{np.median(pooled):.0f} [{min(pooled):.0f}-{max(pooled):.0f}]"
        print(f"{size:>10} {spread:>22} {text:>14}", flush=True)
        rows.append({"rows": size, "pooled_ms": pooled, "every_ms": every and 1e3 * every})
    return rows


def write_day(path, t, slip, force):
    import granflow as gf
    from granflow.io import write_rheocompass

    velocity = np.gradient(slip, t)
    run = gf.Run(t=t, slip=slip, velocity=velocity, force=force, control="stress")
    write_rheocompass(path, run, test="a day of creep", encoding="utf-16")


def part_two(export, seconds):
    """The watch follows the day's export while a writer appends it."""
    import psutil

    folder = Path(tempfile.mkdtemp())
    live, log = folder / "live.txt", folder / "watch.jsonl"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    size = export.stat().st_size
    piece = 1 << 16
    pause = seconds / (size / piece)
    writer_code = (
        "import sys, time\n"
        "src, dst, piece, pause = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])\n"
        "with open(src, 'rb') as a, open(dst, 'ab') as b:\n"
        "    while chunk := a.read(piece):\n"
        "        b.write(chunk); b.flush(); time.sleep(pause)\n"
    )
    live.write_bytes(b"")
    watch = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "granflow",
            "watch",
            str(live),
            "--log",
            str(log),
            "--until-end",
            "--stall",
            "10s",
        ],
        env=env,
        stdout=subprocess.DEVNULL,
    )
    process = psutil.Process(watch.pid)
    while not (log.exists() and log.stat().st_size):  # the watch is ready
        time.sleep(0.1)
    began = time.monotonic()
    writer = subprocess.Popen(
        [sys.executable, "-c", writer_code, str(export), str(live), str(piece), str(pause)]
    )
    samples = []
    while watch.poll() is None:
        try:
            info = process.memory_full_info()
            cpu = process.cpu_times()
        except psutil.NoSuchProcess:
            break
        forecasting = b'"event":"forecast"' in log.read_bytes()
        samples.append(
            (time.monotonic() - began, info.rss, info.uss, cpu.user + cpu.system, forecasting)
        )
        time.sleep(0.5)
    writer.wait()
    wall = time.monotonic() - began
    entries = [json.loads(line) for line in log.read_text().splitlines()]
    forecasts = [e for e in entries if e["event"] == "forecast"]
    first = next((s for s in samples if s[4]), samples[-1])  # at the first forecast
    peak_rss = max(s[1] for s in samples)
    peak_uss = max(s[2] for s in samples)
    mib = 2**20
    print(
        f"\nfollowing the day's export ({size / mib:.0f} MiB, {forecasts[-1]['rows']} rows "
        f"read) as it was written in {wall:.0f} s:"
    )
    print(f"  forecasts: {len(forecasts)}, the last at t = {forecasts[-1]['t']:.0f} s")
    print(
        f"  memory at the first forecast: RSS {first[1] / mib:.0f} MiB, "
        f"USS {first[2] / mib:.0f} MiB"
    )
    print(f"  memory at its peak:  RSS {peak_rss / mib:.0f} MiB, USS {peak_uss / mib:.0f} MiB")
    print(f"  the watch's CPU time: {samples[-1][3]:.0f} s over {wall:.0f} s of wall time")
    return {
        "bytes": size,
        "rows": forecasts[-1]["rows"],
        "forecasts": len(forecasts),
        "wall_s": wall,
        "rss_start_mib": first[1] / mib,
        "uss_start_mib": first[2] / mib,
        "rss_peak_mib": peak_rss / mib,
        "uss_peak_mib": peak_uss / mib,
        "cpu_s": samples[-1][3],
    }


def main(argv):
    seconds = float(argv[1]) if len(argv) > 1 else 240.0
    wall, cpu = time.time(), time.process_time()
    out = ROOT / "benchmarks" / "results" / "watch_day.json"
    saved = json.loads(out.read_text()) if out.exists() else {}
    part = argv[2] if len(argv) > 2 else "both"
    costs = saved.get("update_cost") if part == "follow" else part_one()
    if part == "cost":
        follow = saved.get("follow")
    else:
        export = Path(tempfile.mkdtemp()) / "day.txt"
        write_day(export, *ramp(SIZES[-1], SIZES[-1] / RATE / (DAY + 60.0)))
        follow = part_two(export, seconds)
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({"update_cost": costs, "follow": follow}, indent=1))
    print(
        f"\nwall {time.time() - wall:.0f} s, this process's CPU {time.process_time() - cpu:.0f} s; "
        f"load {os.getloadavg()[0]:.1f}"
    )


if __name__ == "__main__":
    main(sys.argv)
