"""Reading a one-million-row RheoCompass export: granflow.read_runs against a naive reader.

Run by hand: ``PYTHONPATH=src python benchmarks/bench_io.py [rows]``. Each reader runs in its
own subprocess so that its peak resident memory (ru_maxrss) is its own. The export is
UTF-16 with a BOM, tab-delimited, decimal comma, torque in µN·m, in 4 intervals.

The naive reader is what hand-written scripts do: decode, split every line, float() every
cell after replacing the comma by a dot, in a Python loop.
"""

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROWS = int(sys.argv[1]) if len(sys.argv) > 1 and sys.argv[1] != "--write" else 1_000_000

GRANFLOW = """
import resource, sys, time
import granflow
start = time.perf_counter()
runs = granflow.read_runs(sys.argv[1])
elapsed = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(elapsed, peak, sum(len(run) for run in runs))
"""

NAIVE = """
import resource, sys, time
start = time.perf_counter()
text = open(sys.argv[1], encoding="utf-16").read()
columns, rows = [], 0
for line in text.splitlines():
    cells = line.split("\\t")
    if len(cells) > 6 and cells[0] == "" and cells[1].strip().isdigit():
        columns.append([float(cell.replace(",", ".")) for cell in cells[2:6]])
        rows += 1
elapsed = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(elapsed, peak, rows)
"""

BASELINE = """
import resource
import granflow
print(0.0, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 0)
"""


def _export(path, rows):
    import granflow
    from granflow.io import write_rheocompass

    params = granflow.Params.from_time_domain(
        a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6
    )
    runs = []
    per_run = rows // 4
    for index in range(4):
        t = np.arange(per_run) * 0.01
        runs.append(
            granflow.Run(
                t=t,
                slip=0.86e-6 * t,
                velocity=np.full(per_run, 0.86e-6),
                force=granflow.friction_time(t + 0.23, params, 0.86e-6),
                meta={"normal_load": 0.05 * (index + 1)},
            )
        )
    write_rheocompass(
        path, runs, language="fr", encoding="utf-16", decimal=",", units={"torque": "µN·m"}
    )


def _measure(code, path):
    result = subprocess.run(
        [sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True
    )
    elapsed, peak, rows = result.stdout.split()
    return float(elapsed), float(peak), int(rows)


def main():
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "million.csv"
        start = time.perf_counter()
        # written in a subprocess, so this process stays small (children inherit nothing)
        subprocess.run([sys.executable, __file__, "--write", str(path), str(ROWS)], check=True)
        print(
            f"wrote {ROWS} rows, {path.stat().st_size / 2**20:.0f} MiB (UTF-16) in "
            f"{time.perf_counter() - start:.1f} s"
        )
        _, base, _ = _measure(BASELINE, path)
        print(f"python + granflow imported: {base:.0f} MiB peak RSS")
        fast, fast_peak, fast_rows = _measure(GRANFLOW, path)
        naive, naive_peak, naive_rows = _measure(NAIVE, path)
        assert fast_rows == naive_rows == ROWS, (fast_rows, naive_rows)
        print(f"granflow.read_runs: {fast:6.2f} s, peak RSS {fast_peak:6.0f} MiB")
        print(f"naive Python loop:  {naive:6.2f} s, peak RSS {naive_peak:6.0f} MiB")
        print(f"speed-up: {naive / fast:.1f}x")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--write"]:
        _export(Path(sys.argv[2]), int(sys.argv[3]))
    else:
        main()
