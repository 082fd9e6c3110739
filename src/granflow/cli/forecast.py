"""``granflow forecast``: the peak of a rate-controlled start-up, or the failure of a
force-controlled run, forecast from the record up to a cut time."""

import granflow
from granflow.cli._common import add_command, quantity

__all__ = ["add_forecast"]

_EPILOG = """examples:
  granflow forecast ramp.txt --until 120s       (a stress ramp: when will it fail?)
  granflow forecast ramp.txt --within 60s       (and how likely within the next minute?)
  granflow forecast startup.txt --until 15s     (a start-up: where is its peak?)
  granflow forecast startup.csv --velocity 0.86um/s   (a plain CSV start-up)
  granflow forecast steps.txt --direct-effect   (a creeping layer: A and v_ref fitted)
  granflow forecast steps.txt --direct-effect 0.05mN   (A held at 0.05 mN)
Each interval of the file is forecast: rate control gives the peak forecast, force control
the failure forecast. A record that already shows its failure (the slip running away) says
so: the observed failure time is printed, and the forecast uses the samples before it."""


def add_forecast(subparsers):
    """Add the ``forecast`` command."""
    parser = add_command(
        subparsers,
        "forecast",
        _run_forecast,
        help="forecast the peak (rate control) or the failure (force control) of a run",
        description="Forecast, from the record up to --until, the static yield of a start-up\n"
        "or the failure time and force of a force-controlled run, with 90 % intervals.",
        epilog=_EPILOG,
    )
    parser.add_argument("file", help="an instrument export or a CSV of t, slip, force")
    parser.add_argument(
        "--until",
        help="the cut time (default: the whole record, or the last sample before a failure "
        "it shows), e.g. 120s [s]",
    )
    parser.add_argument(
        "--velocity",
        help="a start-up's imposed velocity, e.g. 0.86um/s [m/s] (default: the file's own; "
        "needed for a CSV without a velocity column)",
    )
    parser.add_argument(
        "--level",
        type=float,
        default=0.9,
        help="the intervals' confidence level, a number between 0 and 1 (default 0.9)",
    )
    parser.add_argument(
        "--within",
        help="also print the probability of failure (or of the peak) within this long after "
        "the last sample used, e.g. 60s [s]",
    )
    parser.add_argument("--format", choices=("rheocompass", "rheoplus", "trios", "csv"))
    parser.add_argument(
        "--direct-effect",
        nargs="?",
        const="fit",
        metavar="AMPLITUDE",
        help="force control: the layer creeps with the direct effect, its amplitude A fitted, "
        "or held at AMPLITUDE, e.g. 0.05mN [N] (default: quasi-static, no creep)",
    )


def _run_forecast(args):
    until = quantity(args.until, "t", "--until") if args.until else None
    velocity = quantity(args.velocity, "velocity", "--velocity") if args.velocity else None
    within = quantity(args.within, "t", "--within") if args.within else None
    direct_effect = None
    if args.direct_effect == "fit":
        direct_effect = True
    elif args.direct_effect is not None:
        direct_effect = quantity(args.direct_effect, "direct_effect", "--direct-effect")
    runs = granflow.read_runs(args.file, format=args.format)
    for run in runs:
        if run.control == "rate" or velocity is not None:
            result = granflow.forecast_peak(run, velocity=velocity, until=until, level=args.level)
        else:
            slip = _slip_from_loading_start(run)
            result = granflow.forecast_failure(
                run.t,
                slip,
                run.force,
                until=until,
                level=args.level,
                direct_effect=direct_effect,
            )
        print(f"{run.name}:")
        print(result.report())
        if within is not None:
            what = "the peak" if run.control == "rate" or velocity is not None else "failure"
            print(
                f"    P({what} within {within:g} s of {result.until:.4g} s) = "
                f"{result.probability_within(within):.3f}"
            )
    return 0


def _slip_from_loading_start(run):
    """The run's slip counted from its first sample [m] where the record starts with the
    loading (its first force within 1 % of its largest): a simulation's CSV carries the
    model's slip x, which starts at x0, and the forecast counts slip from the loading's start.
    Says so when it subtracts; other records are passed as they are (the forecast explains)."""
    import numpy as np

    slip, force = np.asarray(run.slip, dtype=float), np.asarray(run.force, dtype=float)
    if slip.size == 0 or not np.isfinite(slip[0]) or slip[0] == 0.0:
        return slip
    largest = np.nanmax(np.abs(force)) if np.isfinite(force).any() else np.nan
    if not (np.isfinite(force[0]) and abs(force[0]) <= 0.01 * largest):
        return slip
    print(
        f"{run.name}: the slip starts at {slip[0] * 1e6:.4g} µm where the loading starts; "
        "counted from there (subtracted)"
    )
    return slip - slip[0]
