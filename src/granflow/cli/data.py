"""``granflow inspect``, ``convert`` and ``fit``: files to runs, tidy tables and fits.

``convert`` and ``fit`` read every file granflow reads (:func:`load_runs`): instrument exports
(RheoCompass, Rheoplus, TRIOS, and CSV with instrument columns such as 'Torque [mN·m]'),
plain CSV whose header names a force column and a time or slip column with units, and the tidy
tables ``convert`` writes (:mod:`granflow.io.tidy`).
"""

import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import granflow
from granflow.cli._common import (
    UsageError,
    add_command,
    add_geometry_option,
    check_outputs,
    describe_geometry,
    geometry_choice,
    plural,
    positive_int,
    quality_text,
    quantity,
)
from granflow.errors import FileFormatError, GranflowError

__all__ = ["add_convert", "add_fit", "add_inspect", "load_runs"]


@dataclass(frozen=True)
class Source:
    """The runs of one file and the geometry that made their forces and slips.

    ``geometry`` is a :meth:`GeometryChoice.to_dict` mapping, or None where the file gave the
    friction force itself (a plain table; a tidy table without its metadata).
    """

    runs: list
    geometry: dict | None


def load_runs(path, choice):
    """The runs of any file granflow reads, with the geometry used (see :class:`Source`).

    Parameters
    ----------
    path : str or pathlib.Path
        A tidy table ``convert`` wrote, an instrument export, or a plain CSV.
    choice : GeometryChoice
        Converts torque, angle and speed where the file holds them.
    """
    from granflow.io import tidy

    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such file")
    if tidy.is_tidy_table(path):
        table = tidy.read_tidy(path)
        return Source(list(table.runs), table.geometry)
    import numpy as np

    try:  # an export, or a table with instrument or granflow's columns: read once
        # a table is read strictly: a cell that is not a number is an error naming its line
        form = granflow.io.detect_file_format(path)
        options = {"strict": True} if form == "csv" else {}
        runs = granflow.io.read_runs(path, geometry=choice.annulus, format=form, **options)
        failure = None
    except FileFormatError as exc:  # perhaps a table whose columns are not instrument data
        runs, failure = [], exc
    if any(np.isfinite(run.force).any() for run in runs):
        return Source(runs, choice.to_dict())
    try:
        columns = granflow.io.read(path, format="csv", only_mapped=True).intervals[0].columns
    except FileFormatError:
        columns = ()
    if _force_columns(columns, path):
        return Source([_table_run(path, columns)], None)
    if failure is not None:
        raise failure
    raise FileFormatError(
        f"{path}: {_NEEDS}; none of its {plural(len(runs), 'interval')} has a force or torque"
    )


# --------------------------------------------------------------------------- inspect


def add_inspect(subparsers):
    """Add the ``inspect`` command."""
    parser = add_command(
        subparsers,
        "inspect",
        _run_inspect,
        help="show what an instrument export holds (format, tests, columns, units, problems)",
        description="Read an instrument export and print its format, encoding, number format, "
        "tests and intervals, columns with units, control mode, row counts and problems; then "
        "each interval as a run (time, slip, velocity, force) through the geometry.",
        epilog="example:\n"
        "  granflow inspect run1.txt --geometry outer_diameter=30mm,wall_thickness=2mm",
    )
    parser.add_argument("file", help="the export (RheoCompass, Rheoplus, TRIOS or CSV)")
    parser.add_argument("--format", choices=("rheocompass", "rheoplus", "trios", "csv"))
    add_geometry_option(parser)


def _run_inspect(args):
    choice = geometry_choice(args.geometry)
    parsed = granflow.read(args.file, format=args.format)
    report = parsed.report()
    print(report)
    print(f"geometry:  {choice.describe()}")
    try:
        runs = granflow.io.read_runs(args.file, geometry=choice.annulus, format=args.format)
    except GranflowError as exc:
        print(f"as runs:   none ({exc})")
        return 0
    print(f"as runs:   {plural(len(runs), 'run')} [display units]")
    for number, run in enumerate(runs, start=1):
        print(f"[{number}] {plural(len(run), 'point')}, {run.control} control: {_ranges(run)}")
        for problem in run.problems:
            if problem not in report:
                print(f"      problem: {problem}")
    return 0


