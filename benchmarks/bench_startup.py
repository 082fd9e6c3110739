"""Start-up time: ``granflow --help`` and ``import granflow`` against ``import numpy``.

Run by hand: ``PYTHONPATH=src python benchmarks/bench_startup.py [runs]``. Every command runs
in a fresh process, round-robin (so a busy machine slows each of them alike); the table gives
the median and the fastest of the runs and the median's ratio to ``python -c "import numpy"``.
The first ``friction_slip`` call is timed with Numba's cache warm (one untimed call first), as
a user meets it on the second day.
"""

import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

RUNS = int(sys.argv[1]) if len(sys.argv) > 1 else 15

FIRST_CALL = (
    "import numpy as np, granflow; "
    "p = granflow.Params(a=3.31e-3, alpha=4.186e4, Fd=1e-2, x0=1.978e-7); "
    "granflow.friction_slip(np.linspace(2e-7, 1e-4, 100), p)"
)


def _console_script():
    """The installed ``granflow`` script beside this interpreter (not a shell shim)."""
    beside = Path(sys.executable).parent / "granflow"
    if beside.is_file():
        return [str(beside)]
    found = shutil.which("granflow")
    return [found] if found else None


def commands():
    """(label, argv) of every command timed; the first is the reference."""
    python = sys.executable
    rows = [
        ('python -c "import numpy"', [python, "-c", "import numpy"]),
        ('python -c "pass"', [python, "-c", "pass"]),
        ('python -c "import granflow"', [python, "-c", "import granflow"]),
    ]
    script = _console_script()
    if script:
        rows.append(("granflow --help (console script)", [*script, "--help"]))
    rows += [
        ("python -m granflow --help", [python, "-m", "granflow", "--help"]),
        ("import + first friction_slip (cache warm)", [python, "-c", FIRST_CALL]),
    ]
    return rows


def _run(argv):
    start = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, env=os.environ.copy())
    return time.perf_counter() - start


def main():
    rows = commands()
    _run(rows[-1][1])  # compile or load Numba's cache once, untimed
    times = {label: [] for label, _ in rows}
    for _ in range(RUNS):
        for label, argv in rows:
            times[label].append(_run(argv))
    reference = statistics.median(times[rows[0][0]])
    width = max(len(label) for label, _ in rows)
    print(f"{RUNS} fresh processes each, round-robin; Python {sys.version.split()[0]}")
    print(f"{'command':<{width}}  {'median':>9}  {'fastest':>9}  {'/ numpy':>7}")
    for label, _ in rows:
        median = statistics.median(times[label])
        fastest = min(times[label])
        print(
            f"{label:<{width}}  {median * 1e3:7.0f} ms  {fastest * 1e3:7.0f} ms  "
            f"{median / reference:6.2f}x"
        )


if __name__ == "__main__":
    main()
