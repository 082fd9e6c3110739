"""
Stability map: when does a switch to force control fail?
========================================================

Fig. 3c asks one question at two points; a stability map asks it everywhere. For every
switch time of a start-up (the layer's place on its overshoot) and every ratio of imposed to
current force, :func:`granflow.stability_map` simulates the switch and records the outcome:
failure, or a stop after some slip.

The boundary is the physics of Fig. 3c. Before the peak, the layer can carry a force up to
``F_peak``: any ratio up to ``F_peak / F(t_switch)`` ends in a stop. After the peak the
friction ahead only falls, so any ratio above 1 fails.
"""

# %%
# A 40 × 40 map of the blue sample (quasi-static, slip clock)
# ------------------------------------------------------------
import matplotlib.pyplot as plt
import numpy as np

import granflow as gf
from granflow.plotting import plot_stability_map

velocity = 0.86e-6  # m/s
params = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=velocity)
switch_points = np.linspace(2.0, 100.0, 40)  # s after the start of shear
ratios = np.linspace(0.95, 1.6, 40)  # imposed force / force at the switch
stability = gf.stability_map(params, switch_points, ratios, velocity=velocity)
failed = np.mean(stability.outcome == "failure")
print(f"{stability.outcome.size} switches, {failed:.0%} of them fail")

# %%
# Draw the map
# ------------
# The peak time (24.3 s) separates the two regimes.
ax = plot_stability_map(stability)
ax.axvline(gf.peak(params, velocity=velocity).time, color="red", linestyle="--", linewidth=1)
plt.show()
