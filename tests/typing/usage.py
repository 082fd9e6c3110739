"""The public API as a user calls it, for the type checker (tests/test_typing.py runs mypy
on this file; it is never imported or run). Every assignment states the type a user would
expect, so a wrong annotation in granflow fails the check."""

from pathlib import Path

import numpy as np

import granflow as gf
from granflow import rsf


def usage(folder: Path) -> None:
    params: gf.Params = gf.Params(a=3e-3, alpha=4e4, Fd=10e-3, x0=2e-7)
    slip = np.linspace(1e-6, 5e-4, 300)
    force = gf.friction_slip(slip, params)
    top: gf.Peak = gf.peak(params)
    steady: float = gf.steady_state(params)
    fitted: gf.FitResult = gf.fit((slip, np.asarray(force)), window=(1e-6, 4e-4))
    text: str = fitted.report()
    back: gf.Params = fitted.to_params()
    comparison: gf.ModelComparison = gf.compare_models((slip, np.asarray(force)))
    joint: gf.JointFitResult = gf.fit_joint([(slip, np.asarray(force))] * 2)
    many: list[object] = gf.fit_many([(slip, force)], jobs=1, progress=False)
    protocol = gf.Protocol([gf.Velocity(1e-6, 100.0), gf.SwitchToForce(60.0, factor=1.01)])
    simulation: gf.SimulationResult = gf.simulate(params, protocol, method="quasistatic")
    run: gf.Run = simulation.to_run()
    events: tuple[gf.Event, ...] = simulation.events_of("failure")
    stability: gf.StabilityMap = gf.stability_map(
        params, [10.0], [1.01], velocity=1e-6, progress=False
    )
    campaign: gf.Campaign = gf.Campaign.load(folder / "campaign.csv")
    result: gf.AnalysisResult = gf.analyze(folder, folder / "out", jobs=1, quiet=True)
    summary: str = result.summary()
    code: int = result.exit_code
    model = rsf.RateState(0.6, 0.005, 1.0, 1e-3, [rsf.State(0.01, 10.0, "aging")])
    sliding: rsf.RateStateResult = rsf.simulate(model, [gf.Velocity(1e-6, 10.0)])
    print(top, steady, text, back, comparison, joint, many, run, events, stability)
    print(campaign, summary, code, sliding)
