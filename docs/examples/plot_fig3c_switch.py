"""
Fig. 3c: the same force, failure or rest
========================================

Shear at a constant velocity, then switch the rheometer to a constant force slightly above
the friction at that instant. What happens depends on *when* you switch:

* **after the peak** (the paper's ``t = 80 s``) the friction is falling: a slip forward lowers
  the resistance below the force, which drives more slip — the layer fails at once;
* **before the peak** (here ``t = 10 s``) the friction is rising: a slip forward raises the
  resistance until it matches the force — the layer slides a little and stops.

For the same stress the layer either does not flow or flows rapidly: the flow history
decides. The first case is the demo campaign's switch (a French RheoCompass export, the force
2 % above the friction at 80 s); the second is simulated for the same layer.
"""

# %%
# The switch after the peak (demo campaign)
# -----------------------------------------
# The rate-controlled part before the switch is a start-up: fit it (in slip, up to the
# switch) to get the layer's overshoot.
import tempfile

import matplotlib.pyplot as plt

import granflow as gf
from granflow.analysis.demo import make_demo_campaign
from granflow.plotting import plot_switch

manifest = make_demo_campaign(tempfile.mkdtemp(prefix="granflow-demo-"))
campaign = gf.Campaign.from_manifest(manifest)
switch = next(run for run in campaign.runs if run.meta["test"] == "switch")
velocity, switch_time = switch.meta["velocity"], 80.0
before = gf.fit(switch, window=(0.0, velocity * switch_time))
params = before.to_params()
print(f"peak of the overshoot at t = {gf.peak(params, velocity=velocity).time:.1f} s")

# %%
# The same layer switched before the peak (simulated)
# ---------------------------------------------------
early = gf.simulate(
    params, gf.Protocol([gf.Velocity(velocity, 10.0), gf.SwitchToForce(60.0, factor=1.02)])
)
print(f"switch at 10 s: {[event.kind for event in early.events]}")

# %%
# Draw Fig. 3c, and its mirror image before the peak
# ---------------------------------------------------
# Slip on the left axis (blue), force on the right (black: the friction under rate control,
# then the imposed force); the grey curve is the overshoot the layer would have followed
# under the velocity, the orange dotted line the switch.
fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), layout="constrained")
plot_switch(switch, params, ax=axes[0], switch_time=switch_time)
plot_switch(early.to_run(), params, ax=axes[1], switch_time=10.0)
plt.show()
