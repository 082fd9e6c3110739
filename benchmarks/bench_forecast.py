"""The failure forecasts: speed against the code at the start of issue 27 (side by side), the
agreement of the two, the running forecast's update cost, and the calibration study over
its design.

Run from the repository root:

* ``python benchmarks/bench_forecast.py speed [SEEDS] [--old PATH]``: CPU time per forecast
  of the benchmark records (the calibration study of issue 15: ramps, regular and irregular
  staircases cut at a quarter lead, creeping ramps, start-ups cut at 70 % of their peak
  time), forecast by this checkout and by ``PATH/src`` (a checkout of the code at the start
  of issue 27, e.g. ``git worktree add /tmp/granflow-old f4a6afb``), each in its own
  process on the same saved records; the ratio printed.
* ``python benchmarks/bench_forecast.py agree [SEEDS] [--old PATH] [--designs A,B]
  [--leads 0.5,0.25] [--save OUT.npz]``: the two codes' intervals on SEEDS records of each
  design (or of those named) at leads 50, 25 and 10 % (or those named): how often their ends
  lie within 2 % of the interval's width, and how often each code's interval holds the
  truth; ``--save`` keeps both codes' answers and the truths.
* ``python benchmarks/bench_forecast.py running [SECONDS]``: the CPU time of each
  :class:`granflow.RunningForecast` update as a 10 Hz ramp (to failure in SECONDS, default
  250) arrives a second at a time.
* ``python benchmarks/bench_forecast.py study CELLS SEEDS PROCESSES FIRST [OUT]``: the
  calibration study (:mod:`granflow.forecast.calibration`) of the cells (comma separated,
  or ``all``) over seeds FIRST .. FIRST + SEEDS - 1 on PROCESSES processes; prints the
  table and saves the outcomes to OUT (a pickle) for :func:`tables`.
* ``python benchmarks/bench_forecast.py tables OUT [OUT ...] [--figure PNG]``: the tables
  of saved outcomes: coverage with its binomial standard error per cell and lead, split by
  thirds of the noise and of the sample count (t_f, F_peak and the step PIT), and the
  reliability of ``probability_within`` (all leads and each lead; ``--figure`` draws it).
* ``python benchmarks/bench_forecast.py league [SEEDS] [PROCESSES] [FIRST_SEED]``: the
  forecast league of issue 29 (``benchmarks/bench_league.py``): every method on every
  family of records, scored as forecasts are scored (``league --from FILE`` redraws its
  table and figures from saved entries).
"""

import math
import os

# CPU time "on one core": OpenBLAS's threads (the creep forecast's normal equations) would
# add a second core's time to a forecast's and, beside a second study process, oversubscribe
# the machine. Set before NumPy loads it; every forecast process here inherits it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pickle
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

import granflow as gf
from granflow.forecast.calibration import CELLS, LEADS, coverage, reliability, study
from granflow.forecast.synthetic import (
    creep_ramp_record,
    levels_record,
    ramp_record,
    staircase_record,
)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
#: Issue 15's study: the demo's tube at 55 mN, a heavier and a lighter one.
SETS = (
    (3.3e-3, 5.0e4, 11.0e-3, 0.3e-6),
    (6.0e-3, 7.0e4, 20.0e-3, 0.5e-6),
    (1.5e-3, 3.5e4, 5.0e-3, 0.2e-6),
)
DESIGNS = ("ramp", "steps", "steps irregular", "creep ramp", "start-up")


def _load():
    return ", ".join(f"{v:.1f}" for v in os.getloadavg())


