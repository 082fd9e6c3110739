"""``granflow inspect``, ``convert`` and ``fit``: instrument exports and curves, read through
:mod:`granflow.io`."""

import sys
from pathlib import Path

import granflow
from granflow.cli._common import UsageError, add_command, quantity
from granflow.errors import FileFormatError, GranflowError

__all__ = ["add_convert", "add_fit", "add_inspect"]


def add_inspect(subparsers):
    """Add the ``inspect`` command."""
    parser = add_command(
        subparsers,
        "inspect",
        _run_inspect,
        help="show what an instrument export holds (format, tests, columns, units, problems)",
        description="Read an instrument export and print its format, encoding, number format, "
        "tests and intervals, columns with units, control mode, row counts and problems.",
        epilog="example:\n  granflow inspect run1.csv",
    )
    parser.add_argument("file", help="the export (RheoCompass, Rheoplus, TRIOS or CSV)")
    parser.add_argument("--format", choices=("rheocompass", "rheoplus", "trios", "csv"))


def _run_inspect(args):
    parsed = granflow.read(args.file, format=args.format)
    print(parsed.report())
    return 0


def _geometry(text):
    if text == "paper":
        return granflow.Annulus.paper()
    parts = text.split(":")
    if len(parts) != 2:
        raise UsageError(
            f"--geometry must be 'paper' or OUTER_DIAMETER:WALL (e.g. 29.7mm:2.3mm), got {text!r}"
        )
    return granflow.Annulus(
        outer_diameter=quantity(parts[0], "outer_diameter", "--geometry outer diameter"),
        wall_thickness=quantity(parts[1], "wall_thickness", "--geometry wall thickness"),
    )


def add_convert(subparsers):
    """Add the ``convert`` command."""
    parser = add_command(
        subparsers,
        "convert",
        _run_convert,
        help="convert instrument exports to one tidy Parquet or CSV table of runs",
        description="Read instrument exports (or a campaign manifest), turn every interval into "
        "a run (time, slip, velocity, friction force in SI units) and save them as one tidy "
        "table. A file that fails is reported and the others are converted (exit code 1).",
        epilog="examples:\n  granflow convert run1.csv run2.txt -o tidy.parquet --geometry paper\n"
        "  granflow convert --manifest campaign.yaml -o tidy.csv",
    )
    parser.add_argument("files", nargs="*", help="export files")
    parser.add_argument("--manifest", help="a campaign manifest (.yaml or .csv)")
    parser.add_argument("-o", "--output", required=True, help="output .parquet or .csv")
    parser.add_argument(
        "--geometry",
        default="paper",
        help="'paper' (29.7 mm tube, 2.3 mm wall; default) or OUTER_DIAMETER:WALL",
    )


def _run_convert(args):
    geometry = _geometry(args.geometry)
    if not args.files and not args.manifest:
        raise UsageError("give export files or --manifest")
    runs, problems = [], []
    if args.manifest:
        campaign = granflow.Campaign.from_manifest(args.manifest, geometry=geometry)
        runs += list(campaign)
        problems += list(campaign.problems)
    for file in args.files:
        try:
            runs += granflow.read_runs(file, geometry=geometry)
        except GranflowError as exc:
            problems.append(str(exc))
    campaign = granflow.Campaign(runs, problems)
    for problem in problems:
        print(f"granflow convert: failed: {problem}", file=sys.stderr)
    if runs:
        path = campaign.save(args.output)
        points = sum(len(run) for run in runs)
        print(f"wrote {len(runs)} runs ({points} points) to {path}")
    return 1 if problems else 0


_EPILOG_FIT = """examples:
  granflow fit run1.csv                         (columns e.g. 'slip [um]', 'force [mN]')
  granflow fit run1.csv --domain time --velocity 0.86um/s --fix Fd=10mN
  granflow fit run1.csv --window 1s:600s --json
The CSV needs a time or slip column and a force column, each with its unit in the header:
'time [s]', 't (min)', 'slip [µm]', 'force [mN]', or granflow's own 'time_s', 'force_N'."""

#: The header names of the columns a curve file may hold, by the quantity they measure.
_COLUMN_KINDS = {
    "time": ("time", "t"),
    "slip": ("slip", "x", "displacement"),
    "force": ("force", "f", "friction"),
}


