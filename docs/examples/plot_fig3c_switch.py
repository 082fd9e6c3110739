"""
Fig. 3c: the same force, failure or rest
========================================

Shear at a constant velocity, then switch the rheometer to a constant force slightly above
the friction at that instant (here 1 % above). What happens depends on *when* you switch:

* **after the peak** (``t = 80 s``) the friction is falling: a slip forward lowers the
  resistance below the force, which drives more slip — the layer fails at once;
* **before the peak** (``t = 10 s``) the friction is rising: a slip forward raises the
  resistance until it matches the force — the layer slides a little and stops.

For the same stress the layer either does not flow or flows rapidly: the flow history
decides. Both runs are simulated with the paper's blue parameters, quasi-statically.
"""

# %%
# Simulate both switches
# ----------------------
import matplotlib.pyplot as plt

import granflow as gf
from granflow.plotting import plot_switch

velocity = 0.86e-6  # m/s
params = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=velocity)
print(f"peak at t = {gf.peak(params, velocity=velocity).time:.1f} s")

results = {}
for switch_time in (80.0, 10.0):
    protocol = gf.Protocol(
        [gf.Velocity(velocity, switch_time), gf.SwitchToForce(60.0, factor=1.01)]
    )
    results[switch_time] = gf.simulate(params, protocol)
    print(f"switch at {switch_time:.0f} s: {results[switch_time].message}")

# %%
# Draw Fig. 3c, and its mirror image before the peak
# ---------------------------------------------------
# Slip on the left axis, force on the right (the imposed friction, then the imposed force);
# the grey curve is the overshoot the layer would have followed under the velocity.
fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
for ax, (switch_time, result) in zip(axes, results.items(), strict=True):
    plot_switch(result.to_run(), params, ax=ax, switch_time=switch_time)
    ax.set_title(f"switch at t = {switch_time:.0f} s", loc="left", fontsize=10)
plt.show()
