"""``granflow fit FILE --model rsf``: a rate-and-state fit of a velocity-step record, with
correlated noise whenever the residuals are correlated (real records), said in the output."""

from granflow.cli._common import UsageError, plural, quality_text, quantity
from granflow.errors import GranflowError

__all__ = ["run_fit_rsf"]


def run_fit_rsf(args):
    """``granflow fit FILE --model rsf``: a rate-and-state fit of a velocity-step record."""
    import json

    from granflow import rsf

    steps = None
    if args.steps:
        steps = [quantity(item, "time", "--steps") for item in args.steps.split(",")]
    record = rsf.read_velocity_steps(args.data, step_times=steps)
    fixed = {}
    for item in args.fix:
        name, sep, value = item.partition("=")
        try:
            fixed[name] = float(value)
        except ValueError:
            sep = ""
        if not sep:
            raise UsageError(f"--fix must be NAME=VALUE (SI), e.g. stiffness=2000, got {item!r}")
    windows = None
    if args.window:
        start, sep, stop = args.window.partition(":")
        if not sep:
            raise UsageError(f"--window must be START:STOP, got {args.window!r}")
        windows = [
            (quantity(start, "time", "--window start"), quantity(stop, "time", "--window stop"))
        ]
    periodic = None
    if args.wavelength:
        periodic = quantity(args.wavelength, "slip", "--wavelength")
    elif args.periodic:
        periodic = True
    try:
        result = rsf.fit(
            record,
            law=args.law,
            states=args.states,
            fixed=fixed,
            detrend=args.detrend,
            windows=windows,
            sigma=float(args.sigma) if args.sigma else None,
            correlated_noise=_noise_option(args),
            periodic=periodic,
            harmonics=args.harmonics,
        )
    except GranflowError as exc:
        raise type(exc)(f"{args.data}: {exc}") from None
    if args.json:
        payload = result.to_dict()
        payload["record"] = {
            "source": str(args.data),
            "step_times": list(record.step_times),
            "velocities": list(record.velocities),
            "time_offset": record.time_offset,
        }
        payload["problems"] = list(record.meta.get("problems", []))
        print(json.dumps(payload, indent=2))
    else:
        speeds = " -> ".join(f"{v * 1e6:.4g}" for v in record.velocities)
        steps_text = ", ".join(f"{s:.4g}" for s in record.step_times)
        print(f"fit of {args.data} ({plural(record.t.size, 'point')}; load point {speeds} µm/s,")
        print(f"  steps at {steps_text} s after the first row, t = {record.time_offset:g} s)")
        print(quality_text(record.meta.get("problems", [])))
        print(_noise_sentence(result, args))
        print(result.report())
    return 0 if result.success else 1


def _noise_option(args):
    """``correlated_noise`` of :func:`granflow.rsf.fit` from the options: "auto" unless
    --correlated-noise or --white-noise says otherwise."""
    if args.correlated_noise:
        return True
    return False if args.white_noise else "auto"


def _noise_sentence(result, args):
    """One line saying how the noise was taken, and why."""
    tau = result.correlation_time
    if result.correlated_noise:
        why = "--correlated-noise" if args.correlated_noise else "the residuals are correlated"
        return (
            f"noise: correlated ({why}: correlation time {tau:.3g} points); the uncertainties "
            f"are scaled by sqrt({tau:.3g}) = {max(tau, 1.0) ** 0.5:.3g} (--white-noise to "
            "take it as white)"
        )
    if args.white_noise and tau > 2:
        return (
            f"noise: white (--white-noise), although the residuals are correlated over "
            f"{tau:.3g} points: the intervals are too narrow by about {tau**0.5:.3g}x"
        )
    return f"noise: white (the residuals' correlation time is {tau:.3g} points)"