def record(seed, design, lead=0.25):
    """(kind, t, slip, force, until, velocity, truth) of issue 15's study for one seed and
    design, cut at ``lead`` of the time to failure (a start-up at 1 - lead of its peak
    time, 70 % by default speed runs)."""
    rng = np.random.default_rng(seed)
    params = gf.Params(*SETS[seed % 3])
    noise = (2e-9, 10e-9)[(seed // 3) % 2]
    strength = gf.peak(params).force
    failure = float(rng.uniform(150.0, 300.0))
    if design == "start-up":
        velocity = 0.86e-6
        top = gf.peak(params, velocity=velocity)
        t = np.arange(1.0, top.time, 0.25)
        force = gf.friction_time(t, params, velocity) + 3e-5 * rng.standard_normal(t.size)
        return "peak", t, np.zeros(t.size), force, (1 - lead) * top.time, velocity, top.time
    if design == "ramp":
        t, slip, force, truth = ramp_record(
            params, strength / failure, noise=noise, force_noise=3e-5, seed=seed
        )
    elif design == "creep ramp":
        effect = gf.DirectEffect(amplitude=0.03 * params.a, velocity=1e-7)
        t, slip, force, truth = creep_ramp_record(
            params, strength / failure, effect, noise=noise, force_noise=3e-5, seed=seed
        )
    else:
        steps = int(rng.integers(10, 16))
        offset = float(rng.uniform())
        step, duration = strength / (steps - offset), failure / steps
        if design == "steps":
            t, slip, force, truth = staircase_record(
                params, step, duration, noise=noise, force_noise=3e-5, seed=seed
            )
        else:
            heights = step * np.clip(1.0 + 0.25 * rng.standard_normal(4 * steps), 0.3, None)
            t, slip, force, truth = levels_record(
                params, np.cumsum(heights), duration, noise=noise, force_noise=3e-5, seed=seed
            )
    kind = "creep" if design.startswith("creep") else "failure"
    return kind, t, slip, force, (1 - lead) * truth, 0.0, truth


def _side(records, source, once=False):
    """Forecast ``records`` with the granflow at ``source`` (a ``src`` folder) in a process
    of its own: per record (CPU [s], t_f, interval, force interval); ``once``: each record
    forecast once, not timed with a warm-up and repeats."""
    with tempfile.TemporaryDirectory() as folder:
        inputs, outputs = Path(folder) / "records.npz", Path(folder) / "out.npz"
        arrays = {"count": len(records)}
        for k, (kind, t, slip, force, until, velocity, _) in enumerate(records):
            arrays.update(
                {
                    f"kind_{k}": kind,
                    f"t_{k}": t,
                    f"slip_{k}": slip,
                    f"force_{k}": force,
                    f"until_{k}": until,
                    f"velocity_{k}": velocity,
                }
            )
        np.savez(inputs, **arrays)
        environment = {**os.environ, "PYTHONPATH": str(source)}
        subprocess.run(
            [sys.executable, str(HERE / "forecast_side.py"), str(inputs), str(outputs)]
            + (["--once"] if once else []),
            check=True,
            env=environment,
        )
        return np.load(outputs)["rows"]


def _old(arguments):
    if "--old" in arguments:
        return Path(arguments[arguments.index("--old") + 1]) / "src"
    return Path("/tmp/granflow-old/src")


def speed(arguments):
    seeds = int(arguments[0]) if arguments and arguments[0].isdigit() else 6
    old = _old(arguments)
    print(f"CPU per forecast, {seeds} records a design, median; load average {_load()}")
    print("| record | code at the start of issue 27 | this code | ratio |")
    print("|---|---|---|---|")
    for design in DESIGNS:
        records = [
            record(1000 + seed, design, 0.3 if design == "start-up" else 0.25)
            for seed in range(seeds)
        ]
        before = _side(records, old)[:, 0]
        after = _side(records, ROOT / "src")[:, 0]
        ratio = np.median(before) / np.median(after)
        print(
            f"| {design} | {np.median(before) * 1e3:.0f} ms | {np.median(after) * 1e3:.1f} ms "
            f"| {ratio:.0f}x |",
            flush=True,
        )


def _designs(arguments):
    """The designs named by ``--designs a,b,...`` (default all)."""
    if "--designs" in arguments:
        return tuple(arguments[arguments.index("--designs") + 1].split(","))
    return DESIGNS


def _leads(arguments):
    """The leads named by ``--leads 0.5,0.25`` (default 50, 25 and 10 %)."""
    if "--leads" in arguments:
        return tuple(float(v) for v in arguments[arguments.index("--leads") + 1].split(","))
    return LEADS


def agree(arguments):
    seeds = int(arguments[0]) if arguments and arguments[0].isdigit() else 100
    old = _old(arguments)
    save = arguments[arguments.index("--save") + 1] if "--save" in arguments else None
    saved = {}
    print(f"{seeds} records a design and lead; load average {_load()}")
    print("| record | lead | both ends within 2 % of the width | old covers | new covers |")
    print("|---|---|---|---|---|")
    for design in _designs(arguments):
        for lead in _leads(arguments):
            records = [record(2000 + seed, design, lead) for seed in range(seeds)]
            before = _side(records, old, once=True)
            after = _side(records, ROOT / "src", once=True)
            truths = np.array([r[-1] for r in records])
            if save:
                saved[f"{design}|{lead}|old"], saved[f"{design}|{lead}|new"] = before, after
                saved[f"{design}|{lead}|truth"] = truths
                np.savez(save, **saved)
            width = np.abs(after[:, 3] - after[:, 2])
            close = (np.abs(before[:, 2] - after[:, 2]) <= 0.02 * width) & (
                np.abs(before[:, 3] - after[:, 3]) <= 0.02 * width
            )
            close |= (
                (before[:, 3] == after[:, 3])
                & np.isinf(after[:, 3])
                & (np.abs(before[:, 2] - after[:, 2]) <= 0.02 * np.abs(after[:, 2] - truths))
            )
            covered_old = np.mean((before[:, 2] <= truths) & (truths <= before[:, 3]))
            covered_new = np.mean((after[:, 2] <= truths) & (truths <= after[:, 3]))
            print(
                f"| {design} | {lead:.0%} | {np.mean(close):.0%} | {covered_old:.0%} "
                f"| {covered_new:.0%} |",
                flush=True,
            )


def running(arguments):
    """The running update's CPU time on a 10 Hz ramp to failure in ``arguments[0]`` seconds
    (default 250: 2500 samples to failure), fed from half to 90 % of it a second at a
    time."""
    seconds = float(arguments[0]) if arguments else 250.0
    params = gf.Params(*SETS[0])
    top = gf.peak(params)
    t, slip, force, failure = ramp_record(
        params, top.force / seconds, noise=3e-9, force_noise=3e-5, seed=1, dt=0.1
    )
    cut = t <= 0.9 * failure
    t, slip, force = t[cut], slip[cut], force[cut]
    live = gf.RunningForecast(kind="failure")
    first = int(0.5 * t.size)
    live.update(t[:first], slip[:first], force[:first])
    costs, sizes = [], []
    for start in range(first, t.size, 10):
        started = time.process_time()
        live.update(t[start : start + 10], slip[start : start + 10], force[start : start + 10])
        costs.append(time.process_time() - started)
        sizes.append(start + 10)
    started = time.process_time()
    gf.forecast_failure(t, slip, force)
    one_shot = time.process_time() - started
    costs = np.array(costs)
    print(
        f"10 Hz ramp, {len(costs)} updates of 1 s from {first} to {t.size} points "
        f"(load average {_load()}): CPU per update median {np.median(costs) * 1e3:.1f} ms, "
        f"90th percentile {np.quantile(costs, 0.9) * 1e3:.1f} ms; the one-shot forecast of the "
        f"whole record {one_shot * 1e3:.1f} ms"
    )


def _cells(text):
    return CELLS if text == "all" else tuple(text.split(","))


def run_study(arguments):
    cells, seeds, processes, first = (
        _cells(arguments[0]),
        int(arguments[1]),
        int(arguments[2]),
        int(arguments[3]),
    )
    out = arguments[4] if len(arguments) > 4 else f"study-{first}.pkl"
    started = time.perf_counter()
    outcomes = []
    chunk = max(seeds // 10, 1)
    with ProcessPoolExecutor(processes) as pool:
        for begin in range(first, first + seeds, chunk):
            seeds_now = range(begin, min(begin + chunk, first + seeds))
            outcomes += study(seeds_now, cells=cells, executor=pool)
            with open(out, "wb") as handle:
                pickle.dump(outcomes, handle)
            elapsed = time.perf_counter() - started
            print(
                f"seeds {first}..{seeds_now[-1]}: {len(outcomes)} forecasts in {elapsed:.0f} s "
                f"({processes} processes, load average {_load()})",
                flush=True,
            )
    tables([out])


def _row(chosen, key):
    share, error, count = coverage(chosen, key)
    if not count:
        return "–"
    return f"{share:.1%} ± {error:.1%} ({count})"


def tables(arguments):
    flags = [a for a in arguments]
    paths = [
        a
        for k, a in enumerate(arguments)
        if not a.startswith("--") and (k == 0 or arguments[k - 1] != "--figure")
    ]
    outcomes = []
    for path in paths:
        with open(path, "rb") as handle:
            outcomes += pickle.load(handle)
    cells = [c for c in CELLS if any(o.cell == c for o in outcomes)]
    print(
        "| cell | lead | t_f covered | F_peak covered | step PIT in central 90 % | open above "
        "| declined | errors | CPU median |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for cell in cells:
        for lead in LEADS:
            chosen = [o for o in outcomes if o.cell == cell and o.lead == lead]
            if not chosen:
                continue
            issued = [o for o in chosen if o.issued]
            opened = np.mean([o.open_above for o in issued]) if issued else math.nan
            pit = _row(chosen, "pit") if "steps" in cell and "creep" not in cell else "–"
            errors = sum(o.message.startswith("error") for o in chosen)
            cpu = np.median([o.cpu for o in chosen])
            print(
                f"| {cell} | {lead:.0%} | {_row(chosen, 'time_covered')} | "
                f"{_row(chosen, 'force_covered')} | {pit} | {opened:.0%} | "
                f"{len(chosen) - len(issued)} | {errors} | {cpu * 1e3:.0f} ms |"
            )
    print()
    print(
        "By thirds of the slip noise (of x_peak - x0) and of the samples to failure "
        "(issued forecasts; t_f, F_peak, and a staircase's step PIT):"
    )
    print("| cell | lead | outcome | noise low / mid / high | samples low / mid / high |")
    print("|---|---|---|---|---|")
    for cell in cells:
        keys = ["time_covered", "force_covered"]
        if "steps" in cell and "creep" not in cell:
            keys.append("pit")
        for lead in LEADS:
            chosen = [o for o in outcomes if o.cell == cell and o.lead == lead and o.issued]
            if not chosen:
                continue
            for key in keys:
                parts = []
                for by in ("noise", "samples"):
                    values = np.array([getattr(o, by) for o in chosen])
                    edges = np.quantile(values, [1 / 3, 2 / 3])
                    thirds = [
                        [o for o, v in zip(chosen, values, strict=True) if v <= edges[0]],
                        [
                            o
                            for o, v in zip(chosen, values, strict=True)
                            if edges[0] < v <= edges[1]
                        ],
                        [o for o, v in zip(chosen, values, strict=True) if v > edges[1]],
                    ]
                    parts.append(" / ".join(_row(part, key) for part in thirds))
                name = {"time_covered": "t_f", "force_covered": "F_peak", "pit": "step PIT"}[key]
                print(f"| {cell} | {lead:.0%} | {name} | {parts[0]} | {parts[1]} |")
    redrawn = [o for o in outcomes if getattr(o, "redraws", 0) and o.lead == LEADS[0]]
    if redrawn:
        print()
        print(
            f"{len(redrawn)} records were drawn again (the simulator could not bring the "
            f"layer to failure), {sum(o.redraws for o in redrawn)} redraws in all."
        )
    issued = [o for o in outcomes if o.issued]
    print()
    print("Reliability of probability_within (issued forecasts, all cells, leads and horizons):")
    _reliability_table(reliability(issued))
    for lead in LEADS:
        print()
        print(f"At {lead:.0%} lead alone:")
        _reliability_table(reliability([o for o in issued if o.lead == lead]))
    _time_pit_table(issued, cells)
    _own_quantile_table(issued)
    if "--figure" in flags:
        _reliability_figure(issued, flags[flags.index("--figure") + 1])


def _time_pit_table(issued, cells):
    """The confidence distribution read at the true time (``Outcome.time_pit``), in tenths,
    per cell and lead: each tenth holds 10 % where the distribution is calibrated at every
    level, not only at its 5 and 95 % points (staircases: the step PIT instead)."""
    rows = []
    for cell in cells:
        for lead in LEADS:
            values = np.array(
                [
                    getattr(o, "time_pit", math.nan)
                    for o in issued
                    if o.cell == cell and o.lead == lead
                ]
            )
            values = values[np.isfinite(values)]
            if values.size:
                rows.append((cell, lead, values))
    if not rows:
        return
    print()
    print(
        "The failure time's confidence distribution at the truth (probability_within(truth - "
        "until)): share of forecasts in each tenth, 10 % each where it is calibrated:"
    )
    print("| cell | lead | forecasts | " + " | ".join(f"{k / 10:.1f}-" for k in range(10)) + " |")
    print("|---|---|---|" + "---|" * 10)
    for cell, lead, values in rows:
        shares = np.histogram(np.clip(values, 0.0, 1.0), bins=np.linspace(0.0, 1.0, 11))[0]
        shares = shares / values.size
        print(
            f"| {cell} | {lead:.0%} | {values.size} | "
            + " | ".join(f"{100 * v:.1f}" for v in shares)
            + " |"
        )


def _reliability_table(rows):
    print("| predicted (bin mean) | observed ± standard error | forecasts | within 5 points |")
    print("|---|---|---|---|")
    for predicted, observed, count in rows:
        error = math.sqrt(max(observed * (1 - observed), 1e-12) / count)
        verdict = "yes" if abs(observed - predicted) <= 0.05 else "no"
        if count < 50:
            verdict = "(fewer than 50)"
        print(f"| {predicted:.3f} | {observed:.3f} ± {error:.3f} | {count} | {verdict} |")


def _own_quantiles(outcomes):
    """[(p, share of forecasts whose truth lies below their own p-quantile, count)] for p in
    tenths: ``probability_within`` read at each forecast's own quantile horizons, the
    reliability check a confidence distribution answers to whatever the study's cut (the
    time PIT of continuous outcomes, a staircase's randomised step PIT)."""
    values = []
    for o in outcomes:
        pit = getattr(o, "time_pit", math.nan)
        if not math.isfinite(pit):
            pit = o.pit
        if math.isfinite(pit):
            values.append(pit)
    values = np.array(values)
    if not values.size:
        return []
    return [(p, float(np.mean(values <= p)), values.size) for p in np.linspace(0.1, 0.9, 9)]


def _own_quantile_table(issued):
    rows = _own_quantiles(issued)
    if not rows:
        return
    print()
    print(
        "Reliability at the forecasts' own quantiles (probability_within at the horizon where "
        "each forecast gives p; issued forecasts with a time or step PIT):"
    )
    _reliability_table(rows)


def _reliability_figure(issued, path):
    """The reliability diagrams to ``path``: at the study's fixed horizons (all leads, and
    each lead) and at the forecasts' own quantiles (each lead)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(8.6, 4.2), layout="constrained", sharey=True)
    leads = list(zip(LEADS, ("tab:blue", "tab:orange", "tab:green"), strict=True))
    for ax in axes:
        ax.plot([0, 1], [0, 1], color="0.6", lw=1, label="perfect")
        ax.fill_between([0, 1], [-0.05, 0.95], [0.05, 1.05], color="0.9", label="within 5 points")
    styles = [("all leads", issued, "k", "o")] + [
        (f"{lead:.0%} lead", [o for o in issued if o.lead == lead], colour, "s")
        for lead, colour in leads
    ]
    for label, chosen, colour, marker in styles:
        rows = [row for row in reliability(chosen) if row[2] >= 50]
        if rows:
            predicted, observed, _ = np.array(rows).T
            axes[0].plot(predicted, observed, marker=marker, color=colour, label=label, ms=4, lw=1)
        rows = _own_quantiles(chosen)
        if rows:
            predicted, observed, _ = np.array(rows).T
            axes[1].plot(predicted, observed, marker=marker, color=colour, label=label, ms=4, lw=1)
    axes[0].set(
        xlabel="predicted probability of failure within the horizon",
        ylabel="observed frequency",
        title="at the study's horizons (0.05-1.6 x the cut)",
    )
    axes[1].set(
        xlabel="p: the horizon at each forecast's own p-quantile",
        title="at each forecast's own quantiles",
    )
    for ax in axes:
        ax.set(xlim=(0, 1), ylim=(0, 1))
        ax.title.set_fontsize(9)
        ax.legend(fontsize=7, loc="upper left")
    fig.savefig(path, dpi=150)
    print(f"figure: {path}")


def league(rest):
    """The forecast league (``benchmarks/bench_league.py``), or its redrawing ``--from FILE``."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import bench_league

    if rest[:1] == ["--from"]:
        bench_league.redraw(rest[1])
    else:
        bench_league.main(*(int(arg) for arg in rest[:3]))


if __name__ == "__main__":
    command, rest = (sys.argv[1], sys.argv[2:]) if len(sys.argv) > 1 else ("speed", [])
    {
        "speed": speed,
        "agree": agree,
        "running": running,
        "study": run_study,
        "tables": tables,
        "league": league,
    }[command](rest)
