"""The campaign pipeline: ``granflow.analyze`` over 12 -> 400 runs, and ``--jobs 2`` against 1.

Run by hand from the repository root:

    PYTHONPATH=src python benchmarks/bench_analyze.py [--runs 12 50 100 200 400]
        [--ratio 200] [--rounds 2] [--folder DIR]

Campaigns are written with the demo's own generator and writers
(:mod:`granflow.analysis.demo`): the first 52 runs are the demo's (a stress ramp, two creep
tests and a switch first, then its 48 start-ups), every further block of 48 start-ups is a
new draw of the demo's start-ups (another seed) in new export files, so that a campaign of
N runs reads N/4.8 files of every format, language, encoding and decimal mark the demo
writes. Nothing is read twice: every file is named by the manifest's entries once.

1. Scaling: ``analyze(manifest, out, jobs=1)`` on each size, wall and CPU time (this
   process and its children), the stage times that ``results["timing"]`` records, and the
   per-run cost of reading (``manifest_runs`` in this process over the number of runs,
   wall and CPU, the minimum of three).
2. ``--jobs`` ratio on the ``--ratio`` campaign: ``jobs=1`` and ``jobs=2`` alternate for
   ``--rounds`` rounds (each from a clean output folder), the minimum of each counts; the
   two ``results.json`` are compared with their ``timing`` entry left out (it is the only
   part that may differ), and the CPU time of the parent and of the worker processes is
   printed beside the wall time: on a machine shared with other jobs the wall-clock ratio
   says as much about the load as about the code, the CPU split says what ran where.
"""

import argparse
import json
import os
import resource
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

import granflow
from granflow.analysis import demo
from granflow.io import write_rheocompass, write_trios

_SPECIAL = ("ramp", "creep", "switch")


def _planned(count):
    """``count`` planned runs: the demo's four stress-controlled runs and 48 start-ups, then
    48 more start-ups per block (each block a new seed), as (block, plan) pairs."""
    out, block = [], 0
    while len(out) < count:
        planned = demo._campaign(np.random.default_rng(1000 + block))
        first = [p for p in planned if p.file in _SPECIAL] if block == 0 else []
        out += [(block, p) for p in first + [p for p in planned if p.file not in _SPECIAL]]
        block += 1
    return out[:count]


def write_campaign(folder, count):
    """Write a campaign of ``count`` runs into ``folder``; returns its manifest."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    planned = _planned(count)
    files = {}
    for block, plan in planned:
        files.setdefault((block, plan.file), []).append(plan)
    entries = {}
    for (block, key), members in files.items():
        spec = demo._FILES[key]
        name = f"b{block:02d}_{spec.name}"
        runs = [plan.run for plan in members]
        if spec.writer == "rheocompass":
            write_rheocompass(
                folder / name, runs, project=demo._PROJECT, test=spec.title, **spec.options
            )
        else:
            write_trios(folder / name, runs, sample=demo._SAMPLE, **spec.options)
        for interval, plan in enumerate(members, start=1):
            entry = demo._manifest_entry(plan, interval)
            entry["file"] = name
            entries[id(plan)] = entry
    manifest = folder / "manifest.yaml"
    text = yaml.safe_dump(
        {"runs": [entries[id(plan)] for _, plan in planned]}, sort_keys=False, width=100
    )
    manifest.write_text(text, encoding="utf-8")
    return manifest


def _children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def analyze_once(manifest, output, jobs):
    """One clean analysis: (wall s, parent CPU s, children CPU s, results dict)."""
    shutil.rmtree(output, ignore_errors=True)
    wall, cpu, children = time.perf_counter(), time.process_time(), _children_cpu()
    result = granflow.analyze(manifest, output, jobs=jobs, quiet=True)
    wall = time.perf_counter() - wall
    cpu, children = time.process_time() - cpu, _children_cpu() - children
    return wall, cpu, children, result.results


def _stages(results):
    stages = results["timing"]["stages_s"]
    return "  ".join(f"{name[:-2]} {seconds:5.2f}" for name, seconds in stages.items())


def read_cost(manifest, size, repeats=3):
    """(wall, CPU) per run of reading the campaign in this process, minimum of ``repeats``."""
    from granflow.io.campaign import manifest_runs

    best = (float("inf"), float("inf"))
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        manifest_runs(manifest)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        best = (min(best[0], wall / size), min(best[1], cpu / size))
    return best


def scaling(sizes, root):
    print(f"analyze, jobs=1, load average {os.getloadavg()[0]:.1f}")
    print("  runs    wall     cpu  per run   read/run (wall, CPU)   stages [s]   load")
    for size in sizes:
        manifest = write_campaign(root / f"campaign{size}", size)
        read_wall, read_cpu = read_cost(manifest, size)
        load = os.getloadavg()[0]
        wall, cpu, children, results = analyze_once(manifest, root / f"out{size}", 1)
        print(
            f"  {size:4d} {wall:7.2f} {cpu + children:7.2f} {1e3 * wall / size:6.1f} ms "
            f"{1e3 * read_wall:6.2f} ms {1e3 * read_cpu:6.2f} ms   {_stages(results)}   "
            f"{load:4.1f}"
        )


def _without_timing(results):
    return json.dumps({k: v for k, v in results.items() if k != "timing"}, sort_keys=True)


def ratio(size, rounds, root):
    manifest = write_campaign(root / f"campaign{size}", size)
    best = {}
    documents = {}
    print(f"analyze on {size} runs, jobs=1 and jobs=2 alternating, {rounds} rounds")
    for round_ in range(rounds):
        for jobs in (1, 2):
            load = os.getloadavg()[0]
            wall, cpu, children, results = analyze_once(manifest, root / f"ratio{jobs}", jobs)
            documents[jobs] = _without_timing(results)
            print(
                f"  round {round_ + 1} jobs={jobs}: wall {wall:6.2f} s, CPU parent {cpu:6.2f} s "
                f"+ workers {children:6.2f} s, load {load:4.1f}   {_stages(results)}"
            )
            if jobs not in best or wall < best[jobs][0]:
                best[jobs] = (wall, cpu, children)
    speedup = best[1][0] / best[2][0]
    print(f"  best: jobs=1 {best[1][0]:.2f} s, jobs=2 {best[2][0]:.2f} s: {speedup:.2f}x")
    same = documents[1] == documents[2]
    print(f"  results.json identical across jobs (timing left out): {same}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, nargs="*", default=[12, 50, 100, 200, 400])
    parser.add_argument("--ratio", type=int, default=200, help="campaign size for --jobs")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--folder", help="where to write (default a temporary folder)")
    args = parser.parse_args()
    root = Path(args.folder or tempfile.mkdtemp(prefix="bench_analyze-"))
    print(f"granflow {granflow.__version__}, {os.cpu_count()} cores, writing to {root}")
    # warm up: compile or load the cached kernels once, outside the timings
    analyze_once(write_campaign(root / "warm", 12), root / "warm-out", 1)
    if args.runs:
        scaling(args.runs, root)
    if args.ratio:
        ratio(args.ratio, args.rounds, root)


if __name__ == "__main__":
    main()
