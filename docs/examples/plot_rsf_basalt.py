"""
A real velocity step: basalt gouge
==================================

A second laboratory record that granflow did not write: basalt gouge at about 20 MPa
normal stress, the load point stepped from about 3 to 10 µm/s (Giacomel, Faulkner, Lambert
and Allen 2024, Geosphere, doi:10.1130/GES02739.1; MIT licence), read from
``../shared/data/rate-state-velocity-steps/`` beside the repository.

Here ``a − b`` is close to zero: the layer is near the boundary between velocity weakening
and strengthening, and the interval of ``a − b`` straddles zero. The whole record is fitted,
and the model comparison puts the rate-and-state laws beside the paper's Eq. 2 (with and
without a direct effect), which has no rate dependence along the slip.
"""

# %%
# Read and fit
# ------------
from pathlib import Path

import matplotlib.pyplot as plt

import granflow
import granflow as gf
from granflow import rsf

DATA = Path(granflow.__file__).resolve().parents[3] / "shared" / "data"
record = rsf.read_velocity_steps(
    DATA / "rate-state-velocity-steps" / "velstep4_BRAVA_expb819_basalt.txt"
)
fit = rsf.fit(record, law="slip", correlated_noise=True)
low, high = (fit.a_minus_b + s * 1.96 * fit.a_minus_b_stderr for s in (-1, 1))
print(f"a − b = {fit.a_minus_b:.5f}, 95 %: [{low:.5f}, {high:.5f}]")
print(f"Dc = {fit.params['Dc'] * 1e6:.3g} ± {fit.stderr['Dc'] * 1e6:.2g} µm")

# %%
# Which law describes the record?
# -------------------------------
comparison = gf.compare_models(record, correlated_noise=True)
for row in comparison.rows:
    print(f"{row['model']:12} ΔAIC = {row['delta_aic']:10.1f}")
print(f"best by AIC: {comparison.best_aic}")

# %%
# The fit over the data, and its residuals
# ----------------------------------------
fig, axes = plt.subplots(
    2, 1, sharex=True, figsize=(7, 5), layout="constrained", gridspec_kw={"height_ratios": [3, 1]}
)
fit.plot(axes)
axes[0].axvline(record.step_times[0], color="0.5", ls=":", lw=1)
plt.show()
