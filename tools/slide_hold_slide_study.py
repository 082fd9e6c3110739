"""Slide-hold-slide study: do rate-and-state fits over holds recover the truth?

For each law (aging, slip) and each seed, a record of the independent generator
(``tools/slide_hold_slide_synthetic.py``: scipy Radau, holds of 1 to 3000 s, friction noise
3e-4) is written in the reader's format, read back (:func:`granflow.rsf.read_slide_hold_slide`,
holds found automatically), fitted with both laws (:func:`granflow.rsf.fit` over the record's
windows) and its healing measured (:func:`granflow.rsf.healing`). Printed per law:

- the coverage of each parameter's 95 % interval (a, b, Dc, stiffness, each window's mu0;
  goal 90-98 %), with its binomial standard error;
- how often AIC prefers the true law;
- how often the 95 % interval of beta covers the truth (beta of the noise-free record).

    PYTHONPATH=src python tools/slide_hold_slide_study.py --seeds 100

It needs :func:`granflow.rsf.fit` to accept holds inside a window (issue 32's rsf branch).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import slide_hold_slide_synthetic as synthetic

from granflow import rsf
from granflow.errors import GranflowError

LAWS = ("aging", "slip")


def truth(slider, windows):
    """The true value of every fitted parameter (mu0 of each window: steady sliding at v0)."""
    values = {"a": slider.a, "b": slider.b, "Dc": slider.Dc, "stiffness": slider.k}
    for index in range(1, windows + 1):
        values[f"mu0_{index}" if windows > 1 else "mu0"] = slider.mu0
    return values


def one_seed(law, clean, beta_true, seed, noise, compare=True):
    """One record's coverage, AIC verdict (None without ``compare``), beta and success."""
    record = rsf.parse_slide_hold_slide(
        synthetic.table(*synthetic.noisy(clean, seed, noise)[:3]), f"seed {seed}"
    )
    laws = LAWS if compare else (law,)
    fits = {name: rsf.fit(record, law=name, windows=record.windows) for name in laws}
    own = fits[law]
    true = truth(synthetic.Slider(), len(record.windows))
    covered = {n: own.ci95[n][0] <= v <= own.ci95[n][1] for n, v in true.items() if n in own.ci95}
    other = next(name for name in LAWS if name != law)
    healed = rsf.healing(record)
    low, high = healed.beta_ci95
    return {
        "covered": covered,
        "aic_right": fits[law].aic < fits[other].aic if compare else None,
        "beta_covered": low <= beta_true <= high,
        "success": own.success,
    }


def summarise(law, rows, noise, beta_true):
    """Print the coverage, AIC and beta lines of the seeds done so far."""
    n = len(rows)
    print(f"== {law} law: {n} seeds, noise {noise:g}, true beta {beta_true:.5g}/decade")
    for name in rows[0]["covered"]:
        share = sum(r["covered"][name] for r in rows) / n
        error = math.sqrt(share * (1 - share) / n)
        print(f"  95 % interval of {name:9s} covers the truth in {share:6.1%} ± {error:.1%}")
    if rows[0]["aic_right"] is not None:
        print(f"  AIC prefers the {law} law in {sum(r['aic_right'] for r in rows) / n:.1%}")
    beta_share = sum(r["beta_covered"] for r in rows) / n
    print(f"  beta's 95 % interval covers the truth in {beta_share:.1%}")
    print(f"  fits successful: {sum(r['success'] for r in rows) / n:.1%}", flush=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--first", type=int, default=0, help="the first seed")
    parser.add_argument("--noise", type=float, default=3e-4)
    parser.add_argument("--laws", nargs="+", default=list(LAWS), choices=LAWS)
    parser.add_argument("--every", type=int, default=10, help="print the numbers so far")
    parser.add_argument(
        "--no-compare",
        action="store_true",
        help="fit only the true law (coverage, beta; no AIC): about a sixth of the time",
    )
    args = parser.parse_args(argv)
    for law in args.laws:
        clock = time.perf_counter()
        clean = synthetic.simulate(law)
        reference = rsf.parse_slide_hold_slide(synthetic.table(*clean[:3]), "noise-free")
        beta_true = rsf.healing(reference).beta
        rows = []
        for count, seed in enumerate(range(args.first, args.first + args.seeds), start=1):
            try:
                rows.append(one_seed(law, clean, beta_true, seed, args.noise, not args.no_compare))
            except GranflowError as exc:  # counted, named, and the study goes on
                print(f"  seed {seed}: {type(exc).__name__}: {exc}", flush=True)
            if rows and (count == args.seeds or count % args.every == 0):
                print(
                    f"  ({count - len(rows)} of {count} seeds raised; seeds {args.first}..{seed})"
                )
                summarise(law, rows, args.noise, beta_true)
        print(f"  {time.perf_counter() - clock:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
