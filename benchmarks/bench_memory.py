"""Peak memory of ``granflow analyze``: the largest single process, and which one it is.

Run by hand from the repository root (Linux: ``ru_maxrss`` in KiB):

    PYTHONPATH=src python benchmarks/bench_memory.py [--jobs 2] [--rounds 1] [--folder DIR]

The campaigns are written with the demo's own generator (:mod:`granflow.analysis.demo`,
seed 0) into a temporary folder:

* *clean*: three start-ups of the demo's Fig. 2a export (intervals 1, 2, 3);
* the four bad manifests of issue 12, the same three entries with the third made bad:
  *bomb* (a billion-laughs ``notes``: 9 levels of 9 aliases), *unknown* (a field
  ``colour``), *negative* (``normal_load: -1 mN``), *interval 99* (an interval the file
  lacks): each must fail that entry alone, in one line naming it, and analyse the others;
* *demo*: the demo's whole campaign (52 runs, every figure).

Each analysis runs as ``granflow analyze`` in a fresh interpreter (``granflow.cli.main``
under a small wrapper), which reports its own peak resident set (``ru_maxrss``: the parent,
that is the process that reads the manifest and runs the joint stage) and that of its
largest worker (``RUSAGE_CHILDREN``: the largest of the local worker processes, each on its
own, not their sum), with ``--jobs`` as given and with ``--jobs 1`` (everything in one
process). The largest of the two is what GNU ``time -f %M`` reports for the command.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from granflow.analysis.demo import make_demo_campaign

_WRAPPER = """
import json, resource, sys
from granflow.cli import main
code = main(sys.argv[2:])
own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
workers = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
with open(sys.argv[1], "w") as file:
    json.dump({"code": code, "parent_kib": own, "workers_kib": workers}, file)
"""

_BOMB = ['&l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
_BOMB += [f"&l{k} [{', '.join([f'*l{k - 1}'] * 9)}]" for k in range(1, 9)]


def write_manifests(folder):
    """The demo campaign in ``folder`` and the small manifests beside its exports:
    ``{name: manifest path}``."""
    demo = make_demo_campaign(folder / "demo", seed=0)
    entries = yaml.safe_load(demo.read_text(encoding="utf-8"))["runs"][:3]
    assert [e["interval"] for e in entries] == [1, 2, 3], "the demo's Fig. 2a export first"
    good, last = entries[:2], dict(entries[2])
    bad = {
        "clean": last,
        "bomb": {**last, "notes": "BOMB"},
        "unknown": {**last, "colour": "red"},
        "negative": {**last, "normal_load": "-1 mN"},
        "interval 99": {**last, "interval": 99},
    }
    manifests = {}
    for name, entry in bad.items():
        text = yaml.safe_dump({"runs": [*good, entry]}, sort_keys=False, width=1000)
        text = text.replace("notes: BOMB", f"notes: [{', '.join(_BOMB)}]")
        path = demo.parent / f"{name.replace(' ', '_')}.yaml"
        path.write_text(text, encoding="utf-8")
        manifests[name] = path
    manifests["demo (52 runs)"] = demo
    return manifests


def measure(manifest, output, jobs):
    """One ``granflow analyze`` in a fresh interpreter: (wall s, exit code, parent MiB,
    largest worker MiB, failed entries' reasons)."""
    report = output.with_suffix(".json")
    command = [sys.executable, "-c", _WRAPPER, str(report), "analyze", str(manifest)]
    command += ["-o", str(output), "--quiet"] + ([] if jobs is None else ["--jobs", str(jobs)])
    wall = time.perf_counter()
    subprocess.run(command, check=False, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - wall
    found = json.loads(report.read_text(encoding="utf-8"))
    results = json.loads((output / "results.json").read_text(encoding="utf-8"))
    failed = [
        f"{r['name']}: {r['reason'].replace(str(manifest.parent) + os.sep, '')}"
        for r in results["runs"]
        if r["status"] != "ok"
    ]
    ok = sum(r["status"] == "ok" for r in results["runs"])
    return (
        wall,
        found["code"],
        found["parent_kib"] / 1024,
        found["workers_kib"] / 1024,
        ok,
        failed,
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=None, help="default: every core")
    parser.add_argument("--rounds", type=int, default=1, help="the minimum of each counts")
    parser.add_argument("--folder", help="where to write (default a temporary folder)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench_memory-") as temporary:
        root = Path(args.folder or temporary)
        root.mkdir(parents=True, exist_ok=True)
        manifests = write_manifests(root)
        print(f"granflow analyze, peak RSS [MiB] per process, {os.cpu_count()} cores")
        print(
            f"  {'manifest':15s} {'jobs':>4s} {'exit':>4s} {'parent':>7s} {'worker':>7s} "
            f"{'max':>6s} {'wall s':>7s}  ok  failed entries"
        )
        for name, manifest in manifests.items():
            for jobs in dict.fromkeys((args.jobs, 1)):
                best = None
                for round_ in range(args.rounds):
                    output = root / f"out-{manifest.stem}-{jobs}-{round_}"
                    found = measure(manifest, output, jobs)
                    best = found if best is None else min(best, found, key=lambda f: max(f[2:4]))
                wall, code, parent, worker, ok, failed = best
                label = "all" if jobs is None else str(jobs)
                print(
                    f"  {name:15s} {label:>4s} {code:4d} {parent:7.0f} {worker:7.0f} "
                    f"{max(parent, worker):6.0f} {wall:7.2f} {ok:3d}  {'; '.join(failed)[:100]}"
                )


if __name__ == "__main__":
    main()
