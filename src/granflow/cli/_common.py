"""What the commands share: the usage error, quantities from arguments, output files."""

import argparse

from granflow.errors import GranflowError

__all__ = ["UsageError", "add_command", "positive_int", "quantity", "write_outputs"]


class UsageError(GranflowError, ValueError):
    """Raised by commands for inconsistent arguments; reported with exit code 2."""


def add_command(subparsers, name, run, *, help, description, epilog):
    """Add the subparser of one command; ``run(args) -> int`` is what it does.

    The help text keeps its line breaks, so the examples in ``epilog`` read as written.
    """
    parser = subparsers.add_parser(
        name,
        help=help,
        description=description,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.set_defaults(run=run)
    return parser


def quantity(text, name, flag):
    """The value of an argument such as "3.31mN" in the SI unit of the quantity ``name``.

    Parameters
    ----------
    text : str
        The argument as given; a plain number is taken as SI.
    name : str
        A key of :data:`granflow.model.units.QUANTITIES` ("a", "velocity", ...).
    flag : str
        The option, for error messages ("--velocity").
    """
    from granflow.model.units import parse_quantity, si_unit

    return parse_quantity(text, si_unit(name), flag)


def positive_int(text):
    """argparse type: an integer of at least 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def write_outputs(args, frame, rows, axes):
    """Write ``frame()`` to ``args.output`` (CSV) and the figure of ``axes()`` to ``args.plot``."""
    if args.output:
        table = frame()
        table.to_csv(args.output, index=False, float_format="%.17g")
        print(f"wrote {len(table)} {rows} to {args.output}")
    if args.plot:
        axes().figure.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")
