"""The live watch scored as forecasters are scored (issue 30): a fleet of synthetic records
replayed through the watch's engine (:class:`granflow.watch.engine.Watch`, as ``granflow
watch`` runs it), its alarms against the failures; the inverse-velocity alarm (Fukuzono) on
the same records, at the same cuts and horizon, at its own 5 % false-alarm setting.

The fleet (each record its own seed and point of the design): stress **ramps**, **staircases**
(F_peak anywhere in its step) and **creeping ramps** (the direct effect, simulated by
granflow.simulate) that fail; **held** creeping layers, ramped to 80-90 % of F_peak and held
there, that never fail; rate-controlled **start-ups**. Parameters a, alpha, Fd, x0 each a
factor 1/3 to 3 about SPEC §4's blue set, 200-1000 s to failure, sampled at 1 Hz, slip
noise 0.1-3 % of the slip to failure, force noise 0.03-1 % of F_peak (log-uniform).

The watch forecasts every ``CADENCE`` seconds of record, or a fortieth of the record where
that is longer (the rows of that interval arrive as one batch); its alarm is raised when
P(failure within the horizon) reaches the threshold (0.5) on ``confirm`` forecasts in a row
and cleared when it falls back. Scores:

* **in time**: a failing record whose alarm was raised within the last horizon before the
  failure; **lead**: failure time minus that raise;
* **false alarms**: an alarm raised on a record that never fails, or more than one horizon
  before the failure; the *false-alarm ratio* is their share of all alarms raised, and the
  records with one are counted too;
* **on at failure**: a failing record whose alarm was on when the failure came, however
  early it was raised (an alarm raised more than a horizon early and kept on is a false
  alarm and not in time, but it did warn);
* the inverse-velocity alarm: raised when the method's failure date lies within
  ``theta * horizon`` of the cut, theta the largest (most eager) setting whose false-alarm
  ratio on the fleet stays at or under 5 %.

Run from the repository root::

    nice -n 10 python benchmarks/bench_watch.py [SCALE] [PROCESSES] [FIRST_SEED]

(SCALE 1: 300 records, as :data:`SHARES`; 0.1 for a quick look.)

The table is printed; the forecasts of every record are kept in
``benchmarks/results/watch_fleet.json`` and the figure (P(failure within the horizon)
against the time to failure) is written to ``docs/_static/watch_fleet.png``.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

HORIZON = 60.0  # s
THRESHOLD = 0.5
CADENCE = 10.0  # s of record between forecasts
MIN_ROWS = 100  # the watch's default: samples a forecast needs to raise the alarm
KINDS = ("ramp", "staircase", "creep ramp", "held", "start-up")
CENTRE = (3.31e-3, 4.19e4, 10e-3, 0.198e-6)  # a [N], alpha [1/m], Fd [N], x0 [m]
RATES = (1.0,)  # Hz: the paper's 1 point/s
#: Records per kind for 300 in all: the creeping and held ones cost the most to replay.
SHARES = {"ramp": 90, "staircase": 90, "creep ramp": 30, "held": 30, "start-up": 60}
#: Points of the pooled record in the fleet's watch (the CLI's default is 2048): the fleet's
#: records hold 200-2000 samples, and on a machine shared with other work this halves the
#: cost of the creeping and held records' forecasts.
MAX_POINTS = 512
ROOT = Path(__file__).resolve().parents[1]


def _log_uniform(rng, low, high):
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def make_record(kind, seed):
    """One record of the fleet: a dict of t, slip, force, velocity [SI], control, failure
    (None when it never fails), F_peak and its design."""
    import granflow as gf
    from granflow.forecast.synthetic import creep_ramp_record, ramp_record, staircase_record
    from granflow.model.friction import friction_time, peak
    from granflow.simulation import ForceTable, Protocol, simulate
    from granflow.simulation.options import DirectEffect

    rng = np.random.default_rng([seed, KINDS.index(kind), 30])
    params = gf.Params(*(c * _log_uniform(rng, 1 / 3, 3) for c in CENTRE))
    top = peak(params)
    rise = top.slip - params.x0
    duration = _log_uniform(rng, 200.0, 1000.0)
    dt = 1.0 / float(rng.choice(RATES))
    noise = _log_uniform(rng, 1e-3, 3e-2) * rise
    force_noise = _log_uniform(rng, 3e-4, 1e-2) * top.force
    noise_seed = int(rng.integers(2**31))
    design = {"duration": duration, "dt": dt, "noise": noise / rise, "force_noise": force_noise}

    def direct_effect():
        return DirectEffect(
            amplitude=_log_uniform(rng, 3e-3, 3e-2) * top.force,
            velocity=_log_uniform(rng, 1e-8, 1e-6),
        )

    control, velocity = "stress", None
    if kind == "ramp":
        t, slip, force, failure = ramp_record(
            params,
            top.force / duration,
            noise=noise,
            force_noise=force_noise,
            seed=noise_seed,
            dt=dt,
        )
    elif kind == "staircase":
        steps = int(rng.integers(8, 21))
        step = top.force / (steps - float(rng.uniform()))
        t, slip, force, failure = staircase_record(
            params,
            step,
            duration / steps,
            noise=noise,
            force_noise=force_noise,
            seed=noise_seed,
            dt=dt,
        )
    elif kind == "creep ramp":
        t, slip, force, failure = creep_ramp_record(
            params,
            top.force / duration,
            direct_effect(),
            noise=noise,
            force_noise=force_noise,
            seed=noise_seed,
            dt=dt,
        )
    elif kind == "held":
        # ramped to 80-95 % of F_peak and held; the ramp slow enough that, had it gone on,
        # the layer would have failed two to three horizons later (an alarm before the hold
        # would be right: the watch cannot know that the force will stop rising)
        fraction = float(rng.uniform(0.80, 0.90))
        duration = max(duration, _log_uniform(rng, 2 * HORIZON, 3 * HORIZON) / (1 - fraction))
        level = fraction * top.force
        ramp_time = duration * fraction
        end = ramp_time + max(0.25 * duration, 2 * HORIZON)
        protocol = Protocol([ForceTable(time=(0.0, ramp_time, end), force=(0.0, level, level))])
        result = simulate(params, protocol, direct_effect=direct_effect(), points=20000)
        if result.failed:
            return make_record(kind, seed + 100_000)  # a held layer that failed: redraw
        noise_rng = np.random.default_rng(noise_seed)
        t = np.arange(0.0, end, dt)
        slip = np.interp(t, result.t, result.displacement)
        slip = slip + noise * noise_rng.standard_normal(t.size)
        force = np.interp(t, (0.0, ramp_time, end), (0.0, level, level))
        force = force + force_noise * noise_rng.standard_normal(t.size)
        failure = None
        design.update(held_at=fraction, duration=duration)
    else:  # start-up: rate control, the peak forecast
        control = "rate"
        velocity = _log_uniform(rng, 0.3e-6, 3e-6)
        peak_time = top.slip / velocity
        t = np.arange(1, int(1.5 * peak_time / dt)) * dt
        t = t[velocity * t > params.x0]
        force = friction_time(t, params, velocity)
        force = force + force_noise * np.random.default_rng(noise_seed).standard_normal(t.size)
        slip = velocity * t
        failure = None
        design["peak_time"] = peak_time
    velocity_column = np.gradient(slip, t) if velocity is None else np.full(t.size, velocity)
    return {
        "kind": kind,
        "seed": seed,
        "t": t,
        "slip": slip,
        "force": force,
        "velocity": velocity_column,
        "control": control,
        "failure": failure,
        "strength": top.force,
        "design": design,
    }


def replay(record):
    """The watch's forecasts of one record and the inverse-velocity forecasts at the cuts.

    Rows arrive in batches of CADENCE seconds of record. The inverse-velocity forecast (cheap)
    is made at every cut, on the record so far. The watch forecasts at every cut while it or
    the baseline sees failure coming (its last P at least 0.1, or the baseline's date within
    two horizons) and the record holds the samples an alarm needs, and every twentieth of
    the record otherwise (an alarm at P >= 0.5 is
    then at most one such step late: the cost falls on the watch, not on the baseline).

    Returns the record's truth and ``forecasts``: (t, P, time, alarm, kind, None,
    force_interval, peak_time_interval, rows) of each of the watch's forecasts, and ``iv``:
    (t, date) of each inverse-velocity forecast.
    """
    from granflow.errors import GranflowError
    from granflow.forecast.baselines import inverse_velocity_forecast
    from granflow.io.follow import Rows
    from granflow.watch.engine import Settings, Watch

    log = []
    settings = Settings(horizon=HORIZON, alarm=THRESHOLD, max_points=MAX_POINTS)
    watch = Watch(settings, log.append)
    t, slip = record["t"], record["slip"]
    edges = np.arange(CADENCE, t[-1] + CADENCE, CADENCE)
    coarse = max(1, round(t[-1] / 20 / CADENCE))
    rows, baseline = [], []
    start, last_p, last_iv = 0, 0.0, None
    cpu = time.process_time()
    for index, edge in enumerate(edges):
        stop = int(np.searchsorted(t, edge, side="right"))
        if stop == start:
            continue
        part = slice(start, stop)
        batch = Rows(
            "fleet",
            1,
            record["kind"],
            record["control"],
            t[part],
            slip[part],
            record["velocity"][part],
            record["force"][part],
        )
        watch.take([batch])
        start = stop
        now = float(t[stop - 1])
        if record["control"] == "stress" and stop >= 12:
            try:
                last_iv = inverse_velocity_forecast(t[:stop], slip[:stop]).time
            except GranflowError:
                last_iv = None
            baseline.append((now, last_iv))
        interested = last_p >= 0.1 or (last_iv is not None and last_iv - now < 2 * HORIZON)
        fine = interested and stop >= MIN_ROWS  # before, no alarm can be raised
        if not (fine or index % coarse == 0 or stop == t.size):
            continue
        before = len(log)
        watch.forecast()
        new = [entry for entry in log[before:] if entry["event"] == "forecast"]
        if not new:
            continue
        entry = new[-1]
        last_p = entry.get("probability_within_horizon") or 0.0
        rows.append(
            (
                entry["t"],
                entry.get("probability_within_horizon"),
                entry.get("time"),
                any(e["event"] == "alarm" for e in log[before:]) or entry["alarm"],
                entry["kind"],
                None,
                entry.get("force_interval"),
                entry.get("peak_time_interval"),
                entry["rows"],
            )
        )
    return {
        "kind": record["kind"],
        "seed": record["seed"],
        "failure": record["failure"],
        "strength": record["strength"],
        "design": record["design"],
        "forecasts": rows,
        "iv": baseline,
        "cpu": time.process_time() - cpu,
    }


def one(args):
    kind, seed = args
    return replay(make_record(kind, seed))


def episodes(flags_and_times):
    """Raise times of alarm episodes from (t, on) pairs in order."""
    raises, on = [], False
    for t, flag in flags_and_times:
        if flag and not on:
            raises.append(t)
        on = flag
    return raises


def model_flags(forecasts, threshold=THRESHOLD, confirm=1, min_rows=0, bounded=True, hold=None):
    """(t, alarm on) of the watch's alarm rule on a record's forecasts: raised when P reaches
    the threshold on ``confirm`` forecasts in a row of at least ``min_rows`` rows each whose
    F_peak interval is bounded above (``bounded``; as the watch's engine does); with
    ``hold`` [s], as the engine's ``confirm``: once every forecast over that much record
    time has reached it."""
    out, run, on, since = [], 0, False, None
    for t, p, *rest in forecasts:
        p = 0.0 if p is None else p
        rows, force_interval = rest[-1], rest[4]
        closed = bool(force_interval) and force_interval[1] is not None
        reached = p >= threshold and rows >= min_rows and (closed or not bounded)
        run = run + 1 if reached else 0
        since = (since if since is not None else t) if reached else None
        ready = (t - since >= hold) if hold is not None and reached else run >= confirm
        on = ready if not on else p >= threshold
        out.append((t, on))
    return out


def iv_flags(result, theta):
    """(t, alarm on) of the inverse-velocity alarm: its date within theta * horizon."""
    return [(t, iv is not None and iv - t <= theta * HORIZON) for t, iv in result["iv"]]


def score(results, flags_of):
    """In-time share, median lead, false alarms (ratio and records) over the fleet."""
    failing = [r for r in results if r["failure"] is not None]
    in_time, leads, false, alarms, false_records, on_at_failure = 0, [], 0, 0, 0, 0
    for result in results:
        if result["kind"] == "start-up":
            continue
        flags = flags_of(result)
        raises = episodes(flags)
        failure = result["failure"]
        if failure is not None:
            before = [on for t, on in flags if t < failure]
            on_at_failure += bool(before and before[-1])
        if failure is not None:
            raises = [t for t in raises if t < failure]
        alarms += len(raises)
        early = [t for t in raises if failure is None or t < failure - HORIZON]
        false += len(early)
        false_records += bool(early)
        timely = [t for t in raises if failure is not None and t >= failure - HORIZON]
        if timely:
            in_time += 1
            leads.append(failure - timely[0])
    counted = [r for r in results if r["kind"] != "start-up"]
    return {
        "failing": len(failing),
        "in_time": in_time / max(len(failing), 1),
        "median_lead": float(np.median(leads)) if leads else math.nan,
        "alarms": alarms,
        "false_ratio": false / max(alarms, 1),
        "false_records": false_records / max(len(counted), 1),
        "on_at_failure": on_at_failure / max(len(failing), 1),
    }


def iv_setting(results, most=0.05):
    """The largest theta whose false-alarm ratio stays at or under ``most``."""
    best = None
    for theta in np.round(np.arange(0.05, 3.01, 0.05), 2):
        scored = score(results, lambda f, theta=theta: iv_flags(f, theta))
        if scored["false_ratio"] <= most and scored["alarms"]:
            best = float(theta)
    return best


def table(results, confirm, min_rows=0):
    lines = []
    kinds = [k for k in KINDS if any(r["kind"] == k for r in results)]
    header = (
        f"{'records':<12}{'n':>4}  {'alarm':<30}{'in time':>8}{'lead (med.)':>12}"
        f"{'false/alarms':>14}{'records w/ false':>18}{'on at failure':>15}"
    )
    lines.append(header)
    theta = iv_setting(results)
    for kind in [*kinds, "all"]:
        subset = [r for r in results if kind == "all" or r["kind"] == kind]
        if kind == "start-up":
            continue
        for name, flags in (
            (
                f"watch (P >= {THRESHOLD})",
                lambda r: model_flags(r["forecasts"], THRESHOLD, confirm, min_rows),
            ),
            (
                f"inverse velocity (theta {theta if theta is not None else '-'})",
                lambda f: iv_flags(f, theta if theta is not None else 0.0),
            ),
        ):
            s = score(subset, flags)
            lead = "-" if math.isnan(s["median_lead"]) else f"{s['median_lead']:.0f} s"
            timely = "-" if not s["failing"] else f"{s['in_time']:.1%}"
            on = "-" if not s["failing"] else f"{s['on_at_failure']:.1%}"
            lines.append(
                f"{kind:<12}{len(subset):>4}  {name:<30}{timely:>8}{lead:>12}"
                f"{s['false_ratio']:>13.1%} {s['false_records']:>17.1%}{on:>15}"
            )
    startups = [r for r in results if r["kind"] == "start-up"]
    if startups:
        right = sum(all(f[4] == "peak" for f in r["forecasts"]) for r in startups)
        lines.append(
            f"start-ups: {right}/{len(startups)} forecast as start-ups (the peak), no failure alarm"
        )
    return "\n".join(lines), theta


def figure(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for result in results:
        if result["failure"] is None or result["kind"] == "start-up":
            continue
        lead = [result["failure"] - f[0] for f in result["forecasts"] if f[1] is not None]
        prob = [f[1] for f in result["forecasts"] if f[1] is not None]
        ax.plot(lead, prob, color="#1565c0", alpha=0.08, lw=0.8)
    held = [r for r in results if r["kind"] == "held"]
    for result in held:
        end = result["forecasts"][-1][0] if result["forecasts"] else 0.0
        ax.plot(
            [end - f[0] for f in result["forecasts"]],
            [f[1] or 0.0 for f in result["forecasts"]],
            color="#c62828",
            alpha=0.08,
            lw=0.8,
        )
    ax.axvline(HORIZON, color="k", ls="--", lw=0.8)
    ax.axhline(THRESHOLD, color="#c62828", ls=":", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlim(3000.0, 1.0)
    ax.set_xlabel("time to failure [s] (held records, red: time to the record's end)")
    ax.set_ylabel(f"P(failure within {HORIZON:g} s)")
    ax.set_title("the watch's probability as failure approaches")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def policies(results):
    """The watch's alarm on the fleet under other rules (a look, not a tuning)."""
    lines = [
        f"{'threshold':>9} {'confirm':>8} {'min rows':>9} {'bounded':>8} {'in time':>8} "
        f"{'lead':>6} {'false/alarms':>13} {'records w/ false':>17}"
    ]
    for threshold in (0.5, 0.7, 0.9):
        for confirm in (1, 2):
            for min_rows, bounded in ((0, False), (MIN_ROWS, False), (MIN_ROWS, True)):
                s = score(
                    results,
                    lambda r, a=threshold, c=confirm, m=min_rows, b=bounded: model_flags(
                        r["forecasts"], a, c, m, b
                    ),
                )
                lines.append(
                    f"{threshold:>9} {confirm:>8} {min_rows:>9} {bounded!s:>8} "
                    f"{s['in_time']:>8.1%} {s['median_lead']:>6.0f} {s['false_ratio']:>13.1%} "
                    f"{s['false_records']:>17.1%}"
                )
    lines.append("the engine's --confirm (every forecast over that much record time):")
    for threshold in (0.5, 0.7, 0.9):
        for hold in (10.0, 20.0):
            s = score(
                results,
                lambda r, a=threshold, h=hold: model_flags(r["forecasts"], a, 1, MIN_ROWS, True, h),
            )
            lines.append(
                f"{threshold:>9} {f'{hold:g} s':>8} {MIN_ROWS:>9} {'True':>8} "
                f"{s['in_time']:>8.1%} {s['median_lead']:>6.0f} {s['false_ratio']:>13.1%} "
                f"{s['false_records']:>17.1%}"
            )
    return "\n".join(lines)


def rescore(argv):
    """``bench_watch.py score [CONFIRM] [MIN_ROWS]``: the table of the saved fleet."""
    results = json.loads((ROOT / "benchmarks" / "results" / "watch_fleet.json").read_text())
    confirm = int(argv[2]) if len(argv) > 2 else 1
    min_rows = int(argv[3]) if len(argv) > 3 else MIN_ROWS
    print(table(results, confirm, min_rows)[0])
    print(policies(results))
    figure(results, ROOT / "docs" / "_static" / "watch_fleet.png")


def main(argv):
    if len(argv) > 1 and argv[1] == "score":
        return rescore(argv)
    scale = float(argv[1]) if len(argv) > 1 else 1.0
    processes = int(argv[2]) if len(argv) > 2 else 2
    first = int(argv[3]) if len(argv) > 3 else 0
    confirm = int(os.environ.get("WATCH_CONFIRM", "1"))
    counts = {kind: max(1, round(scale * share)) for kind, share in SHARES.items()}
    jobs = [
        (kind, first + i) for i in range(max(counts.values())) for kind in KINDS if i < counts[kind]
    ]
    wall, cpu0 = time.time(), time.process_time()
    results = []
    out = ROOT / "benchmarks" / "results" / "watch_fleet.json"
    out.parent.mkdir(exist_ok=True)
    with ProcessPoolExecutor(processes) as pool:
        futures = [pool.submit(one, job) for job in jobs]
        for future in as_completed(futures):
            results.append(future.result())
            if len(results) % 10 == 0:  # kept as it goes: a stopped run can be scored
                out.write_text(json.dumps(results, default=float))
                print(f"{len(results)}/{len(jobs)} records, {time.time() - wall:.0f} s", flush=True)
    results.sort(key=lambda r: (KINDS.index(r["kind"]), r["seed"]))
    elapsed = time.time() - wall
    cpu = sum(r["cpu"] for r in results)
    out.write_text(json.dumps(results, default=float))
    text, _theta = table(results, confirm, MIN_ROWS)
    print(text)
    forecasts = sum(len(r["forecasts"]) for r in results)
    print(
        f"{len(results)} records, {forecasts} forecasts; wall {elapsed:.0f} s, CPU in the "
        f"forecasts {cpu:.0f} s ({1e3 * cpu / max(forecasts, 1):.0f} ms a forecast), "
        f"parent CPU {time.process_time() - cpu0:.0f} s; load {os.getloadavg()[0]:.1f}"
    )
    figure(results, ROOT / "docs" / "_static" / "watch_fleet.png")


if __name__ == "__main__":
    main(sys.argv)
