"""The ``granflow`` command: a thin layer over the public API.

Every command parses its arguments, calls the library and prints; each is testable in-process
with ``main([...])``. Exit codes: 0 success, 1 some work failed, 2 usage or input errors, 141
when whoever read the output went away (``granflow ... | head -1``: the output is cut short
quietly, and the code is the one the shell gives a program stopped by SIGPIPE).
The commands live one group per module (:mod:`~granflow.cli.curve`, :mod:`~granflow.cli.data`,
:mod:`~granflow.cli.simulation`, :mod:`~granflow.cli.campaign`); none imports NumPy, pandas or
matplotlib before it runs, so ``granflow --help`` starts fast.
"""

import argparse
import os
import sys
import traceback

import granflow
from granflow.cli._common import UNITS_RULE, Parser
from granflow.cli.campaign import add_analyze, add_demo
from granflow.cli.curve import add_curve
from granflow.cli.data import add_convert, add_fit, add_inspect
from granflow.cli.forecast import add_forecast
from granflow.cli.simulation import add_simulate, add_stability_map
from granflow.cli.watch import add_watch
from granflow.errors import GranflowError

__all__ = ["PIPE_CLOSED", "build_parser", "main"]

#: The exit code when the output pipe was closed (128 + SIGPIPE, as the shell reports it).
PIPE_CLOSED = 141

_EPILOG = f"""examples:
  granflow curve --a 3.31mN --k 0.036/s --t0 0.23s --Fd 10mN --velocity 0.86um/s
  granflow inspect run1.txt --geometry paper
  granflow convert run1.txt run2.txt -o tidy.csv      (tidy.csv + tidy.csv.json)
  granflow fit run1.txt --interval 2 --window 1s:600s
  granflow simulate switch.yaml --params blue.yaml --plot switch.png
  granflow stability-map --params blue.yaml --switch-points 2s:100s:50 --ratios 0.95:1.2:50
  granflow analyze campaign/ -o results    (your campaign: a folder with a manifest)
  granflow demo -o demo                    (a synthetic campaign, analysed)
  granflow watch run.txt --log run.jsonl   (the forecast, live, while the file grows)
Run 'granflow COMMAND --help' for a command's options and examples.
{UNITS_RULE}
Exit codes: 0 success, 1 some runs failed, 2 bad arguments or input, {PIPE_CLOSED} the output pipe
was closed (e.g. by 'head'; the output stops quietly)."""


def build_parser():
    """The argument parser of the ``granflow`` command (one subparser per command)."""
    parser = Parser(
        prog="granflow",
        description="granflow: the onset of dense granular flow (Farain & Bonn's "
        "aging-rejuvenation friction model).",
        epilog=_EPILOG,
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
        add_watch,
    ):
        add(subparsers)
    return parser


def main(argv=None):
    """Run the command line; returns the exit code (0 ok, 1 some work failed, 2 bad input,
    141 the output pipe was closed)."""
    try:
        code = _main(argv, own_process=argv is None)
        sys.stdout.flush()
    except BrokenPipeError:
        _discard_stdout()
        return PIPE_CLOSED
    return code


def _main(argv, own_process=False):
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits on --help, --version and usage errors
        return int(exc.code or 0)
    if args.command is None:
        parser.print_help()
        return 2
    if own_process and args.command == "watch":
        _keep_out(_WATCH_UNUSED)
    try:
        return args.run(args)
    except BrokenPipeError:
        raise
    except (GranflowError, ImportError) as exc:
        # bad input, a missing optional extra
        return _error(args, exc, 2)
    except OSError as exc:  # a file that cannot be read or written: its name and the reason
        return _error(args, _file_error(exc), 2)
    except Exception as exc:  # a bug: one line, the traceback with --debug
        return _error(args, exc, 1, internal=True)


#: Libraries that load with the watch's and never serve it: pandas loads pyarrow (34 MiB of
#: resident memory) for string columns the readers do not keep, pint loads dask (8 MiB) for
#: arrays it never sees. A watch runs all day beside the instrument software.
_WATCH_UNUSED = ("pyarrow", "dask")


def _keep_out(names):
    """Make ``names`` unimportable in this process, where nothing has imported them yet
    (pandas and pint take them as not installed). Only for a command that owns its process
    (``granflow watch`` from the shell): never inside a caller's interpreter."""
    for name in names:
        sys.modules.setdefault(name, None)


def _file_error(error):
    """An OSError as a sentence naming the file and the reason, not '[Errno 1] ...'."""
    from granflow._files import reason
    from granflow.errors import OutputError

    if error.filename is None:
        return OutputError(reason(error))
    return OutputError(f"{error.filename}: {reason(error)}")


def _discard_stdout():
    """Point the process's stdout at /dev/null, so that the flush at exit raises nothing."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # an in-process stdout without a file descriptor
        pass


def _error(args, exc, code, internal=False):
    if args.debug:
        traceback.print_exc()
    text = f"{type(exc).__name__}: {exc}" if internal else str(exc)
    hint = " (run with --debug for the traceback)" if internal and not args.debug else ""
    print(f"granflow {args.command}: error: {text}{hint}", file=sys.stderr)
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
