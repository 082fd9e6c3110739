"""Reading a one-million-row RheoCompass export, side by side with pandas and a Python loop;
and refusing a 1 GiB file of a valid header followed by junk.

Run by hand: ``PYTHONPATH=src python benchmarks/bench_io.py [rows]``. Each reader runs in its
own subprocess so that its peak resident memory (ru_maxrss) is its own; every subprocess
first imports what it needs and reads a tiny file (pandas, the unit registry), so the times
are those of reading, and "peak - warm" is what reading added to the warmed interpreter.
granflow and pandas alternate, one process each per round, and the minimum over rounds
counts: the machine is shared, and a ratio of two runs taken minutes apart means little.

The export is UTF-16 with a BOM, tab-delimited, decimal comma, French labels, torque in
µN·m, in 4 intervals. The pandas baseline reads the same data rows (the same UTF-16 bytes
without the header lines) with ``pandas.read_csv(encoding="utf-16", sep="\\t", decimal=",")``.
The naive reader is what hand-written scripts do: decode, split every line, float() every
cell after replacing the comma by a dot, in a Python loop.
"""

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROWS = int(sys.argv[1]) if len(sys.argv) > 1 and not sys.argv[1].startswith("--") else 1_000_000
ROUNDS = 3  # granflow and pandas alternate, one process each per round
REPEATS = 2  # reads per process (the minimum counts)
JUNK_BYTES = 2**30

WARM = """
import resource, sys, time
import pandas, granflow
from granflow.io import write_rheocompass
tiny = sys.argv[1] + ".tiny"
write_rheocompass(tiny, granflow.Run(t=[0.0, 1.0], slip=[0, 1e-6], velocity=[1e-6] * 2,
                                     force=[1e-3, 2e-3]))
granflow.read_runs(tiny)
warm = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
"""

GRANFLOW = (
    WARM
    + """
best = float("inf")
for _ in range(int(sys.argv[2])):
    start = time.perf_counter()
    runs = granflow.read_runs(sys.argv[1])
    best = min(best, time.perf_counter() - start)
    rows = sum(len(run) for run in runs)
    del runs
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(best, peak, warm, rows)
"""
)

PANDAS = (
    WARM
    + """
best = float("inf")
for _ in range(int(sys.argv[2])):
    start = time.perf_counter()
    frame = pandas.read_csv(sys.argv[1] + ".rows", encoding="utf-16", sep="\\t", decimal=",",
                            header=None)
    best = min(best, time.perf_counter() - start)
    rows = len(frame)
    del frame
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(best, peak, warm, rows)
"""
)

NAIVE = (
    WARM
    + """
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
print(elapsed, peak, warm, rows)
"""
)

REFUSE = (
    WARM
    + """
limit = int(sys.argv[2]) or None
start = time.perf_counter()
try:
    granflow.read(sys.argv[1], max_bytes=limit)
    message = "read (not refused)"
except granflow.FileFormatError as exc:
    message = str(exc).replace(sys.argv[1], "FILE")
elapsed = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(elapsed, peak, warm, message[:150])
"""
)


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
    text = path.read_bytes().decode("utf-16")
    rows_only = [line for line in text.split("\r\n") if line[:1] == "\t" and line[1:2].isdigit()]
    Path(f"{path}.rows").write_bytes(("\r\n".join(rows_only) + "\r\n").encode("utf-16"))


def _junk(path, kind):
    """A valid RheoCompass header (UTF-8) followed by junk up to JUNK_BYTES."""
    header = (
        "Project:\tjunk\r\nTest:\tt\r\nInterval and data points:\t1\t1000\r\n"
        "Interval data:\tPoint No.\tTime\tTorque\r\n\t\t[s]\t[mN·m]\r\n"
    ).encode()
    rng = np.random.default_rng(0)
    line = b"this line is not data, nor a header line\r\n"
    with path.open("wb") as stream:
        stream.write(header)
        written = len(header)
        while written < JUNK_BYTES:
            size = min(1 << 26, JUNK_BYTES - written)
            if kind == "random bytes":
                block = rng.integers(0, 256, size, dtype=np.uint8).tobytes()
            else:
                block = (line * (size // len(line) + 1))[:size]
            stream.write(block)
            written += size


def _measure(code, *args):
    result = subprocess.run(
        [sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, check=True
    )
    elapsed, peak, warm, rest = result.stdout.strip().split(maxsplit=3)
    return float(elapsed), float(peak), float(warm), rest


def main():
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "million.csv"
        start = time.perf_counter()
        # written in a subprocess, so this process stays small (children inherit nothing)
        subprocess.run([sys.executable, __file__, "--write", str(path), str(ROWS)], check=True)
        size = path.stat().st_size / 2**20
        print(f"wrote {ROWS} rows, {size:.0f} MiB (UTF-16) in {time.perf_counter() - start:.1f} s")
        rounds = {"granflow.read_runs": [], "pandas.read_csv (rows only)": []}
        for _ in range(ROUNDS):
            rounds["granflow.read_runs"].append(_measure(GRANFLOW, path, REPEATS))
            rounds["pandas.read_csv (rows only)"].append(_measure(PANDAS, path, REPEATS))
        rounds["naive Python loop"] = [_measure(NAIVE, path)]
        best = {}
        for name, results in rounds.items():
            assert all(int(rows) == ROWS for *_, rows in results), name
            times = sorted(elapsed for elapsed, *_ in results)
            peak = max(result[1] for result in results)
            warm = min(result[2] for result in results)
            best[name] = times[0]
            print(
                f"{name:28s} min {times[0]:6.2f} s, median {times[len(times) // 2]:6.2f} s   "
                f"peak RSS {peak:5.0f} MiB   peak - warm {peak - warm:5.0f} MiB "
                f"({(peak - warm) / size:.2f}x the file)"
            )
        fast = best["granflow.read_runs"]
        print(f"granflow / pandas: {fast / best['pandas.read_csv (rows only)']:.2f}x the time")
        print(f"naive / granflow:  {best['naive Python loop'] / fast:.1f}x")

        for kind in ("random bytes", "text lines"):
            junk = Path(folder) / "junk.txt"
            subprocess.run([sys.executable, __file__, "--junk", str(junk), kind], check=True)
            for limit in (0, 2**29):
                elapsed, peak, warm, message = _measure(REFUSE, junk, limit)
                guard = "default limit" if not limit else f"max_bytes={limit}"
                print(
                    f"1 GiB header + {kind}, {guard}: refused in {elapsed:.2f} s, "
                    f"peak RSS {peak:.0f} MiB (warm {warm:.0f})\n    {message}"
                )
            junk.unlink()


if __name__ == "__main__":
    if sys.argv[1:2] == ["--write"]:
        _export(Path(sys.argv[2]), int(sys.argv[3]))
    elif sys.argv[1:2] == ["--junk"]:
        _junk(Path(sys.argv[2]), sys.argv[3])
    else:
        main()