def _ranges(run):
    """'t 0 to 19 s; slip none; ...': the finite range of each column in display units."""
    import numpy as np

    from granflow.model.units import display_unit, to_display

    parts = []
    for name in ("t", "slip", "velocity", "force"):
        values = getattr(run, name)
        finite = values[np.isfinite(values)]
        if finite.size == 0:
            parts.append(f"{name} none")
            continue
        low, high = (to_display(name, float(value)) for value in (finite.min(), finite.max()))
        parts.append(f"{name} {low:.4g} to {high:.4g} {display_unit(name)}")
    return "; ".join(parts)


# --------------------------------------------------------------------------- convert


def add_convert(subparsers):
    """Add the ``convert`` command."""
    parser = add_command(
        subparsers,
        "convert",
        _run_convert,
        help="convert instrument exports to one tidy CSV or Parquet table of runs",
        description="Read instrument exports, plain CSV tables or a campaign manifest, turn "
        "every interval into a run (time, slip, velocity, friction force in SI units) and save "
        "them as one tidy table that pandas.read_csv reads as it is. A file that fails is "
        "reported and the others are converted (exit code 1).",
        epilog="examples:\n  granflow convert run1.txt run2.txt -o tidy.csv --geometry paper\n"
        "  granflow convert --manifest campaign.yaml -o tidy.parquet\n" + _TABLE,
    )
    parser.add_argument("files", nargs="*", help="export files")
    parser.add_argument("--manifest", help="a campaign manifest (.yaml or .csv)")
    parser.add_argument(
        "--allow-outside",
        action="store_true",
        help="read files the manifest names outside its folder (refused by default)",
    )
    parser.add_argument("-o", "--output", required=True, help="output .csv or .parquet")
    add_geometry_option(parser)


_TABLE = (
    "The table has one row per point, columns run, source, interval, control, t_s, slip_m,\n"
    "velocity_m_s, force_N (SI; empty where unknown); pandas.read_csv reads it as it is. Each\n"
    "run's metadata and data-quality problems, the files that failed and the geometry are in\n"
    "TABLE.json beside a CSV (tidy.csv -> tidy.csv.json), in the metadata of a Parquet table."
)


def _run_convert(args):
    from granflow.io import tidy

    choice = geometry_choice(args.geometry)
    if Path(args.output).suffix.lower() not in tidy.SUFFIXES:
        raise UsageError(f"-o must end in .csv or .parquet, got {Path(args.output).name!r}")
    if not args.files and not args.manifest:
        raise UsageError("give export files or --manifest")
    check_outputs(args)
    runs, failures = [], []
    if args.manifest:
        campaign = granflow.Campaign.from_manifest(
            args.manifest,
            geometry=choice.annulus if choice.given else None,
            allow_outside=args.allow_outside,
        )
        runs += list(campaign)
        failures += list(campaign.problems)
    for file in args.files:
        try:
            runs += load_runs(file, choice).runs
        except GranflowError as exc:
            failures.append(str(exc))
    for failure in failures:
        print(f"granflow convert: failed: {failure}", file=sys.stderr)
    if runs:
        path = tidy.write_tidy(args.output, runs, problems=failures, geometry=choice.to_dict())
        metadata = tidy.metadata_location(path)
        points = sum(len(run) for run in runs)
        print(
            f"wrote {plural(len(runs), 'run')} ({plural(points, 'point')}) to {path}, "
            f"metadata in {metadata}"
        )
        print(f"geometry: {choice.describe()}")
        damaged = sum(1 for run in runs if run.problems)
        if damaged:
            print(f"data quality: {plural(damaged, 'run')} with problems, listed in {metadata}")
    return 1 if failures else 0


