"""
Fig. 3b: creep under two forces below the peak
==============================================

Hold the force constant below ``F_peak`` and the layer creeps: a fraction of a micrometre
over hours, logarithmic in time, larger for the larger force (here one force below the
steady friction ``F_d`` and one between ``F_d`` and ``F_peak``). It never flows: the peak has
to be overcome first. Creep lies outside Eq. 2, so granflow offers two things: a fit of
``δ(t) = B ln(1 + t/τ_c)`` to measured creep (:func:`granflow.fit_creep`), and a small
direct-effect term ``A ln(v/v_ref)`` (:class:`granflow.DirectEffect`) that makes the
simulator creep. The demo campaign's creep tests were made with the latter.

The inset shows the overshoot of the same sample under an imposed velocity, with ``F_d``
(dashed) and the two creep forces: both lie below the peak.
"""

# %%
# Read the creep tests and fit each
# ---------------------------------
# The export has German labels (``Zeit``, ``Drehmoment``, ``Auslenkwinkel``) in cp1252.
import tempfile

import matplotlib.pyplot as plt

import granflow as gf
from granflow.analysis.demo import make_demo_campaign
from granflow.plotting import plot_creep

manifest = make_demo_campaign(tempfile.mkdtemp(prefix="granflow-demo-"))
campaign = gf.Campaign.from_manifest(manifest)
creeps = [run for run in campaign.runs if run.meta["source"].endswith("fig3b_creep_de.txt")]
fits = [gf.fit_creep(run.t, run.slip) for run in creeps]
for run, fit in zip(creeps, fits, strict=True):
    B, tau = fit.params["B"], fit.params["tau_c"]
    force = run.force[-1] * 1e3
    print(f"creep at {force:.2f} mN: B = {B * 1e9:.1f} nm, τ_c = {tau:.3g} s")

# %%
# The overshoot of the same sample (55 mN), from a start-up of Fig. 2a
# ---------------------------------------------------------------------
startup = next(run for run in campaign.runs if run.meta["preparation"] == "fig2a-A")
params = gf.fit(startup).to_params()

# %%
# Draw Fig. 3b
# ------------
# Logarithmic creep is a straight line on a logarithmic time axis.
ax = plot_creep(creeps, fits, params=params, log_time=True)
plt.show()
