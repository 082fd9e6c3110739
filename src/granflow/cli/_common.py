"""What the commands share: the parser, the usage error, quantities and the geometry from
arguments, plurals, output files."""

import argparse
import math
import re
from dataclasses import dataclass

from granflow.errors import GranflowError

__all__ = [
    "GeometryChoice",
    "Parser",
    "UsageError",
    "add_command",
    "add_geometry_option",
    "check_outputs",
    "describe_geometry",
    "geometry_choice",
    "plural",
    "positive_int",
    "quality_text",
    "quantity",
    "write_outputs",
    "written_names",
]

#: A word that starts like a negative number ("-0.86um/s", "-.5mN", "-3e-6m/s") is a value.
_NEGATIVE_VALUE = re.compile(r"^-\.?\d")

#: What every command's help says about units.
UNITS_RULE = (
    "Every physical value needs its unit, e.g. 3.31mN, 0.86um/s, -0.86um/s, 2.16/min, "
    "'860 nm/s' (any pint expression); a bare number is an error (0 and ratios excepted)."
)


class UsageError(GranflowError, ValueError):
    """Raised by commands for inconsistent arguments; reported with exit code 2."""


class Parser(argparse.ArgumentParser):
    """An ArgumentParser that reads a negative quantity such as ``-0.86um/s`` as a value.

    argparse takes any word that starts with "-" for an option unless it is a plain negative
    number ("-0.86"); a quantity with a unit is a value too. No option of granflow starts with
    a digit, so nothing is lost.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NEGATIVE_VALUE


def add_command(subparsers, name, run, *, help, description, epilog):
    """Add the subparser of one command; ``run(args) -> int`` is what it does.

    The help text keeps its line breaks, so the examples in ``epilog`` read as written; the
    rule on units closes it.
    """
    parser = subparsers.add_parser(
        name,
        help=help,
        description=description,
        epilog=f"{epilog}\n{UNITS_RULE}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.set_defaults(run=run)
    return parser


def plural(count, noun, nouns=None):
    """``"1 run"``, ``"2 runs"``, ``"0 runs"``; ``nouns`` for an irregular plural."""
    return f"{count} {noun if count == 1 else nouns or noun + 's'}"


def _require_unit(text, name, flag, example):
    """Refuse a bare number (other than 0) for a quantity that has a unit."""
    from granflow.model.units import QUANTITIES, display_unit

    if QUANTITIES[name].si in ("", "1"):
        return
    try:
        value = float(str(text).strip())
    except ValueError:
        return
    if math.isfinite(value) and value != 0:
        typed = str(text).strip()
        units = dict.fromkeys(
            u.replace("µ", "u") for u in (QUANTITIES[name].si, display_unit(name))
        )
        choices = " or ".join(example(typed + _after_number(unit)) for unit in units)
        raise UsageError(
            f"{flag} needs a unit ({QUANTITIES[name].label}): the bare number {typed} is not "
            f"taken as SI; write e.g. {choices}"
        )


def _after_number(unit):
    """A unit as written right after a number: "1/s" -> "/s", "N s/m" -> "N*s/m"."""
    return unit[1:] if unit.startswith("1/") else unit.replace(" ", "*")


def quantity(text, name, flag):
    """The value of an argument such as "3.31mN" in the SI unit of the quantity ``name``.

    Parameters
    ----------
    text : str
        The argument as given: a number with its unit or a pint expression ("-0.86 um/s",
        "2.16/min"). A bare number is refused (it would silently be SI), except 0 and the
        values of dimensionless quantities.
    name : str
        A key of :data:`granflow.model.units.QUANTITIES` ("a", "velocity", ...).
    flag : str
        The option, for error messages ("--velocity").

    Raises
    ------
    UsageError
        A bare number for a quantity with a unit; the message names the option and its unit.
    granflow.InvalidParameterError
        Text that is not a quantity of the right dimension.
    """
    from granflow.model.units import parse_quantity, si_unit

    _require_unit(text, name, flag, lambda typed: f"{flag} {typed}")
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


@dataclass(frozen=True)
class GeometryChoice:
    """The tube a command converts torque, angle and speed with, and how it was chosen.

    Attributes
    ----------
    annulus : granflow.Annulus
        The contact.
    spec : str
        ``--geometry`` as typed, or ``"paper (default)"``.
    given : bool
        Whether ``--geometry`` was given.
    """

    annulus: object
    spec: str
    given: bool

    def describe(self):
        """One line: the spec and the two radii it gives [mm]."""
        return describe_geometry(self.to_dict())

    def to_dict(self):
        """JSON-safe: the spec and the annulus's lengths [m]."""
        tube = self.annulus
        return {
            "spec": self.spec,
            "outer_diameter": tube.outer_diameter,
            "wall_thickness": tube.wall_thickness,
            "torque_radius": tube.torque_radius,
            "effective_radius": tube.effective_radius,
            "mean_radius": tube.mean_radius,
        }


