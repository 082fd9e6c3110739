"""``granflow simulate`` and ``granflow stability-map``: protocols through the model."""

import granflow
from granflow.cli._common import UsageError, add_command, check_outputs, quantity, write_outputs

__all__ = ["add_simulate", "add_stability_map"]

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
      --switch-points 2s:100s:50 --ratios 0.95:1.2:50 --jobs 2 -o map.csv --plot map.png
A range START:STOP:COUNT is evenly spaced (START and STOP with units); a list is
comma-separated (each with its unit: 5s,10s,80s)."""

#: The quantity of each column of a stability map's table (its unit goes into the name).
_MAP_QUANTITIES = {
    "switch_point": "switch_time",
    "switch_slip": "slip",
    "switch_force": "force",
    "imposed_force": "force",
    "stop_slip": "slip",
    "failure_time": "t",
    "failure_force": "force",
}

#: The simulator's options that take a quantity (units from the unit table).
_DYNAMIC_QUANTITIES = ("mass", "damping", "stiffness", "v_fail", "direct_effect")


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
    parser.add_argument("--damping", help="damping of the drive, e.g. 1N*s/m (dynamic)")
    parser.add_argument("--stiffness", help="machine stiffness, e.g. 1e4N/m (dynamic)")
    parser.add_argument("--v-fail", help="failure velocity threshold, e.g. 1mm/s [m/s]")
    parser.add_argument("--direct-effect", help="direct-effect amplitude A, e.g. 0.05mN [N]")


def _dynamic_options(args):
    options = {"clock": args.clock, "method": args.method}
    for name in _DYNAMIC_QUANTITIES:
        text = getattr(args, name)
        if text is not None:
            options[name] = quantity(text, name, "--" + name.replace("_", "-"))
    return options


def add_simulate(subparsers):
    """Add the ``simulate`` command."""
    parser = add_command(
        subparsers,
        "simulate",
        _run_simulate,
        help="run a protocol (velocity, hold, force, ramps, switches) through the model",
        description="Simulate a protocol: stick, slide, stop and fail under imposed velocities "
        "and forces. Prints the report; optionally writes the time series and a figure.",
        epilog=_EPILOG_SIMULATE,
    )
    parser.add_argument("protocol", help="protocol YAML file")
    parser.add_argument("--params", required=True, help="parameters YAML file")
    _add_dynamic_options(parser)
    parser.add_argument("-o", "--output", help="write the time series to this CSV file")
    parser.add_argument("--plot", help="write force and slip against time to this image")


def _run_simulate(args):
    from granflow.plotting import plot_simulation
    from granflow.simulation.results import ARRAY_QUANTITIES

    check_outputs(args)
    params = granflow.Params.load(args.params)
    protocol = granflow.Protocol.load(args.protocol)
    result = granflow.simulate(params, protocol, **_dynamic_options(args))
    print(result.report())
    write_outputs(
        args,
        lambda: _record_frame(result),
        "point",
        lambda: plot_simulation(result)[0],
        ARRAY_QUANTITIES,
    )
    return 0 if result.success else 1


def _record_frame(result):
    """The simulation as a record: one row per instant, and each row's control mode
    ("rate" or "stress"), which the readers take as the run's."""
    import numpy as np

    frame = result.to_frame(one_row_per_instant=True)
    stress = np.array([segment.control == "force" for segment in result.protocol])
    frame["control"] = np.where(stress[frame["segment"].to_numpy()], "stress", "rate")
    return frame


def _grid(text, name, flag):
    """'START:STOP:COUNT' (evenly spaced) or 'a,b,c' of the quantity ``name``, as an array."""
    import numpy as np

    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise UsageError(f"{flag}: give START:STOP:COUNT, got {text!r}")
        try:
            count = int(parts[2])
        except ValueError:
            raise UsageError(f"{flag}: COUNT must be an integer, got {parts[2]!r}") from None
        if count < 1:
            raise UsageError(f"{flag}: COUNT must be at least 1, got {count}")
        start, stop = (quantity(part, name, flag) for part in parts[:2])
        return np.linspace(start, stop, count)
    return np.array([quantity(part, name, flag) for part in text.split(",")])


def add_stability_map(subparsers):
    """Add the ``stability-map`` command."""
    parser = add_command(
        subparsers,
        "stability-map",
        _run_stability_map,
        help="fail or stop after switching a start-up to force control",
        description="For each switch point of a constant-velocity start-up and each ratio of "
        "imposed to current force: does the layer fail or stop, after which slip, how fast?",
        epilog=_EPILOG_MAP,
    )
    parser.add_argument("--params", required=True, help="parameters YAML file")
    parser.add_argument(
        "--velocity", default="0.86um/s", help="start-up velocity, e.g. 0.86um/s (the default)"
    )
    parser.add_argument(
        "--switch-points", required=True, help="switch times, e.g. 2s:100s:50 or 5s,10s,80s"
    )
    parser.add_argument(
        "--ratios", required=True, help="imposed / current force ratios, e.g. 0.95:1.2:50"
    )
    parser.add_argument("--hold", default="60s", help="time under force control (default 60s)")
    parser.add_argument("--ramp", default="0s", help="time to apply the force (default 0s)")
    parser.add_argument("--jobs", type=int, default=1, help="local processes (default 1)")
    _add_dynamic_options(parser)
    parser.add_argument("-o", "--output", help="write one row per cell to this CSV file")
    parser.add_argument("--plot", help="write the map to this image")


def _run_stability_map(args):
    import numpy as np

    from granflow.plotting import plot_stability_map

    check_outputs(args)
    params = granflow.Params.load(args.params)
    options = _dynamic_options(args)
    stability = granflow.stability_map(
        params,
        _grid(args.switch_points, "switch_time", "--switch-points"),
        _grid(args.ratios, "factor", "--ratios"),
        velocity=quantity(args.velocity, "velocity", "--velocity"),
        hold=quantity(args.hold, "hold", "--hold"),
        ramp=quantity(args.ramp, "ramp", "--ramp"),
        jobs=args.jobs,
        **options,
    )
    print(stability.report())
    write_outputs(
        args, stability.to_frame, "cell", lambda: plot_stability_map(stability), _MAP_QUANTITIES
    )
    return 1 if np.any(stability.outcome == "error") else 0
