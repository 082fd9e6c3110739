"""Measure the noise spectra of the record family "red noise" (granflow.forecast.families):
the residuals of the two real velocity-step records (../shared/data/rate-state-velocity-steps)
about their rate-and-state fits, described as white noise plus one Ornstein-Uhlenbeck
(red, exponentially correlated) component.

For each record: the aging-law fit of granflow.rsf (one state, no trend: the fit of
tests/rsf/test_rsf_real.py), its residuals on a uniform clock (the basalt record, sampled at
0.1 s for 66 s and at 0.01 s after, is read at 0.1 s throughout), and their autocorrelation at
50 log-spaced lags up to a quarter of the record, fitted by ``(1 - w) exp(-lag / tau)``: w
is the white share of the variance, tau the red component's correlation time. Printed: w,
tau / T (T the record's length), the red component's standard deviation over the white
one's, sqrt((1 - w) / w), and the sampling's jitter (the standard deviation of the sampling
interval over its median, where the interval does not change rate).

Run from the repository root: ``python tools/noise_spectra.py``; the numbers go into
``SPECTRA`` in src/granflow/forecast/families.py by hand.
"""

from pathlib import Path

import numpy as np
from scipy.optimize import curve_fit

from granflow import rsf

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "rate-state-velocity-steps"
RECORDS = ("velstep3_TR2_exp013_sepiolite.txt", "velstep4_BRAVA_expb819_basalt.txt")


def uniform(t, residuals):
    """The residuals at one sampling interval: where the record changes rate, the faster
    part is thinned to the slower part's interval."""
    steps = np.diff(t)
    longer = steps > 1.5 * np.min(steps)
    slow = np.median(steps[longer]) if np.any(longer) else None
    if slow is None:
        return t, residuals
    keep, last = [0], t[0]
    for i in range(1, t.size):
        if t[i] - last >= 0.999 * slow:
            keep.append(i)
            last = t[i]
    return t[keep], residuals[keep]


def measure(name):
    record = rsf.read_velocity_steps(DATA / name)
    fit = rsf.fit(record, law="aging", correlated_noise=True)
    t, residuals = np.asarray(fit.t), np.asarray(fit.residuals)
    steps = np.diff(t)
    same = steps < 1.5 * np.median(steps)
    jitter = float(np.std(steps[same]) / np.median(steps[same]))
    t, residuals = uniform(t, residuals)
    dt, span = float(np.median(np.diff(t))), float(t[-1] - t[0])
    x = residuals - residuals.mean()
    size = 2 ** int(np.ceil(np.log2(2 * x.size)))
    power = np.fft.rfft(x, size)
    correlation = np.fft.irfft(power * np.conj(power))[: x.size]
    correlation /= np.arange(x.size, 0, -1) * x.var()
    lags = np.unique(np.round(np.geomspace(1, x.size / 4, 50)).astype(int))

    def shape(lag, white, log_tau):
        return (1 - white) * np.exp(-lag * dt / np.exp(log_tau))

    (white, log_tau), _ = curve_fit(
        shape, lags, correlation[lags], p0=[0.2, np.log(span / 20)], bounds=([0, -10], [1, 20])
    )
    tau = float(np.exp(log_tau))
    print(
        f"{name}: T = {span:.5g} s, dt = {dt:.4g} s, white share {white:.4f}, "
        f"tau = {tau:.4g} s = {tau / span:.4f} T, "
        f"red / white sd {np.sqrt((1 - white) / white):.4f}, "
        f"jitter {jitter:.4f}, residual rms {np.sqrt(x.var()):.4g}"
    )


if __name__ == "__main__":
    for name in RECORDS:
        measure(name)