# --------------------------------------------------------------------------- fit

_EPILOG_FIT = """examples:
  granflow fit run1.txt --interval 2                (an instrument export: its 2nd interval)
  granflow fit tidy.csv --interval 3                (the 3rd run of what 'convert' wrote)
  granflow fit curve.csv --domain time --velocity 0.86um/s --fix Fd=10mN --json
  granflow fit run1.txt --window 1s:600s --geometry outer_radius=15mm,inner_radius=12.5mm
  granflow fit velstep.txt --model rsf --law aging  (a velocity-step record: a, b, Dc, k)
  granflow fit velstep.txt --model rsf --law slip --detrend --steps 68.6s --json
  granflow fit velstep.txt --model rsf --law slip --periodic --window 0s:1485s
                                                  (an apparatus ripple in load-point slip)
A plain CSV needs a force column and a time or slip column, each with its unit in the header:
'time [s]', 't (min)', 'slip [µm]', 'force [mN]', or granflow's own 't_s', 'force_N'. The
data-quality problems the reader found are printed with the fit and kept in --json's
'problems'; --strict makes them an error (exit 1)."""

_NEEDS = (
    "need a force column ('force [mN]') or a torque column ('Torque [mN·m]'), and a time or "
    "slip column"
)

#: The header names of the columns a curve file may hold, by the quantity they measure.
_COLUMN_KINDS = {
    "time": ("time", "t"),
    "slip": ("slip", "x", "displacement"),
    "force": ("force", "f", "friction"),
}


def _kind_and_unit(name, unit):
    """(kind or None, label, unit or None) of a header as io split it; 'force_N' carries its
    unit after the underscore."""
    if not unit:
        base, _, suffix = name.rpartition("_")
        name, unit = (base, suffix) if base and suffix else (name, None)
    label = name.strip().lower()
    kind = next((kind for kind, names in _COLUMN_KINDS.items() if label in names), None)
    return kind, label, unit


def _force_columns(columns, path):
    """Whether a table names a force column (and then a time or slip column)."""
    kinds = {_kind_and_unit(column.name, column.unit)[0] for column in columns}
    if "force" not in kinds:
        return False
    if not kinds & {"time", "slip"}:
        raise FileFormatError(f"{path}: {_NEEDS}, found {_header_text(columns)}")
    return True


def _header_text(columns):
    return ", ".join(f"{c.name} [{c.unit}]" if c.unit else c.name for c in columns[:12])


def _table_run(path, columns):
    """The Run of a plain table (force and time or slip by name), read with a column map."""
    import numpy as np

    column_map, units = {}, {}
    for column in columns:
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
        raise FileFormatError(f"{path}: {_NEEDS}, found {_header_text(columns)}")
    parsed = granflow.io.read(
        path, format="csv", column_map=column_map, units=units, only_mapped=True, strict=True
    )
    interval = parsed.intervals[0]
    missing = np.full(interval.rows, np.nan)
    values = {kind: interval.si(kind) for kind in column_map}
    return granflow.Run(
        t=values.get("time", missing),
        slip=values.get("slip", missing),
        velocity=missing,
        force=values["force"],
        meta={"source": str(path), "interval": 1},
        problems=(*parsed.problems, *interval.problems),
    )


