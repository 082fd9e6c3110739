"""The ``granflow`` command: a thin layer over the public API.

Every command parses its arguments, calls the library and prints; each is testable in-process
with ``main([...])``. Exit codes: 0 success, 1 some work failed, 2 usage or input errors.
"""

import argparse
import contextlib
import sys
import traceback
from pathlib import Path

import numpy as np

import granflow
import granflow.model.units
from granflow.errors import GranflowError
from granflow.model.units import parse_quantity
from granflow.plotting import plot_simulation, plot_stability_map

__all__ = ["build_parser", "main"]

_EPILOG_CURVE = """examples:
  granflow curve --a 3.31mN --k 0.036/s --t0 0.23s --Fd 10mN --velocity 0.86um/s
  granflow curve --a 3.31mN --alpha 4.19e4/m --x0 0.198um --Fd 10mN -o curve.csv
Plain numbers are SI (N, 1/s, s, m/s, 1/m, m)."""


class _UsageError(GranflowError, ValueError):
    """Raised by commands for inconsistent arguments; reported with exit code 2."""


def _add_curve(subparsers):
    parser = subparsers.add_parser(
        "curve",
        help="evaluate the model curve (Eq. 3) and print its peak",
        description="Evaluate the friction transient of Eq. 3 under a constant velocity, print "
        "the static yield point (peak) and optionally write the curve as CSV.",
        epilog=_EPILOG_CURVE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--a", required=True, help="aging amplitude, e.g. 3.31mN [N]")
    parser.add_argument("--Fd", required=True, help="steady-state friction, e.g. 10mN [N]")
    parser.add_argument("--k", help="rejuvenation rate alpha*v, e.g. 0.036/s [1/s]")
    parser.add_argument("--t0", help="initial-state time, e.g. 0.23s [s]")
    parser.add_argument("--alpha", help="rejuvenation constant, e.g. 4.19e4/m [1/m]")
    parser.add_argument("--x0", help="initial state as a slip, e.g. 0.198um [m]")
    parser.add_argument(
        "--velocity", default="0.86um/s", help="sliding velocity (default 0.86um/s) [m/s]"
    )
    parser.add_argument(
        "--duration", help="time span of the curve (default: 20 times the peak time) [s]"
    )
    parser.add_argument("--points", type=int, default=400, help="points on the curve (default 400)")
    parser.add_argument("-o", "--output", help="write the curve to this CSV file")
    parser.set_defaults(run=_run_curve)


def _curve_params(args):
    velocity = parse_quantity(args.velocity, "m/s", "--velocity")
    a = parse_quantity(args.a, "N", "--a")
    Fd = parse_quantity(args.Fd, "N", "--Fd")
    time_domain = args.k is not None or args.t0 is not None
    slip_domain = args.alpha is not None or args.x0 is not None
    if (
        time_domain == slip_domain
        or (time_domain and None in (args.k, args.t0))
        or (slip_domain and None in (args.alpha, args.x0))
    ):
        raise _UsageError(
            "give either --k and --t0 (time domain) or --alpha and --x0 (slip domain)"
        )
    if time_domain:
        params = granflow.Params.from_time_domain(
            a=a,
            k=parse_quantity(args.k, "1/s", "--k"),
            t0=parse_quantity(args.t0, "s", "--t0"),
            Fd=Fd,
            velocity=velocity,
        )
    else:
        params = granflow.Params(
            a=a,
            alpha=parse_quantity(args.alpha, "1/m", "--alpha"),
            Fd=Fd,
            x0=parse_quantity(args.x0, "m", "--x0"),
        )
    return params, velocity


def _run_curve(args):
    params, velocity = _curve_params(args)
    if args.points < 2:
        raise _UsageError(f"--points must be at least 2, got {args.points}")
    top = granflow.peak(params, velocity=velocity)
    t0 = params.t0(velocity)
    duration = parse_quantity(args.duration, "s", "--duration") if args.duration else 20 * top.time
    if duration <= t0:
        raise _UsageError(f"--duration must exceed t0 = {t0:.6g} s, got {duration:.6g} s")
    time = np.geomspace(t0, duration, args.points)
    force = granflow.friction_time(time, params, velocity)
    print(f"parameters: {params!r}")
    print(
        f"velocity:   {velocity * 1e6:.6g} um/s  "
        f"(k = {params.k(velocity):.6g} 1/s, t0 = {t0:.6g} s)"
    )
    print(
        f"peak:       F = {top.force * 1e3:.10g} mN at t = {top.time:.10g} s, "
        f"slip = {top.slip * 1e6:.10g} um"
    )
    print(f"steady:     Fd = {params.Fd * 1e3:.6g} mN")
    if args.output:
        import pandas as pd

        frame = pd.DataFrame({"time_s": time, "slip_m": velocity * time, "force_N": force})
        frame.to_csv(args.output, index=False, float_format="%.17g")
        print(f"wrote {len(frame)} points to {args.output}")
    else:
        for index in np.linspace(0, len(time) - 1, 9).astype(int):
            print(f"  t = {time[index]:12.6g} s   F = {force[index] * 1e3:10.6f} mN")
    return 0


def _add_inspect(subparsers):
    parser = subparsers.add_parser(
        "inspect",
        help="show what an instrument export holds (format, tests, columns, units, problems)",
        description="Read an instrument export and print its format, encoding, number format, "
        "tests and intervals, columns with units, control mode, row counts and problems.",
        epilog="example:\n  granflow inspect run1.csv",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", help="the export (RheoCompass, Rheoplus, TRIOS or CSV)")
    parser.add_argument("--format", choices=("rheocompass", "rheoplus", "trios", "csv"))
    parser.set_defaults(run=_run_inspect)


def _run_inspect(args):
    parsed = granflow.read(args.file, format=args.format)
    print(parsed.report())
    return 0


def _geometry(text):
    if text == "paper":
        return granflow.Annulus.paper()
    parts = text.split(":")
    if len(parts) != 2:
        raise _UsageError(
            f"--geometry must be 'paper' or OUTER_DIAMETER:WALL (e.g. 29.7mm:2.3mm), got {text!r}"
        )
    return granflow.Annulus(
        outer_diameter=parse_quantity(parts[0], "m", "--geometry outer diameter"),
        wall_thickness=parse_quantity(parts[1], "m", "--geometry wall thickness"),
    )


def _add_convert(subparsers):
    parser = subparsers.add_parser(
        "convert",
        help="convert instrument exports to one tidy Parquet or CSV table of runs",
        description="Read instrument exports (or a campaign manifest), turn every interval into "
        "a run (time, slip, velocity, friction force in SI units) and save them as one tidy "
        "table. A file that fails is reported and the others are converted (exit code 1).",
        epilog="examples:\n  granflow convert run1.csv run2.txt -o tidy.parquet --geometry paper\n"
        "  granflow convert --manifest campaign.yaml -o tidy.csv",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("files", nargs="*", help="export files")
    parser.add_argument("--manifest", help="a campaign manifest (.yaml or .csv)")
    parser.add_argument("-o", "--output", required=True, help="output .parquet or .csv")
    parser.add_argument(
        "--geometry",
        default="paper",
        help="'paper' (29.7 mm tube, 2.3 mm wall; default) or OUTER_DIAMETER:WALL",
    )
    parser.set_defaults(run=_run_convert)


def _run_convert(args):
    geometry = _geometry(args.geometry)
    if not args.files and not args.manifest:
        raise _UsageError("give export files or --manifest")
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

_COLUMN_KINDS = {
    "time": ("time", "t"),
    "slip": ("slip", "x", "displacement"),
    "force": ("force", "f", "friction"),
}
_SI_UNITS = {"time": "s", "slip": "m", "force": "N"}


def _split_header(header):
    """'force [mN]' / 'force (mN)' / 'force_mN' -> ('force', 'mN'); no unit -> (name, None)."""
    import re

    text = str(header).strip()
    match = re.fullmatch(r"(.+?)\s*[\[(](.+)[\])]", text)
    if match:
        return match.group(1).strip().lower(), match.group(2).strip()
    name, _, unit = text.rpartition("_")
    if name and unit:
        return name.strip().lower(), unit
    return text.lower(), None


def _read_fit_csv(path):
    """{'time'|'slip'|'force': SI array} from a CSV whose headers carry units."""
    import pandas as pd

    from granflow.errors import FileFormatError
    from granflow.model.units import to_si

    try:
        frame = pd.read_csv(path)
    except FileNotFoundError:
        raise FileFormatError(f"{path}: no such file") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"{path}: not a readable CSV file ({exc})") from None
    columns = {}
    for header in frame.columns:
        name, unit = _split_header(header)
        kind = next((k for k, names in _COLUMN_KINDS.items() if name in names), None)
        if kind is None or kind in columns:
            continue
        if unit is None:
            raise FileFormatError(
                f"{path}: column {header!r} has no unit; write it as '{name} [unit]'"
            )
        values = pd.to_numeric(frame[header], errors="coerce").to_numpy(dtype=float)
        bad = np.isnan(values) & frame[header].notna().to_numpy()
        if bad.any():
            line = int(np.argmax(bad)) + 2  # header is line 1
            raise FileFormatError(
                f"line {line} of {path}: column {header!r} has a non-numeric value "
                f"{frame[header].iloc[line - 2]!r}"
            )
        try:
            columns[kind] = np.asarray(to_si(values, unit, f"{path}: column {header!r}"))
        except GranflowError as exc:
            raise FileFormatError(str(exc)) from None
        expected = granflow.model.units.unit_registry()(_SI_UNITS[kind]).dimensionality
        if (
            granflow.model.units.unit_registry()(
                unit.replace("µ", "u").replace("μ", "u")
            ).dimensionality
            != expected
        ):
            raise FileFormatError(f"{path}: column {header!r} has unit {unit!r}, not a {kind} unit")
    if "force" not in columns or not ({"time", "slip"} & columns.keys()):
        raise FileFormatError(
            f"{path}: need a force column and a time or slip column, found "
            f"{', '.join(map(str, frame.columns))}"
        )
    return columns


def _add_fit(subparsers):
    parser = subparsers.add_parser(
        "fit",
        help="fit Eq. 3 to a friction curve in a CSV file",
        description="Fit the aging-rejuvenation model (Eq. 3) to one friction curve, with no "
        "initial guess, and print the parameters with standard errors and 95 % intervals.",
        epilog=_EPILOG_FIT,
        formatter_class=argparse.RawDescriptionHelpFormatter,
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
    parser.set_defaults(run=_run_fit)


def _run_fit(args):
    import json

    from granflow.fitting.single import _UNITS

    columns = _read_fit_csv(args.data)
    domain = args.domain or ("slip" if "slip" in columns else "time")
    abscissa = "slip" if domain == "slip" else "time"
    if abscissa not in columns:
        raise _UsageError(f"--domain {domain} needs a {abscissa} column in {args.data}")
    units = _UNITS[domain]
    fixed = {}
    for item in args.fix:
        name, sep, value = item.partition("=")
        if not sep or name not in units:
            raise _UsageError(
                f"--fix must be NAME=VALUE with NAME one of {', '.join(units)}, got {item!r}"
            )
        fixed[name] = parse_quantity(value, units[name], f"--fix {name}")
    window = None
    if args.window:
        start, sep, stop = args.window.partition(":")
        if not sep:
            raise _UsageError(f"--window must be START:STOP, got {args.window!r}")
        unit = _SI_UNITS[abscissa]
        window = (
            parse_quantity(start, unit, "--window start"),
            parse_quantity(stop, unit, "--window stop") if stop else None,
        )
    velocity = parse_quantity(args.velocity, "m/s", "--velocity") if args.velocity else None
    sigma = parse_quantity(args.sigma, "N", "--sigma") if args.sigma else None
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


_EPILOG_SIMULATE = """examples:
  granflow simulate switch.yaml --params blue.yaml --plot switch.png
  granflow simulate ramp.yaml --params blue.yaml --method dynamic -o ramp.csv
PROTOCOL.yaml lists the segments, e.g.
  segments:
    - velocity: {velocity: 0.86 um/s, duration: 80 s}
    - switch_to_force: {duration: 60 s, factor: 1.01}
PARAMS.yaml gives a, alpha, Fd, x0 (or a, k, t0, Fd, velocity), as SI numbers or with units."""

_EPILOG_MAP = """examples:
  granflow stability-map --params blue.yaml --velocity 0.86um/s \\
      --switch-points 2:100:50 --ratios 0.95:1.2:50 --jobs 2 -o map.csv --plot map.png
A range START:STOP:COUNT is evenly spaced; a list is comma-separated."""

_PARAM_KEYS = {
    "a": "N",
    "alpha": "1/m",
    "Fd": "N",
    "x0": "m",
    "k": "1/s",
    "t0": "s",
    "velocity": "m/s",
}


def _load_params(path):
    """Params from a YAML mapping (slip domain a, alpha, Fd, x0 or time domain a, k, t0, Fd,
    velocity); values are SI numbers or strings with units."""
    import yaml

    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise _UsageError(f"{path}: cannot read the parameters ({exc})") from None
    except yaml.YAMLError as exc:
        raise _UsageError(f"{path}: not valid YAML ({exc})") from None
    if isinstance(data, dict) and isinstance(data.get("params"), dict):
        data = data["params"]
    if not isinstance(data, dict):
        raise _UsageError(f"{path}: expected a mapping of parameters (a, alpha, Fd, x0)")
    unknown = sorted(set(data) - set(_PARAM_KEYS))
    if unknown:
        raise _UsageError(f"{path}: unknown parameter(s) {', '.join(unknown)}")
    values = {
        key: parse_quantity(value, _PARAM_KEYS[key], f"{path}: {key}")
        for key, value in data.items()
    }
    try:
        if {"k", "t0"} <= set(values):
            return granflow.Params.from_time_domain(
                a=values["a"],
                k=values["k"],
                t0=values["t0"],
                Fd=values["Fd"],
                velocity=values["velocity"],
            )
        return granflow.Params(
            a=values["a"], alpha=values["alpha"], Fd=values["Fd"], x0=values["x0"]
        )
    except KeyError as exc:
        raise _UsageError(
            f"{path}: missing parameter {exc.args[0]} (give a, alpha, Fd, x0 or a, k, t0, Fd, "
            "velocity)"
        ) from None


def _add_dynamic_options(parser):
    parser.add_argument(
        "--clock",
        choices=("slip", "time"),
        default="slip",
        help="aging along the slip (default) or in time",
    )
    parser.add_argument(
        "--method",
        choices=("quasistatic", "dynamic"),
        default="quasistatic",
        help="neglect inertia (default) or integrate it",
    )
    parser.add_argument("--mass", help="effective mass at the contact, e.g. 0.05kg (dynamic)")
    parser.add_argument("--damping", help="damping of the drive [N s/m] (dynamic)")
    parser.add_argument("--stiffness", help="machine stiffness, e.g. 1e4N/m (dynamic)")
    parser.add_argument("--v-fail", help="failure velocity threshold, e.g. 1mm/s [m/s]")
    parser.add_argument("--direct-effect", help="direct-effect amplitude A, e.g. 0.05mN [N]")


def _dynamic_options(args):
    options = {"clock": args.clock, "method": args.method}
    for name, unit in (
        ("mass", "kg"),
        ("damping", "N*s/m"),
        ("stiffness", "N/m"),
        ("v_fail", "m/s"),
        ("direct_effect", "N"),
    ):
        text = getattr(args, name)
        if text is not None:
            options[name] = parse_quantity(text, unit, "--" + name.replace("_", "-"))
    return options


def _add_simulate(subparsers):
    parser = subparsers.add_parser(
        "simulate",
        help="run a protocol (velocity, hold, force, ramps, switches) through the model",
        description="Simulate a protocol: stick, slide, stop and fail under imposed velocities "
        "and forces. Prints the report; optionally writes the time series and a figure.",
        epilog=_EPILOG_SIMULATE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("protocol", help="protocol YAML file")
    parser.add_argument("--params", required=True, help="parameters YAML file")
    _add_dynamic_options(parser)
    parser.add_argument("-o", "--output", help="write the time series to this CSV file")
    parser.add_argument("--plot", help="write force and slip against time to this image")
    parser.set_defaults(run=_run_simulate)


def _run_simulate(args):
    params = _load_params(args.params)
    protocol = granflow.Protocol.load(args.protocol)
    result = granflow.simulate(params, protocol, **_dynamic_options(args))
    print(result.report())
    _write_outputs(args, result.to_frame, "points", lambda: plot_simulation(result)[0])
    return 0 if result.success else 1


def _write_outputs(args, frame, rows, axes):
    """Write ``frame()`` to ``args.output`` (CSV) and the figure of ``axes()`` to ``args.plot``."""
    if args.output:
        table = frame()
        table.to_csv(args.output, index=False, float_format="%.17g")
        print(f"wrote {len(table)} {rows} to {args.output}")
    if args.plot:
        axes().figure.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")


def _grid(text, unit, name):
    """'START:STOP:COUNT' (evenly spaced) or 'a,b,c' as a float array."""
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise _UsageError(f"{name}: give START:STOP:COUNT, got {text!r}")
        try:
            count = int(parts[2])
        except ValueError:
            raise _UsageError(f"{name}: COUNT must be an integer, got {parts[2]!r}") from None
        if count < 1:
            raise _UsageError(f"{name}: COUNT must be at least 1, got {count}")
        start, stop = (parse_quantity(part, unit, name) for part in parts[:2])
        return np.linspace(start, stop, count)
    return np.array([parse_quantity(part, unit, name) for part in text.split(",")])


def _add_stability_map(subparsers):
    parser = subparsers.add_parser(
        "stability-map",
        help="fail or stop after switching a start-up to force control",
        description="For each switch point of a constant-velocity start-up and each ratio of "
        "imposed to current force: does the layer fail or stop, after which slip, how fast?",
        epilog=_EPILOG_MAP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--params", required=True, help="parameters YAML file")
    parser.add_argument("--velocity", default="0.86um/s", help="start-up velocity [m/s]")
    parser.add_argument("--switch-points", required=True, help="switch times [s]")
    parser.add_argument("--ratios", required=True, help="imposed / current force ratios")
    parser.add_argument("--hold", default="60s", help="time under force control (default 60s)")
    parser.add_argument("--ramp", default="0s", help="time to apply the force (default 0s)")
    parser.add_argument("--jobs", type=int, default=1, help="local processes (default 1)")
    _add_dynamic_options(parser)
    parser.add_argument("-o", "--output", help="write one row per cell to this CSV file")
    parser.add_argument("--plot", help="write the map to this image")
    parser.set_defaults(run=_run_stability_map)


def _run_stability_map(args):
    params = _load_params(args.params)
    options = _dynamic_options(args)
    stability = granflow.stability_map(
        params,
        _grid(args.switch_points, "s", "--switch-points"),
        _grid(args.ratios, "", "--ratios"),
        velocity=parse_quantity(args.velocity, "m/s", "--velocity"),
        hold=parse_quantity(args.hold, "s", "--hold"),
        ramp=parse_quantity(args.ramp, "s", "--ramp"),
        jobs=args.jobs,
        **options,
    )
    print(stability.report())
    _write_outputs(args, stability.to_frame, "cells", lambda: plot_stability_map(stability))
    return 1 if np.any(stability.outcome == "error") else 0


_EPILOG_ANALYZE = """examples:
  granflow analyze campaign/                        (a folder holding manifest.yaml)
  granflow analyze campaign/manifest.yaml -o results --jobs 4
  granflow analyze campaign/ -o results --resume    (after an interruption: reuses finished runs)
  granflow analyze campaign/ --scheduler tcp://10.0.0.5:8786   (Dask: pip install granflow[dask])
  granflow analyze campaign/ --mcmc --seed 1        (emcee: pip install granflow[mcmc])
The manifest lists the export files with normal_load, velocity, preparation, test, ...
Writes report.html, results.json, tables/ (CSV and Parquet), figures/ (PNG and SVG) and runs/
(one result per run, written as it finishes). Exit code 1 when some runs failed (named in the
output, results.json and the report), 2 for a bad argument or an unreadable manifest."""

_EPILOG_DEMO = """examples:
  granflow demo                                     (writes granflow-demo/)
  granflow demo -o demo --seed 3 --jobs 2
Generates a synthetic campaign that mirrors the paper, labelled as synthetic, writes it as
instrument exports with a manifest in DIR/exports, then runs 'granflow analyze' on it:
DIR/report.html, DIR/results.json and DIR/synthetic_truth.json (the values it was made with)."""


def _positive_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def _add_analyze(subparsers):
    parser = subparsers.add_parser(
        "analyze",
        help="analyse a campaign: fits, joint analyses, predictions, tables, figures, report",
        description="Read every run a manifest names, fit each (start-ups, creep, stress ramps, "
        "switches), run the joint analyses the campaign allows (velocity collapse, Amontons' "
        "law, preparation spread), predict the static yield and a stability map, and write "
        "the results, tables, figures and an HTML report.",
        epilog=_EPILOG_ANALYZE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
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
    parser.set_defaults(run=_run_analyze)


def _add_execution_options(parser):
    parser.add_argument(
        "--jobs",
        type=_positive_int,
        help="local worker processes (default: every core; 1 runs in this process)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--quiet", action="store_true", help="no progress output")


def _add_demo(subparsers):
    parser = subparsers.add_parser(
        "demo",
        help="generate a synthetic campaign like the paper's and analyse it",
        description="Generate a synthetic campaign that mirrors the paper (start-ups over "
        "preparations, velocities and loads; a stress ramp; creep; a switch), write it as "
        "instrument exports and run 'granflow analyze' on it. Everything is labelled synthetic.",
        epilog=_EPILOG_DEMO,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "-o", "--output", default="granflow-demo", help="output folder (default granflow-demo)"
    )
    _add_execution_options(parser)
    parser.set_defaults(run=_run_demo)


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


def _analyze_and_report(args, campaign):
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
            )
    except KeyboardInterrupt:
        print(
            f"granflow {args.command}: interrupted; the finished runs are saved in "
            f"{Path(args.output) / 'runs'}: run again with --resume to go on",
            file=sys.stderr,
        )
        return 130
    print(result.summary())
    return result.exit_code


def _run_analyze(args):
    return _analyze_and_report(args, args.campaign)


def _run_demo(args):
    from granflow.analysis.demo import make_demo_campaign

    manifest = make_demo_campaign(args.output, seed=args.seed)
    if not args.quiet:
        print(f"wrote a synthetic campaign (seed {args.seed}): {manifest}", file=sys.stderr)
    return _analyze_and_report(args, manifest)


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
    _add_curve(subparsers)
    _add_inspect(subparsers)
    _add_convert(subparsers)
    _add_fit(subparsers)
    _add_simulate(subparsers)
    _add_stability_map(subparsers)
    _add_analyze(subparsers)
    _add_demo(subparsers)
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
