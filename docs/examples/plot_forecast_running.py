"""
Forecasting the failure of a stress ramp
========================================

The paper closes with a hope: that the failure of a granular fault "could be predicted from
analysis of the slow and aseismic slip". The model makes this concrete. Under a slowly rising
force the layer creeps up the rising branch of its overshoot ``F(x)``, and fails when the
force reaches ``F_peak``; so the slip *before* the failure constrains ``F(x)``, and with it
the force — and the time — at which the layer will fail.

Here we play observer on the demo campaign's stress ramp (Fig. 3a): at each cut time we keep
only the record up to then and ask :func:`granflow.forecast_failure` when the layer will
fail. :func:`granflow.forecast.running_forecast` does this for a sequence of cuts, with two
baselines of landslide practice: the inverse-velocity method (Fukuzono) and Voight's law.
"""

# %%
# The stress ramp of the demo campaign
# ------------------------------------
import json
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import granflow as gf
from granflow.analysis.demo import make_demo_campaign
from granflow.forecast import running_forecast
from granflow.plotting import plot_forecast

folder = Path(tempfile.mkdtemp(prefix="granflow-demo-"))
campaign = gf.Campaign.from_manifest(make_demo_campaign(folder))
ramp = next(run for run in campaign.runs if run.meta["test"] == "ramp")
truth = json.loads((folder / "synthetic_truth.json").read_text(encoding="utf-8"))
failure = next(run["failure"] for run in truth["runs"] if run["test"] == "ramp")
print(f"the layer failed at t = {failure['time']:.1f} s, F = {failure['force'] * 1e3:.2f} mN")

# %%
# One forecast, from the first 120 s of slip
# ------------------------------------------
forecast = gf.forecast_failure(ramp.t, ramp.slip, ramp.force, until=120.0)
low, high = forecast.time_interval
print(f"at t = 120 s: failure expected at {forecast.time:.1f} s (90 %: {low:.1f}-{high:.1f} s)")

# %%
# The running forecast
# --------------------
# What an observer would have said at each cut time; the dashed line is the observed failure.
running = running_forecast(ramp.t, ramp.slip, ramp.force, observed=failure["time"])
ax = plot_forecast(running)
plt.show()
