"""
Fig. 2a: three preparations, three overshoots
=============================================

The same layer, the same load (55 mN) and the same imposed velocity (0.86 µm/s), prepared
three times: the overshoot always appears and Eq. 3 describes each curve, but its height and
position change from one preparation to the next. The fits attribute the difference to the
initial state ``t0`` (equivalently ``x0 = v t0``), while the steady friction ``F_d`` does not
move. The demo campaign uses the paper's three ``t0`` (0.23, 0.39 and 0.55 s).
"""

# %%
# Make the demo campaign and read the three start-ups of Fig. 2a
# ---------------------------------------------------------------
# ``make_demo_campaign`` writes the synthetic exports and a manifest; a campaign reads every
# file the manifest names (here a RheoCompass export with English labels).
import tempfile

import matplotlib.pyplot as plt

import granflow as gf
from granflow.analysis.demo import make_demo_campaign
from granflow.plotting import plot_startup

manifest = make_demo_campaign(tempfile.mkdtemp(prefix="granflow-demo-"))
campaign = gf.Campaign.from_manifest(manifest)
runs = [run for run in campaign.runs if run.meta["source"].endswith("fig2a_preparations_en.txt")]
print(f"{len(runs)} start-ups at {runs[0].meta['normal_load'] * 1e3:.0f} mN")

# %%
# Fit Eq. 3 to each, with no initial guess
# ----------------------------------------
# ``gf.fit`` finds its own start from the shape of the curve. The time-domain parameters are
# the paper's: ``a`` [N], ``k = α v`` [1/s] and ``t0`` [s].
fits = [gf.fit(run, domain="time") for run in runs]
for run, fit in zip(runs, fits, strict=True):
    p = fit.params
    low, high = fit.ci95["t0"]
    print(
        f"{run.meta['preparation']}: a = {p['a'] * 1e3:.2f} mN, αv = {p['k']:.4f} 1/s, "
        f"t0 = {p['t0']:.3f} s (95 %: {low:.3f}-{high:.3f} s), F_d = {p['Fd'] * 1e3:.2f} mN"
    )

# %%
# Draw Fig. 2a
# ------------
# Data as points, each fit as a line in the same colour, the residuals below.
ax = plot_startup(runs, fits)
plt.show()
