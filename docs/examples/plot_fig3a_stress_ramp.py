"""
Fig. 3a: a stress ramp fails at the peak
========================================

The generic yield-stress experiment: raise the imposed force slowly and watch the slip. The
layer does not flow below a threshold, then suddenly does. The model says where the threshold
is: under force control the layer can only sit on the *rising* branch of its overshoot
``F(x)``, creeping up it as the force grows, and it fails when the force reaches the top of
the overshoot — the static yield ``F_peak`` measured under an imposed velocity. The inset
zooms on the slip before the failure: already a fraction of the grain size, the first sign of
what is coming (and the basis of :doc:`forecasting <../user_guide/forecasting>`).

The record is the demo campaign's stress ramp (55 mN, 0.065 mN/s, a TRIOS export). In the
paper the overshoot of the same sample under an imposed velocity was measured beforehand; in
the synthetic demo it is known exactly (``synthetic_truth.json``), and we use that.
"""

# %%
# The ramp, and the overshoot of the same layer under an imposed velocity
# -----------------------------------------------------------------------
import json
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import granflow as gf
from granflow.analysis.demo import make_demo_campaign
from granflow.plotting import plot_stress_ramp

folder = Path(tempfile.mkdtemp(prefix="granflow-demo-"))
campaign = gf.Campaign.from_manifest(make_demo_campaign(folder))
ramp = next(run for run in campaign.runs if run.meta["test"] == "ramp")
truth = json.loads((folder / "synthetic_truth.json").read_text(encoding="utf-8"))
layer = next(run for run in truth["runs"] if run["test"] == "ramp")
params = gf.Params(a=layer["a"], alpha=layer["alpha"], Fd=layer["Fd"], x0=layer["x0"])
print(f"F_peak of this layer: {gf.peak(params).force * 1e3:.3f} mN")

# %%
# The model's prediction: simulate the same ramp
# ----------------------------------------------
# Quasi-statically (inertia neglected, as in the paper) the layer fails exactly when the
# imposed force reaches ``F_peak``.
simulated = gf.simulate(params, gf.Protocol([gf.ForceRamp(rate=layer["rate"], duration=400.0)]))
failure = simulated.failure
print(f"predicted failure at t = {failure.time:.1f} s, F = {failure.force * 1e3:.3f} mN")

# %%
# Draw Fig. 3a
# ------------
# Slip (blue, left axis) and imposed force (black, right axis) against time. The grey curve
# is the rate-controlled overshoot F(t) of this layer at 0.86 µm/s, as in the paper: the
# layer fails where the imposed force reaches its peak ``F_peak`` (red dashed; the dotted
# line is the predicted failure). The grey dashed curve is the quasi-static slip along the
# rising branch of ``F(x)``; the inset magnifies the sub-µm creep long before the failure.
# After the failure the layer flows (the export's last points): the slip runs away.
slip_ax, force_ax = plot_stress_ramp(ramp, params, velocity=0.86e-6)
plt.show()