def add_fit(subparsers):
    """Add the ``fit`` command."""
    parser = add_command(
        subparsers,
        "fit",
        _run_fit,
        help="fit Eq. 3 to one friction curve (an export's interval, a table, a tidy run)",
        description="Fit the aging-rejuvenation model (Eq. 3) to one friction curve, with no "
        "initial guess, and print the parameters with standard errors and 95 % intervals. "
        "The record's time is the model's time t (0 when shearing starts).",
        epilog=_EPILOG_FIT,
    )
    parser.add_argument(
        "data", help="an instrument export, a CSV table, or a tidy table from 'granflow convert'"
    )
    parser.add_argument(
        "--interval",
        type=positive_int,
        metavar="N",
        help="which interval (or run of a tidy table) to fit, 1-based in file order; needed "
        "when the file holds several",
    )
    parser.add_argument(
        "--domain",
        choices=("slip", "time"),
        help="fit F(slip) with a, alpha, Fd, x0 or F(t) with a, k, Fd, t0 "
        "(default: slip when the run has a slip, else time)",
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
    add_geometry_option(parser)
    parser.add_argument(
        "--strict", action="store_true", help="a data-quality problem is an error (exit 1)"
    )
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    rsf = parser.add_argument_group(
        "rate-and-state (--model rsf)",
        "a velocity-step record: 'Time(s)', 'Displ(microns)', 'Friction' (units in the "
        "header); the load-point velocity history comes from the displacement",
    )
    parser.add_argument(
        "--model",
        choices=("eq3", "rsf"),
        default="eq3",
        help="eq3: the aging-rejuvenation model (default); rsf: rate-and-state on a spring",
    )
    rsf.add_argument("--law", default="aging", choices=("aging", "slip", "prz"))
    rsf.add_argument("--states", type=positive_int, default=1, help="state variables (1 or 2)")
    rsf.add_argument("--detrend", action="store_true", help="fit a linear trend in slip")
    rsf.add_argument(
        "--steps", help="the step times, e.g. 68.6s or 100s,250s (default: found automatically)"
    )
    noise = rsf.add_mutually_exclusive_group()
    noise.add_argument(
        "--correlated-noise",
        action="store_true",
        help="always scale the uncertainties by the residuals' correlation time (by default "
        "they are scaled whenever the residuals are correlated, as on real records)",
    )
    noise.add_argument(
        "--white-noise",
        action="store_true",
        help="take the noise as white even where the residuals are correlated (the "
        "intervals are then too narrow on a real record; for simulated records)",
    )
    rsf.add_argument(
        "--periodic",
        action="store_true",
        help="fit an apparatus ripple periodic in load-point displacement (a drive screw), "
        "its wavelength found from the residuals (or starting at --wavelength)",
    )
    rsf.add_argument(
        "--wavelength",
        metavar="LENGTH",
        help="the ripple's starting wavelength, with its unit, e.g. 87um (implies --periodic)",
    )
    rsf.add_argument(
        "--harmonics",
        type=positive_int,
        default=2,
        help="harmonics of the ripple (default 2)",
    )


def _choose(runs, interval, path):
    """(run, label) of ``--interval`` among a file's runs."""
    count = len(runs)
    if count == 0:
        raise FileFormatError(f"{path}: no data to fit")
    if interval is None and count > 1:
        raise UsageError(
            f"{path} holds {plural(count, 'interval')}: choose one with --interval N (1 to "
            f"{count}); 'granflow inspect {path}' lists them"
        )
    interval = interval or 1
    if interval > count:
        raise UsageError(f"--interval {interval}: {path} holds {plural(count, 'interval')}")
    label = str(path) if count == 1 else f"{path}, interval {interval} of {count}"
    return runs[interval - 1], label


def _fit_options(args, domain):
    """The keyword arguments of :func:`granflow.fit` that the options give."""
    from granflow.fitting.single import parameter_names

    names = parameter_names(domain)
    fixed = {}
    for item in args.fix:
        name, sep, value = item.partition("=")
        if not sep or name not in names:
            raise UsageError(
                f"--fix must be NAME=VALUE with NAME one of {', '.join(names)}, got {item!r}"
            )
        fixed[name] = quantity(value, name, f"--fix {name}")
    abscissa = "slip" if domain == "slip" else "time"
    window = None
    if args.window:
        start, sep, stop = args.window.partition(":")
        if not sep:
            raise UsageError(f"--window must be START:STOP, got {args.window!r}")
        window = (
            quantity(start, abscissa, "--window start"),
            quantity(stop, abscissa, "--window stop") if stop else None,
        )
    return {
        "domain": domain,
        "velocity": quantity(args.velocity, "velocity", "--velocity") if args.velocity else None,
        "fixed": fixed,
        "window": window,
        "sigma": quantity(args.sigma, "sigma", "--sigma") if args.sigma else None,
    }


def _run_fit(args):
    import json

    import numpy as np

    from granflow._json import json_safe

    if args.model == "rsf":
        from granflow.cli.fit_rsf import run_fit_rsf

        return run_fit_rsf(args)
    from granflow.io.velocity_steps import is_velocity_step_file

    if Path(args.data).is_file() and is_velocity_step_file(args.data):
        raise UsageError(
            f"{args.data} is a velocity-step record (time, load-point displacement, friction "
            "coefficient), not a friction curve of Eq. 3: fit it with --model rsf"
        )
    choice = geometry_choice(args.geometry)
    source = load_runs(args.data, choice)
    if choice.given and source.geometry is None:
        raise UsageError(
            f"--geometry does not apply to {args.data}: it gives the friction force, not torque"
        )
    run, label = _choose(source.runs, args.interval, args.data)
    problems = list(run.problems)
    if args.strict and problems:
        print(
            f"granflow fit: error: {label} has {plural(len(problems), 'data-quality problem')} "
            f"(--strict): {'; '.join(problems)}",
            file=sys.stderr,
        )
        return 1
    domain = args.domain or ("slip" if np.isfinite(run.slip).any() else "time")
    if not np.isfinite(run.slip if domain == "slip" else run.t).any():
        column = "a slip (or deflection angle)" if domain == "slip" else "a time"
        raise UsageError(f"--domain {domain} needs {column} column in {label}")
    slip = run.slip[np.isfinite(run.slip) & np.isfinite(run.force)]
    if args.domain is None and args.window is None and np.any(np.diff(slip) <= 0):
        raise UsageError(
            f"{label}: the slip stands still or goes back (a creep or stress-controlled "
            "record?), so it cannot be the abscissa: fit the force against time with "
            "--domain time (and --velocity), or choose the sliding part with --window"
        )
    options = _fit_options(args, domain)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = granflow.fit(run, **options)
        except GranflowError as exc:
            raise type(exc)(f"{label}: {exc}") from None
    # the caveats granflow gives (ConvergenceWarning); NumPy's floating-point notes are noise here
    notes = (str(item.message) for item in caught if issubclass(item.category, UserWarning))
    for message in dict.fromkeys(notes):
        print(f"granflow fit: warning: {message}", file=sys.stderr)
    if args.json:
        payload = result.to_dict()
        payload["problems"] = problems
        payload["record"] = json_safe(
            {
                "source": str(args.data),
                "interval": run.meta.get("interval"),
                "test": run.meta.get("test"),
                "control": run.control,
                "points": len(run),
                "geometry": source.geometry,
            }
        )
        print(json.dumps(payload, indent=2))
    else:
        details = [f"{run.control} control", plural(len(run), "point")]
        if run.meta.get("test"):
            details.insert(0, f"test {run.meta['test']!r}")
        print(f"fit of {label} ({', '.join(details)})")
        print(f"geometry: {_geometry_text(source.geometry)}")
        print(quality_text(problems))
        print(result.report())
        print(_display_text(result))
    return 0 if result.success else 1


def _geometry_text(geometry):
    if geometry is None:
        return "not used (the file gives the friction force)"
    return describe_geometry(geometry)


def _display_text(result):
    """The fitted values with standard errors in display units (mN, µm, ...)."""
    from granflow.model.units import display_unit, to_display

    parts = []
    for name in result.names:
        value = to_display(name, result.params[name])
        error = to_display(name, result.stderr[name])
        unit = display_unit(name)
        parts.append(f"{name} = {value:.6g} ± {error:.2g} {unit}".rstrip())
    return "[[Display units]]\n    " + "\n    ".join(parts)
