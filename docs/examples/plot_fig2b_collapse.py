"""
Fig. 2b: the collapse in slip
=============================

One preparation sheared five times (1 min rest between tests) at velocities from 0.43 to
8.6 µm/s. Plotted against time the transients would spread over a factor of twenty; plotted
against the slip ``x = v t`` they fall on one curve. That is the model's central claim: Eq. 2
divided by ``v`` reads ``dF/dx = a/x − α (F − F_d)``, a function of slip only, so the
quasi-static friction of the layer does not depend on the rate — like the friction between
two solids.

:func:`granflow.velocity_collapse` tests this claim: it fits all runs jointly with ``a``,
``α`` and ``F_d`` shared (one ``x0`` per run), then again with one set per velocity, and
compares the two with a likelihood-ratio test.
"""

# %%
# The five start-ups of the demo campaign
# ---------------------------------------
# They are stored in a CSV export with French labels and a decimal comma; the reader finds
# the columns and their units by itself.
import tempfile

import matplotlib.pyplot as plt

import granflow as gf
from granflow.analysis.demo import make_demo_campaign
from granflow.plotting import plot_collapse

manifest = make_demo_campaign(tempfile.mkdtemp(prefix="granflow-demo-"))
campaign = gf.Campaign.from_manifest(manifest)
runs = [run for run in campaign.runs if run.meta["source"].endswith("fig2b_velocities_fr.csv")]
for run in runs:
    print(f"v = {run.nominal_velocity * 1e6:.2f} µm/s: {run.t.size} points over {run.t[-1]:.0f} s")

# %%
# Test the collapse
# -----------------
collapse = gf.velocity_collapse(runs)
print(
    f"likelihood ratio {collapse.statistic:.2f} on {collapse.df} degrees of freedom, "
    f"p = {collapse.p_value:.2f}: "
    + ("one curve in slip" if collapse.collapses else "the velocities differ")
)

# %%
# Draw Fig. 2b
# ------------
# Points are the data, lines the shared fit, both coloured by velocity; the inset magnifies
# the short slips, where the runs differ a little by their initial state ``x0``.
ax = plot_collapse(collapse)
plt.show()