def describe_geometry(geometry):
    """One line from a :meth:`GeometryChoice.to_dict` mapping: the spec and its radii [mm]."""
    return (
        f"{geometry['spec']}: r_eff = {geometry['effective_radius'] * 1e3:.6g} mm (torque to "
        f"force), r_m = {geometry['mean_radius'] * 1e3:.6g} mm (angle and speed to slip and "
        "velocity)"
    )


_GEOMETRY_HELP = (
    "the tube that turns torque, angle and speed into force, slip and velocity: 'paper' "
    "(29.7 mm outer diameter, 2.3 mm wall; the default) or key=value pairs with units, e.g. "
    "outer_diameter=30mm,wall_thickness=2mm (or outer_radius and inner_radius, or "
    "effective_radius and mean_radius)"
)


def add_geometry_option(parser):
    """Add ``--geometry SPEC`` (read by :func:`geometry_choice`)."""
    parser.add_argument("--geometry", metavar="SPEC", help=_GEOMETRY_HELP)


def geometry_choice(text):
    """The :class:`GeometryChoice` of a ``--geometry`` argument (None: the paper's tube).

    The spec is read by :meth:`granflow.Annulus.from_spec`; each length needs its unit here,
    as every quantity on the command line.
    """
    from granflow.model.geometry import Annulus

    if text is None:
        return GeometryChoice(Annulus.paper(), "paper (default)", False)
    for item in text.split(","):
        key, sep, value = item.partition("=")
        if sep:
            key = key.strip()
            length = key if key in ("outer_diameter", "wall_thickness") else "radius"
            _require_unit(
                value, length, f"--geometry {key}", lambda typed, key=key: f"{key}={typed}"
            )
    return GeometryChoice(Annulus.from_spec(text), text.strip(), True)


def check_outputs(args):
    """Refuse ``-o``/``--output`` and ``--plot`` files that cannot be written, before any work
    (:class:`granflow.OutputError` naming the file and the reason)."""
    from granflow._files import writable_file

    if getattr(args, "output", None):
        writable_file(args.output, "output file")
    if getattr(args, "plot", None):
        writable_file(args.plot, "figure")


def written_names(quantities):
    """{column: the name granflow writes it under} for columns holding the quantities of
    :data:`granflow.model.units.QUANTITIES` ("t" -> "t_s", "failure_force" -> "failure_force_N");
    one name per quantity in every CSV, which every command reads back."""
    from granflow.model.units import column_name

    return {name: column_name(name, quantity) for name, quantity in quantities.items()}


def write_outputs(args, frame, rows, axes, quantities=None):
    """Write ``frame()`` to ``args.output`` (CSV) and the figure of ``axes()`` to ``args.plot``;
    ``rows`` names one row ("point", "cell"); ``quantities`` ({column: quantity}) gives the
    columns their units in their names (:func:`written_names`)."""
    if args.output:
        table = frame()
        if quantities:
            table = table.rename(columns=written_names(quantities))
        table.to_csv(args.output, index=False, float_format="%.17g")
        print(f"wrote {plural(len(table), rows)} to {args.output}")
    if args.plot:
        axes().figure.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")


def quality_text(problems):
    """The data-quality line (and one line per problem)."""
    if not problems:
        return "data quality: no problems recorded by the reader"
    lines = [f"data quality: {plural(len(problems), 'problem')} (kept in --json's 'problems')"]
    return "\n".join([*lines, *(f"  - {problem}" for problem in problems)])
