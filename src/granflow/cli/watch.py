"""``granflow watch``: the forecast, live, while the rheometer writes its export (or a finished
record replayed as if it were being written)."""

from pathlib import Path

from granflow.cli._common import UsageError, add_command, add_geometry_option, quantity

__all__ = ["add_watch"]

_EPILOG = """examples:
  granflow watch run.txt --log run.jsonl                 (follow an export as it grows)
  granflow watch exports/ --log watch.jsonl --serve 8765 (a folder: each new export followed)
  granflow watch ramp.txt --log w.jsonl --horizon 60s --alarm 0.5 --on-alarm 'notify-send fail'
  granflow watch --replay demo/watch/ramp.txt --speed 20 --log replay.jsonl --until-end
A stress-controlled record (ramp, staircase, creep) gets the failure forecast, a rate-
controlled start-up the forecast of its peak (--test overrides what the file says; 'creep'
fits the direct effect). The alarm is raised when P(failure within the horizon) reaches
--alarm, and cleared when it falls back. Every forecast and event is one JSON line of --log
(appended to): t, kind, force_interval, time_interval, probability_within_horizon, alarm,
event, message, ... ('null' where a value is unknown or an interval is open). --on-alarm runs
a shell command with the forecast in GRANFLOW_* environment variables (GRANFLOW_FORECAST:
the whole record as JSON). Ctrl-C stops the watch; the log stays whole. Exit code 0."""


def add_watch(subparsers):
    """Add the ``watch`` command."""
    parser = add_command(
        subparsers,
        "watch",
        _run_watch,
        help="forecast live while an export is written: alarms, a log, a live panel and page",
        description="Follow an export (or a folder of exports) while the instrument writes it,\n"
        "and forecast the failure (force control) or the peak (rate control) at each new\n"
        "batch of rows, with an alarm when failure becomes likely within the horizon.",
        epilog=_EPILOG,
    )
    parser.add_argument("path", help="the export being written, or a folder of exports")
    parser.add_argument("--log", required=True, metavar="FILE.jsonl", help="the JSON-lines log")
    parser.add_argument(
        "--horizon", default="60s", help="the alarm's horizon, e.g. 60s [s] (default 60 s)"
    )
    parser.add_argument(
        "--alarm",
        type=float,
        default=0.5,
        help="raise the alarm when P(failure within the horizon) reaches this (default 0.5)",
    )
    parser.add_argument(
        "--confirm",
        default="0s",
        help="raise the alarm only once P has stayed at or above --alarm this long, e.g. 10s "
        "[s] (default 0 s: at the first forecast that reaches it)",
    )
    parser.add_argument(
        "--test",
        choices=("ramp", "staircase", "creep", "startup"),
        help="what the record is (default: from the file's control mode)",
    )
    parser.add_argument(
        "--serve", metavar="[HOST:]PORT", help="serve the live page (host 127.0.0.1)"
    )
    parser.add_argument(
        "--on-alarm", metavar="CMD", help="a shell command run when the alarm is raised"
    )
    parser.add_argument(
        "--replay", action="store_true", help="play a finished record as if it were being written"
    )
    parser.add_argument(
        "--speed", type=float, default=1.0, help="record seconds per second of a replay (default 1)"
    )
    parser.add_argument(
        "--until-end",
        action="store_true",
        help="stop at the end of a finished file (with --replay, of the replay)",
    )
    parser.add_argument(
        "--stall",
        default="30s",
        help="data have stopped after this long without new rows, e.g. 30s [s] (default 30 s)",
    )
    parser.add_argument(
        "--level", type=float, default=0.9, help="the intervals' level (default 0.9)"
    )
    parser.add_argument(
        "--prior",
        metavar="results.json",
        help="the campaign's material constants as the forecasts' prior (a granflow analyze "
        "result, or a JSON mapping of a, alpha, Fd with their errors)",
    )
    parser.add_argument("--format", choices=("rheocompass", "rheoplus", "trios", "csv"))
    add_geometry_option(parser)


def _run_watch(args):
    from granflow.cli._common import geometry_choice
    from granflow.watch.engine import Settings
    from granflow.watch.session import Options, run

    if args.speed <= 0:
        raise UsageError(f"--speed must be positive, got {args.speed:g}")
    if args.speed != 1.0 and not args.replay:
        raise UsageError("--speed applies to --replay only")
    settings = Settings(
        horizon=quantity(args.horizon, "t", "--horizon"),
        alarm=args.alarm,
        confirm=quantity(args.confirm, "t", "--confirm"),
        test=args.test,
        level=args.level,
        prior=_prior(args.prior) if args.prior else None,
    )
    options = Options(
        path=Path(args.path),
        log=Path(args.log),
        serve=args.serve,
        on_alarm=args.on_alarm,
        replay=args.replay,
        speed=args.speed,
        until_end=args.until_end,
        stall=quantity(args.stall, "t", "--stall"),
        geometry=geometry_choice(args.geometry).annulus,
        format=args.format,
    )
    return run(options, settings)


def _prior(path):
    """The forecasts' prior from a JSON file: a campaign's results or a mapping."""
    from granflow.watch.prior import read_prior

    return read_prior(path)
