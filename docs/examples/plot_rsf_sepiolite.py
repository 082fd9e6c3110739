"""
A real velocity step: sepiolite gouge
=====================================

A laboratory record that granflow did not write: sepiolite gouge sheared at about 30 MPa
effective normal stress, the load point stepped from about 0.2 to 2 µm/s (Giacomel,
Faulkner, Lambert and Allen 2024, Geosphere, doi:10.1130/GES02739.1; MIT licence). It is read
from ``../shared/data/rate-state-velocity-steps/`` beside the repository, as it came off the
apparatus, never copied into granflow.

The record is fitted by the rate-and-state slip and aging laws over the step, from 900 s
to 250 s after it, with the uncertainties widened by the residuals' correlation time
(real records are not white noise). The velocity-strengthening layer (``a > b``) rises to a
higher steady friction after the step.
"""

# %%
# Read the record
# ---------------
# One velocity step; the protocol (the load point's history) is found in the displacement.
from pathlib import Path

import matplotlib.pyplot as plt

import granflow
from granflow import rsf

# the shared data lie beside the repository that granflow is installed from
DATA = Path(granflow.__file__).resolve().parents[3] / "shared" / "data"
record = rsf.read_velocity_steps(
    DATA / "rate-state-velocity-steps" / "velstep3_TR2_exp013_sepiolite.txt"
)
print(record.protocol)
print(f"load point: {' -> '.join(f'{v * 1e6:.3g}' for v in record.velocities)} µm/s")

# %%
# Fit both laws over the step
# ---------------------------
# No initial guess: the direct jump gives a, the change of steady state a − b, the relaxation
# distance Dc. Dc is shown in µm.
step = record.step_times[0]
window = [(900.0, step + 250.0)]
fits = {
    law: rsf.fit(record, law=law, windows=window, correlated_noise=True)
    for law in ("slip", "aging")
}
for law, fit in fits.items():
    dc = fit.params["Dc"] * 1e6
    print(
        f"{law:5} law: a − b = {fit.a_minus_b:.4f} ± {fit.a_minus_b_stderr:.4f}, "
        f"Dc = {dc:.3g} µm, residual RMS {fit.residual_rms / fit.noise:.2f} × the scatter, "
        f"AIC {fit.aic:.1f}"
    )
print(f"the slip law is {fits['aging'].aic - fits['slip'].aic:.0f} AIC units ahead")

# %%
# The fits over the data, and their residuals
# -------------------------------------------
fig, axes = plt.subplots(
    2, 1, sharex=True, figsize=(7, 5), layout="constrained", gridspec_kw={"height_ratios": [3, 1]}
)
fits["slip"].plot(axes)
axes[0].axvline(step, color="0.5", ls=":", lw=1)
plt.show()
