"""The ``granflow`` command: a thin layer over the public API.

Every command parses its arguments, calls the library and prints; each is testable in-process
with ``main([...])``. Exit codes: 0 success, 1 some work failed, 2 usage or input errors.
The commands live one group per module (:mod:`~granflow.cli.curve`, :mod:`~granflow.cli.data`,
:mod:`~granflow.cli.simulation`, :mod:`~granflow.cli.campaign`); none imports NumPy, pandas or
matplotlib before it runs, so ``granflow --help`` starts fast.
"""

import argparse
import sys
import traceback

import granflow
from granflow.cli.campaign import add_analyze, add_demo
from granflow.cli.curve import add_curve
from granflow.cli.data import add_convert, add_fit, add_inspect
from granflow.cli.forecast import add_forecast
from granflow.cli.simulation import add_simulate, add_stability_map
from granflow.errors import GranflowError

__all__ = ["build_parser", "main"]


def build_parser():
    """The argument parser of the ``granflow`` command (one subparser per command)."""
    parser = argparse.ArgumentParser(
        prog="granflow",
        description="granflow: the onset of dense granular flow (Farain & Bonn's "
        "aging-rejuvenation friction model).",
        epilog="examples:\n"
        "  granflow demo -o demo                    (a synthetic campaign, analysed)\n"
        "  granflow analyze campaign/ -o results    (your campaign: a folder with a manifest)\n"
        "  granflow curve --a 3.31mN --k 0.036/s --t0 0.23s --Fd 10mN\n"
        "Run 'granflow COMMAND --help' for a command's options and examples. Exit codes: 0 "
        "success, 1 some runs failed, 2 bad arguments or input.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"granflow {granflow.__version__}")
    parser.add_argument(
        "--debug", action="store_true", help="show the traceback of an error (give it first)"
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for add in (
        add_curve,
        add_inspect,
        add_convert,
        add_fit,
        add_simulate,
        add_stability_map,
        add_analyze,
        add_demo,
        add_forecast,
    ):
        add(subparsers)
    return parser


def main(argv=None):
    """Run the command line; returns the exit code (0 ok, 1 some work failed, 2 bad input)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits on --help, --version and usage errors
        return int(exc.code or 0)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        return args.run(args)
    except (GranflowError, ImportError, OSError) as exc:
        # bad input, a missing optional extra, a file that cannot be read or written
        return _error(args, exc, 2)
    except Exception as exc:  # a bug: one line, the traceback with --debug
        return _error(args, exc, 1, internal=True)


def _error(args, exc, code, internal=False):
    if args.debug:
        traceback.print_exc()
    text = f"{type(exc).__name__}: {exc}" if internal else str(exc)
    hint = " (run with --debug for the traceback)" if internal and not args.debug else ""
    print(f"granflow {args.command}: error: {text}{hint}", file=sys.stderr)
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
