"""``granflow analyze`` and ``granflow demo``: a campaign analysed end to end."""

import contextlib
import sys
from pathlib import Path

from granflow.cli._common import add_command, positive_int

__all__ = ["add_analyze", "add_demo"]

_EPILOG_ANALYZE = """examples:
  granflow analyze campaign/                        (a folder holding manifest.yaml)
  granflow analyze campaign/manifest.yaml -o results --jobs 4
  granflow analyze campaign/ -o results --resume    (after an interruption: reuses finished runs)
  granflow analyze campaign/ --scheduler tcp://10.0.0.5:8786   (Dask: pip install granflow[dask])
  granflow analyze campaign/ --mcmc --seed 1        (emcee: pip install granflow[mcmc])
  granflow analyze campaign/ --geometry "effective_radius=9mm,mean_radius=8.5mm" --strict
The manifest lists the export files with normal_load, velocity, preparation,
preparation_state, test, ... Writes report.html, results.json, tables/ (CSV and Parquet,
display units in the column names), figures/ (PNG; --figure-formats png,svg,pdf) and runs/
(one result per run, written as it finishes). Data-quality problems (a truncated export, NaN
cells, points a fit left out, a bad manifest entry) are listed per run in results.json and in
the report's "Data quality" section; --strict makes them errors. Exit code 1 when some runs or
joint analyses failed (named in the output, results.json and the report), 2 for a bad argument
or an unreadable manifest."""

_EPILOG_DEMO = """examples:
  granflow demo                                     (writes granflow-demo/)
  granflow demo -o demo --seed 3 --jobs 2
Generates a synthetic campaign that mirrors the paper, labelled as synthetic, writes it as
instrument exports with a manifest in DIR/exports, then runs 'granflow analyze' on it:
DIR/report.html, DIR/results.json and DIR/synthetic_truth.json (the values it was made with)."""


def add_analyze(subparsers):
    """Add the ``analyze`` command."""
    parser = add_command(
        subparsers,
        "analyze",
        _run_analyze,
        help="analyse a campaign: fits, joint analyses, predictions, tables, figures, report",
        description="Read every run a manifest names, fit each (start-ups, creep, stress ramps, "
        "switches), run the joint analyses the campaign allows (velocity collapse, Amontons' "
        "law, preparation spread), predict the static yield and a stability map, and write "
        "the results, tables, figures and an HTML report.",
        epilog=_EPILOG_ANALYZE,
    )
    parser.add_argument(
        "campaign", help="a manifest (.yaml, .yml, .csv) or a folder holding manifest.yaml"
    )
    parser.add_argument(
        "-o", "--output", default="granflow-analysis", help="output folder (default: %(default)s)"
    )
    _add_execution_options(parser)
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the per-run work on a Dask scheduler, e.g. tcp://host:8786",
    )
    parser.add_argument(
        "--resume", action="store_true", help="reuse the runs an interrupted analysis finished"
    )
    parser.add_argument(
        "--mcmc", action="store_true", help="sample the posterior of a representative fit"
    )
    parser.add_argument(
        "--geometry",
        metavar="SPEC",
        help="the tube of the entries whose manifest declares none: 'paper' (default), "
        "'outer_radius=14.85mm,inner_radius=12.55mm', 'outer_diameter=..,wall_thickness=..' "
        "or 'effective_radius=..,mean_radius=..'",
    )
    parser.add_argument(
        "--strict",
        action="store_true",
        help="make every data-quality problem (a truncated file, NaN cells, points a fit "
        "left out) an error: those runs fail (exit 1), the rest is analysed",
    )
    parser.add_argument(
        "--allow-outside",
        action="store_true",
        help="read files the manifest names outside its folder ('..', absolute paths, "
        "symbolic links leading out); by default such an entry fails, named",
    )


def _add_execution_options(parser):
    parser.add_argument(
        "--jobs",
        type=positive_int,
        help="local worker processes (default: every core; 1 runs in this process)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    parser.add_argument(
        "--figure-formats",
        default="png",
        metavar="LIST",
        help="the files of each figure, from png, svg and pdf, e.g. png,svg,pdf (default png; "
        "each figure is drawn once)",
    )


def add_demo(subparsers):
    """Add the ``demo`` command."""
    parser = add_command(
        subparsers,
        "demo",
        _run_demo,
        help="generate a synthetic campaign like the paper's and analyse it",
        description="Generate a synthetic campaign that mirrors the paper (start-ups over "
        "preparations, velocities and loads; a stress ramp; creep; a switch), write it as "
        "instrument exports and run 'granflow analyze' on it. Everything is labelled synthetic.",
        epilog=_EPILOG_DEMO,
    )
    parser.add_argument(
        "-o", "--output", default="granflow-demo", help="output folder (default granflow-demo)"
    )
    _add_execution_options(parser)


@contextlib.contextmanager
def _sigterm_interrupts():
    """Within the block, SIGTERM stops the work like Ctrl-C (finished runs stay saved)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _figure_formats(args):
    """The --figure-formats list ("png,svg"), checked by analyze."""
    text = getattr(args, "figure_formats", None) or "png"
    return tuple(part.strip() for part in text.split(",") if part.strip())


def _analyze_and_report(args, campaign):
    # looked up when called, not imported with the module: tests replace it
    from granflow.analysis import analyze

    try:
        with _sigterm_interrupts():
            result = analyze(
                campaign,
                args.output,
                jobs=args.jobs,
                scheduler=getattr(args, "scheduler", None),
                resume=getattr(args, "resume", False),
                quiet=args.quiet,
                mcmc=getattr(args, "mcmc", False),
                seed=args.seed,
                geometry=getattr(args, "geometry", None),
                strict=getattr(args, "strict", False),
                figure_formats=_figure_formats(args),
                allow_outside=getattr(args, "allow_outside", False),
            )
    except KeyboardInterrupt:
        print(
            f"granflow {args.command}: interrupted; the finished runs are saved in "
            f"{Path(args.output) / 'runs'}: run again with --resume to go on",
            file=sys.stderr,
        )
        return 130
    summary = result.summary()
    print(wrapped(summary) if sys.stdout.isatty() else summary)
    return result.exit_code


def wrapped(text, width=None):
    """``text`` with each line wrapped at the terminal's width between words, never inside
    a number or a path (a continued line indented under its start): for a terminal, which
    would otherwise break a line wherever it reaches the edge; a log keeps whole lines."""
    import shutil
    import textwrap

    width = width or shutil.get_terminal_size(fallback=(100, 24)).columns
    lines = []
    for line in text.splitlines():
        indent = line[: len(line) - len(line.lstrip())]
        lines.append(
            textwrap.fill(
                line,
                width=max(width, 40),
                subsequent_indent=indent + "    ",
                break_long_words=False,
                break_on_hyphens=False,
            )
            if line.strip()
            else line
        )
    return "\n".join(lines)


def _run_analyze(args):
    return _analyze_and_report(args, args.campaign)


def _run_demo(args):
    from granflow._files import writable_folder
    from granflow.analysis.demo import make_demo_campaign

    writable_folder(args.output, "output folder")
    manifest = make_demo_campaign(args.output, seed=args.seed)
    if not args.quiet:
        print(f"wrote a synthetic campaign (seed {args.seed}): {manifest}", file=sys.stderr)
        record = Path(args.output) / "watch" / "ramp.txt"
        print(
            f"a record to watch live: granflow watch --replay {record} --speed 20 "
            f"--log {record.with_suffix('.jsonl')}",
            file=sys.stderr,
        )
    return _analyze_and_report(args, manifest)
