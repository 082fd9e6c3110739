"""
Fig. 2c: Amontons' law for the overshoot
========================================

The steady friction obeys Amontons' law, ``F_d = μ_d F_N``. For Eq. 2 to scale over the full
range the aging amplitude must do the same, ``a = μ_a F_N``, while the rejuvenation constant
``α`` must not depend on the load. The paper checks this with five tube weights and at least
eight repeats at each; the demo campaign does the same (20 to 120 mN, eight repeats, each
with its own preparation ``x0``).

:func:`granflow.fit_amontons` fits the 40 start-ups jointly with ``μ_a``, ``μ_d`` and ``α``
shared and one ``x0`` per run, and also reports the per-load means with their standard
errors (the paper's error bars).
"""

# %%
# Fit the 40 start-ups
# --------------------
import tempfile

import matplotlib.pyplot as plt
import numpy as np

import granflow as gf
from granflow.analysis.demo import make_demo_campaign
from granflow.plotting import plot_amontons

manifest = make_demo_campaign(tempfile.mkdtemp(prefix="granflow-demo-"))
campaign = gf.Campaign.from_manifest(manifest)
runs = [run for run in campaign.runs if "loads_" in run.meta["source"]]
amontons = gf.fit_amontons(runs)
for name in ("a", "Fd"):
    slope, error = amontons.lines[name]
    print(f"{name} = ({slope:.4f} ± {error:.1g}) F_N")
alpha = amontons.joint.params["alpha"]
print(f"alpha = {alpha:.4g} 1/m (one value for every load)")

# %%
# The three panels of :func:`granflow.plotting.plot_amontons`
# ------------------------------------------------------------
# ``a``, ``α v`` and ``F_d`` against the load, each with the joint fit's line and its band.
plot_amontons(amontons)
plt.show()

# %%
# The paper's layout: ``a`` and ``α v`` on twin axes, ``F_d`` in the inset
# -------------------------------------------------------------------------
# The same result, drawn as in the paper: the per-load means and standard errors are in
# ``amontons.per_load``.
loads = np.array([row["normal_load"] for row in amontons.per_load]) * 1e3  # mN
a_mean, a_error = (np.array([row["a"][i] for row in amontons.per_load]) * 1e3 for i in (0, 1))
k_mean, k_error = (np.array([row["alpha_v"][i] for row in amontons.per_load]) for i in (0, 1))
fd_mean = np.array([row["Fd"][0] for row in amontons.per_load]) * 1e3
span = np.array([0.0, loads.max() * 1.05])  # for the lines through the origin [mN]

fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
ax.errorbar(loads, a_mean, a_error, fmt="o", color="tab:blue", capsize=3, label="a")
ax.plot(span, amontons.lines["a"][0] * span, color="tab:blue", linewidth=0.8)
ax.set_xlabel(r"normal load $F_\mathrm{N}$ [mN]")
ax.set_ylabel(r"$a$ [mN]", color="tab:blue")
ax.set_ylim(0, 1.25 * a_mean.max())
twin = ax.twinx()
twin.errorbar(loads, k_mean, k_error, fmt="s", color="tab:red", capsize=3, label="α v")
twin.set_ylabel(r"$\alpha v$ [1/s]", color="tab:red")
twin.set_ylim(0, 2 * k_mean.max())
inset = ax.inset_axes([0.12, 0.6, 0.32, 0.32])
inset.plot(loads, fd_mean, "ko", markersize=4)
inset.plot(span, amontons.lines["Fd"][0] * span, "k-", linewidth=0.8)
inset.set_xlabel(r"$F_\mathrm{N}$ [mN]", fontsize=8)
inset.set_ylabel(r"$F_\mathrm{d}$ [mN]", fontsize=8)
inset.tick_params(labelsize=7)
ax.set_xlim(0, None)
plt.show()