def _kind_and_unit(name, unit):
    """(kind or None, unit or None) of a header as io split it; 'force_N' carries its unit
    after the underscore."""
    if not unit:
        base, _, suffix = name.rpartition("_")
        name, unit = (base, suffix) if base and suffix else (name, None)
    label = name.strip().lower()
    kind = next((kind for kind, names in _COLUMN_KINDS.items() if label in names), None)
    return kind, label, unit


def _read_curve(path):
    """{'time'|'slip'|'force': SI array} from a CSV whose headers carry units, read with
    :func:`granflow.io.read` and a column map of the columns found by name."""
    if not Path(path).is_file():
        raise FileFormatError(f"{path}: no such file")
    header = granflow.io.read(path, format="csv", only_mapped=True).intervals[0].columns
    column_map, units = {}, {}
    for column in header:
        kind, label, unit = _kind_and_unit(column.name, column.unit)
        if kind is None or kind in column_map:
            continue
        if unit is None:
            raise FileFormatError(
                f"{path}: column {column.name!r} has no unit; write it as '{label} [unit]'"
            )
        column_map[kind] = column.name
        units[column.name] = unit
    if "force" not in column_map or not ({"time", "slip"} & column_map.keys()):
        found = ", ".join(f"{c.name} [{c.unit}]" if c.unit else c.name for c in header)
        raise FileFormatError(
            f"{path}: need a force column and a time or slip column, found {found}"
        )
    parsed = granflow.io.read(
        path, format="csv", column_map=column_map, units=units, only_mapped=True, strict=True
    )
    interval = parsed.intervals[0]
    return {kind: interval.si(kind) for kind in column_map}


def add_fit(subparsers):
    """Add the ``fit`` command."""
    parser = add_command(
        subparsers,
        "fit",
        _run_fit,
        help="fit Eq. 3 to a friction curve in a CSV file",
        description="Fit the aging-rejuvenation model (Eq. 3) to one friction curve, with no "
        "initial guess, and print the parameters with standard errors and 95 % intervals.",
        epilog=_EPILOG_FIT,
    )
    parser.add_argument("data", help="CSV file with a time or slip column and a force column")
    parser.add_argument(
        "--domain",
        choices=("slip", "time"),
        help="fit F(slip) with a, alpha, Fd, x0 or F(t) with a, k, Fd, t0 "
        "(default: slip when the file has a slip column)",
    )
    parser.add_argument(
        "--fix",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="hold a parameter fixed, e.g. --fix Fd=10mN (repeatable)",
    )
    parser.add_argument("--velocity", help="sliding velocity, e.g. 0.86um/s (time domain)")
    parser.add_argument("--window", help="fit window START:STOP with units, e.g. 1s:600s")
    parser.add_argument("--sigma", help="known force noise, e.g. 0.05mN")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")


def _run_fit(args):
    import json

    from granflow.fitting.single import parameter_names

    columns = _read_curve(args.data)
    domain = args.domain or ("slip" if "slip" in columns else "time")
    abscissa = "slip" if domain == "slip" else "time"
    if abscissa not in columns:
        raise UsageError(f"--domain {domain} needs a {abscissa} column in {args.data}")
    names = parameter_names(domain)
    fixed = {}
    for item in args.fix:
        name, sep, value = item.partition("=")
        if not sep or name not in names:
            raise UsageError(
                f"--fix must be NAME=VALUE with NAME one of {', '.join(names)}, got {item!r}"
            )
        fixed[name] = quantity(value, name, f"--fix {name}")
    window = None
    if args.window:
        start, sep, stop = args.window.partition(":")
        if not sep:
            raise UsageError(f"--window must be START:STOP, got {args.window!r}")
        window = (
            quantity(start, abscissa, "--window start"),
            quantity(stop, abscissa, "--window stop") if stop else None,
        )
    velocity = quantity(args.velocity, "velocity", "--velocity") if args.velocity else None
    sigma = quantity(args.sigma, "sigma", "--sigma") if args.sigma else None
    result = granflow.fit(
        (columns[abscissa], columns["force"]),
        domain=domain,
        velocity=velocity,
        fixed=fixed,
        window=window,
        sigma=sigma,
    )
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(f"fit of {args.data}")
        print(result.report())
    return 0 if result.success else 1
