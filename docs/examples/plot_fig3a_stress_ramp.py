"""
Fig. 3a: a stress ramp fails at the peak
========================================

The generic yield-stress experiment: raise the imposed force slowly and watch the slip. The
layer does not flow below a threshold, then suddenly does. The model says where the threshold
is: under force control the layer can only sit on the *rising* branch of its overshoot
``F(x)``, creeping up it as the force grows, and it fails when the force reaches the top of
the overshoot, the static yield ``F_peak`` measured under an imposed velocity. The inset
zooms on the slip before failure: already a fraction of a micrometre, a first sign of what is
coming.

Here the experiment is simulated with the paper's blue parameters (Fig. 2a), quasi-statically
as in the paper (inertia neglected), on the slip clock.
"""

# %%
# The sample, and its overshoot under an imposed velocity
# -------------------------------------------------------
import matplotlib.pyplot as plt

import granflow as gf
from granflow.plotting import plot_stress_ramp

velocity = 0.86e-6  # m/s
params = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=velocity)
top = gf.peak(params, velocity=velocity)
print(f"F_peak = {top.force * 1e3:.3f} mN at x = {top.slip * 1e6:.2f} µm")

# %%
# Ramp the force at 0.05 mN/s
# ---------------------------
ramp = gf.Protocol([gf.ForceRamp(rate=0.05e-3, duration=400.0)])
result = gf.simulate(params, ramp)
print(result.report())

# %%
# Draw Fig. 3a
# ------------
# Slip on the left axis, imposed force on the right; the red dashed line is ``F_peak`` and
# the grey dashed curve the quasi-static slip along the rising branch of ``F(x)``.
slip_ax, force_ax = plot_stress_ramp(result.to_run(), params)
plt.show()
