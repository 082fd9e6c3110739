"""The forecast league (issue 29): every method on every family of records at leads of 50, 25
and 10 %, scored as forecasts are scored; run by ``python benchmarks/bench_forecast.py league
[SEEDS] [PROCESSES] [FIRST_SEED]`` from the repository root.

Writes the entries to ``benchmarks/league_entries.pkl.gz`` (a gzipped pickle) after each
round of seeds (``league --from benchmarks/league_entries.pkl.gz`` redraws from them without
forecasting), prints the table in markdown (each score with its standard error; skill
against inverse velocity) and the declining rule's record, and draws the figures into
``docs/_static/league/``: reliability diagrams of ``probability_within``, PIT histograms and
the CRPS against the lead.
"""

import gzip
import math
import os
import pickle
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from granflow.forecast.families import FAMILIES
from granflow.forecast.league import LEADS, METHODS, league, table

ROOT = Path(__file__).resolve().parents[1]
ENTRIES = ROOT / "benchmarks" / "league_entries.pkl.gz"
FIGURES = ROOT / "docs" / "_static" / "league"
REFERENCE = "inverse velocity"


def _pm(value, se, digits=3):
    if not math.isfinite(value):
        return "–"
    return f"{value:.{digits}g} ± {se:.2g}" if math.isfinite(se) else f"{value:.{digits}g}"


