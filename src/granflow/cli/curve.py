"""``granflow curve``: the model curve (Eq. 3) under a constant velocity, and its peak."""

import granflow
from granflow.cli._common import (
    UsageError,
    add_command,
    check_outputs,
    plural,
    quantity,
    written_names,
)

__all__ = ["add_curve"]

_EPILOG_CURVE = """examples:
  granflow curve --a 3.31mN --k 0.036/s --t0 0.23s --Fd 10mN --velocity 0.86um/s
  granflow curve --a 3.31mN --alpha 4.19e4/m --x0 0.198um --Fd 10mN -o curve.csv
The curve CSV (t_s, slip_m, force_N: the names of every table granflow writes) is what
'granflow fit', 'inspect', 'convert' and 'forecast' read back."""


def add_curve(subparsers):
    """Add the ``curve`` command."""
    parser = add_command(
        subparsers,
        "curve",
        _run_curve,
        help="evaluate the model curve (Eq. 3) and print its peak",
        description="Evaluate the friction transient of Eq. 3 under a constant velocity, print "
        "the static yield point (peak) and optionally write the curve as CSV.",
        epilog=_EPILOG_CURVE,
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
        "--duration", help="time span of the curve, e.g. 600s (default: 20 times the peak time)"
    )
    parser.add_argument("--points", type=int, default=400, help="points on the curve (default 400)")
    parser.add_argument("-o", "--output", help="write the curve to this CSV file")


def _curve_params(args):
    velocity = quantity(args.velocity, "velocity", "--velocity")
    a = quantity(args.a, "a", "--a")
    Fd = quantity(args.Fd, "Fd", "--Fd")
    time_domain = args.k is not None or args.t0 is not None
    slip_domain = args.alpha is not None or args.x0 is not None
    if (
        time_domain == slip_domain
        or (time_domain and None in (args.k, args.t0))
        or (slip_domain and None in (args.alpha, args.x0))
    ):
        raise UsageError("give either --k and --t0 (time domain) or --alpha and --x0 (slip domain)")
    if time_domain:
        params = granflow.Params.from_time_domain(
            a=a,
            k=quantity(args.k, "k", "--k"),
            t0=quantity(args.t0, "t0", "--t0"),
            Fd=Fd,
            velocity=velocity,
        )
    else:
        params = granflow.Params(
            a=a,
            alpha=quantity(args.alpha, "alpha", "--alpha"),
            Fd=Fd,
            x0=quantity(args.x0, "x0", "--x0"),
        )
    return params, velocity


def _run_curve(args):
    import numpy as np

    check_outputs(args)
    params, velocity = _curve_params(args)
    if args.points < 2:
        raise UsageError(f"--points must be at least 2, got {args.points}")
    top = granflow.peak(params, velocity=velocity)
    t0 = params.t0(velocity)
    duration = quantity(args.duration, "duration", "--duration") if args.duration else 20 * top.time
    if duration <= t0:
        raise UsageError(f"--duration must exceed t0 = {t0:.6g} s, got {duration:.6g} s")
    time = np.geomspace(t0, duration, args.points)
    force = granflow.friction_time(time, params, velocity)
    print(f"parameters: {params!r}")
    print(
        f"velocity:   {velocity * 1e6:.6g} µm/s  "
        f"(k = {params.k(velocity):.6g} 1/s, t0 = {t0:.6g} s)"
    )
    print(
        f"peak:       F = {top.force * 1e3:.10g} mN at t = {top.time:.10g} s, "
        f"slip = {top.slip * 1e6:.10g} µm"
    )
    print(f"steady:     Fd = {params.Fd * 1e3:.6g} mN")
    if args.output:
        import pandas as pd

        frame = pd.DataFrame({"t": time, "slip": velocity * time, "force": force})
        frame = frame.rename(columns=written_names({"t": "t", "slip": "slip", "force": "force"}))
        frame.to_csv(args.output, index=False, float_format="%.17g")
        print(f"wrote {plural(len(frame), 'point')} to {args.output}")
    else:
        for index in np.linspace(0, len(time) - 1, 9).astype(int):
            print(f"  t = {time[index]:12.6g} s   F = {force[index] * 1e3:10.6f} mN")
    return 0