def markdown(cells):
    """The league's table: one row per family, lead and method."""
    lines = [
        "| family | lead | method | n | declined or no date | 90 % coverage | CRPS [s] | "
        "log score | interval score [s] | sharpness [s] | CRPS skill vs inverse velocity |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for family in FAMILIES:
        for lead in LEADS:
            reference = cells.get((family, lead, REFERENCE))
            for method in METHODS:
                s = cells.get((family, lead, method))
                if s is None:
                    continue
                skill = s.skill(reference) if reference is not None else (math.nan, math.nan)
                coverage = (
                    f"{s.coverage:.1%} ± {s.coverage_se:.1%}" if s.issued else "– (none issued)"
                )
                lines.append(
                    f"| {family} | {lead:.0%} | {method} | {s.count} | {s.declined:.1%} | "
                    f"{coverage} | {_pm(s.crps, s.crps_se)} | {_pm(s.log_score, s.log_score_se)} "
                    f"| {_pm(s.interval_score, s.interval_score_se)} | {s.sharpness:.3g} | "
                    f"{_pm(skill[0], skill[1], 2)} |"
                )
    return "\n".join(lines)


def goals(cells):
    """The goals of the issue's point 5, cell by cell: granflow's coverage of the intervals it
    gave (with their number where it gave fewer than the cell's records), how often it
    declined or gave no date, its CRPS against the best reference of the cell (paired over the
    same records: granflow's minus the reference's, with its standard error) and the verdict:
    on granflow's own records it must beat every reference, elsewhere be no worse than the
    best (a difference within two standard errors counts as no worse)."""
    lines = [
        "| family | lead | granflow's 90 % coverage (issued) | declined or no date | "
        "granflow CRPS [s] | best reference, its CRPS [s] | granflow's CRPS against it |",
        "|---|---|---|---|---|---|---|",
    ]
    for family in FAMILIES:
        for lead in LEADS:
            own = cells.get((family, lead, "granflow"))
            others = {m: cells.get((family, lead, m)) for m in METHODS if m != "granflow"}
            others = {m: s for m, s in others.items() if s is not None}
            if own is None or not others:
                continue
            best = min(others, key=lambda m: others[m].crps)
            paired = np.asarray(own.crps_values) - np.asarray(others[best].crps_values)
            difference = float(np.mean(paired))
            se = float(np.std(paired, ddof=1) / math.sqrt(paired.size)) if paired.size > 1 else 0
            if family == FAMILIES[0]:
                verdict = (
                    "beats every reference" if difference < 0 else "does not beat every reference"
                )
            else:
                verdict = "not worse" if difference <= 2 * se else "worse"
            coverage = (
                f"{own.coverage:.1%} ± {own.coverage_se:.1%}" if own.issued else "– (none issued)"
            )
            if 0 < own.issued < own.count:
                coverage += f" ({own.issued} of {own.count})"
            reference = _pm(others[best].crps, others[best].crps_se)
            lines.append(
                f"| {family} | {lead:.0%} | {coverage} | {own.declined:.1%} | "
                f"{_pm(own.crps, own.crps_se)} | {best}, {reference} "
                f"| {difference:+.3g} ± {se:.2g} s: {verdict} |"
            )
    return "\n".join(lines)


def declining(entries):
    """granflow's declining rule, family by family: forecasts, declined, the would-be misses
    (declined forecasts that would have missed, issued ones that missed) and the share of them
    declined; and the declined ones that would have held the truth."""
    lines = [
        "| family | forecasts | declined | would have missed | of them declined | "
        "declined but would have held |",
        "|---|---|---|---|---|---|",
    ]
    for family in FAMILIES:
        rows = [e for e in entries if e.family == family and e.method == "granflow"]
        if not rows:
            continue
        declined = [e for e in rows if e.declined]
        caught = sum(1 for e in declined if e.would_cover is False)
        missed = sum(
            1
            for e in rows
            if not e.declined
            and math.isfinite(e.time_interval[0])
            and not e.time_interval[0] <= e.truth <= e.time_interval[1]
        )
        total = caught + missed
        share = f"{caught / total:.1%}" if total else "–"
        held = sum(1 for e in declined if e.would_cover)
        lines.append(f"| {family} | {len(rows)} | {len(declined)} | {total} | {share} | {held} |")
    return "\n".join(lines)


def cpu_summary(entries):
    """CPU time per forecast [s], method by method."""
    lines = ["| method | forecasts | CPU per forecast [s] | CPU in all [s] |", "|---|---|---|---|"]
    for method in METHODS:
        values = [e.cpu for e in entries if e.method == method]
        if values:
            lines.append(
                f"| {method} | {len(values)} | {np.mean(values):.3g} | {np.sum(values):.0f} |"
            )
    return "\n".join(lines)


def figures(cells):
    """Reliability diagrams, PIT histograms and CRPS against lead, into docs/_static/league."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    FIGURES.mkdir(parents=True, exist_ok=True)
    colours = dict(zip(METHODS, ("C3", "C0", "C2", "C7"), strict=True))
    columns = 3
    rows = math.ceil(len(FAMILIES) / columns)

    fig, axes = plt.subplots(rows, columns, figsize=(11, 3.4 * rows), squeeze=False)
    for ax, family in zip(axes.flat, FAMILIES, strict=False):
        ax.plot([0, 1], [0, 1], color="0.7", lw=1)
        for method in METHODS:
            pooled = {}
            for lead in LEADS:
                s = cells.get((family, lead, method))
                for predicted, observed, count in s.reliability if s else []:
                    k = min(int(predicted * 10), 9)
                    p, o, n = pooled.get(k, (0.0, 0.0, 0))
                    pooled[k] = (p + predicted * count, o + observed * count, n + count)
            keys = sorted(k for k in pooled if pooled[k][2] >= 20)
            ax.plot(
                [pooled[k][0] / pooled[k][2] for k in keys],
                [pooled[k][1] / pooled[k][2] for k in keys],
                "o-",
                ms=3,
                color=colours[method],
                label=method,
            )
        ax.set_title(family)
        ax.set_xlabel("forecast probability of failure within h")
        ax.set_ylabel("observed frequency")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle("Reliability of probability_within (all leads; horizons 5-80 % of the cut)")
    fig.tight_layout()
    fig.savefig(FIGURES / "reliability.png", dpi=90)
    plt.close(fig)

    fig, axes = plt.subplots(
        len(FAMILIES), len(METHODS), figsize=(11, 1.6 * len(FAMILIES)), squeeze=False
    )
    for i, family in enumerate(FAMILIES):
        for j, method in enumerate(METHODS):
            ax = axes[i, j]
            counts = np.zeros(10)
            for lead in LEADS:
                s = cells.get((family, lead, method))
                if s is not None:
                    counts += s.pit_histogram
            total = counts.sum()
            ax.bar(np.arange(10) / 10 + 0.05, counts / total * 10 if total else counts,
                   width=0.1, color=colours[method])  # fmt: skip
            ax.axhline(1.0, color="0.5", lw=0.8)
            ax.set_xlim(0, 1)
            ax.set_yticks([])
            ax.set_xticks([])
            if i == 0:
                ax.set_title(method, fontsize=9)
            if j == 0:
                ax.set_ylabel(family, fontsize=8)
    fig.suptitle("PIT histograms of the issued forecasts (all leads; flat = calibrated)")
    fig.tight_layout()
    fig.savefig(FIGURES / "pit.png", dpi=90)
    plt.close(fig)

    fig, axes = plt.subplots(rows, columns, figsize=(11, 3.2 * rows), squeeze=False)
    for ax, family in zip(axes.flat, FAMILIES, strict=False):
        for method in METHODS:
            values = [cells.get((family, lead, method)) for lead in LEADS]
            if any(v is None for v in values):
                continue
            ax.errorbar(
                [100 * lead for lead in LEADS],
                [v.crps for v in values],
                yerr=[v.crps_se for v in values],
                fmt="o-",
                ms=3,
                capsize=2,
                color=colours[method],
                label=method,
            )
        ax.set_yscale("log")
        ax.set_title(family)
        ax.set_xlabel("lead [% of the time to failure]")
        ax.set_ylabel("CRPS [s]")
        ax.invert_xaxis()
    axes.flat[0].legend(fontsize=7)
    fig.suptitle("CRPS against lead (mean ± standard error; lower is better)")
    fig.tight_layout()
    fig.savefig(FIGURES / "crps.png", dpi=90)
    plt.close(fig)


def report(entries, elapsed=None, processes=None):
    cells = table(entries)
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    counts = {key: s.count for key, s in cells.items()}
    print(
        f"{len(entries)} forecasts, {min(counts.values())} to {max(counts.values())} records a "
        f"cell" + (f", {elapsed:.0f} s wall on {processes} processes" if elapsed else "")
        + f" (load average {load})"
    )  # fmt: skip
    print(goals(cells))
    print()
    print(declining(entries))
    print()
    print(markdown(cells))
    print()
    print(cpu_summary(entries))
    figures(cells)


def main(seeds=500, processes=2, first=29000, chunk=25):
    """The league over seeds ``first, ..., first + seeds - 1`` of every family, in rounds of
    ``chunk`` seeds of every family (the entries saved after each, so that a run cut short
    leaves every family with as many records as it reached)."""
    started, wall = time.process_time(), time.perf_counter()
    entries = []
    with ProcessPoolExecutor(processes) as pool:
        for start in range(first, first + seeds, chunk):
            stop = min(start + chunk, first + seeds)
            entries += league(range(start, stop), FAMILIES, executor=pool)
            with gzip.open(ENTRIES, "wb") as handle:
                pickle.dump(entries, handle)
            print(f"{stop - first} seeds: {time.perf_counter() - wall:.0f} s", flush=True)
    cpu = sum(e.cpu for e in entries)
    print(
        f"CPU time of the forecasts {cpu:.0f} s; this process {time.process_time() - started:.0f} s"
    )
    report(entries, time.perf_counter() - wall, processes)


def redraw(path):
    opener = gzip.open if str(path).endswith(".gz") else open
    with opener(path, "rb") as handle:
        report(pickle.load(handle))
