"""
Rate-and-state friction: a velocity step
========================================

The comparison family of friction science. In rate-and-state friction the friction
coefficient depends on the slip rate and on a state variable θ (the age of the contacts):

.. code-block:: text

   μ = μ0 + a ln(v/v_ref) + b ln(v_ref θ / D_c)
   dθ/dt = 1 − v θ / D_c              (aging law, Dieterich)
   dθ/dt = −(v θ / D_c) ln(v θ / D_c)  (slip law, Ruina)

and a spring of stiffness ``k`` connects the slider to the load point. The classic experiment
steps the load-point velocity: friction jumps by the *direct effect* ``a ln(v2/v1)``, then
decays over a slip of order ``D_c`` by ``b ln(v2/v1)`` to the new steady state
``μ_ss = μ0 + (a − b) ln(v/v_ref)``. With ``b > a`` (velocity weakening, as here) the new
steady friction is lower.

The two state laws agree near steady state and differ in their transients: the slip law
responds symmetrically to steps up and down, the aging law does not.
"""

# %%
# A tenfold step, 1 → 10 µm/s, under the aging and the slip law
# ---------------------------------------------------------------
import matplotlib.pyplot as plt
import numpy as np

import granflow as gf
from granflow import rsf

v1, v2 = 1e-6, 10e-6  # m/s
step = gf.Protocol([gf.Velocity(v1, 50.0), gf.Velocity(v2, 15.0)])
t = np.linspace(0.0, 65.0, 1301)  # s
results = {}
for law in ("aging", "slip"):
    model = rsf.RateState(
        mu0=0.6, a=0.005, v_ref=v1, stiffness=2e3, states=[rsf.State(b=0.008, Dc=10e-6, law=law)]
    )
    results[law] = rsf.simulate(model, step, t_eval=t)
print(f"steady state before: {model.steady_state_friction(v1):.5f}")
print(f"steady state after:  {model.steady_state_friction(v2):.5f}  (a − b) ln 10 lower")
for law, result in results.items():
    after = result.t > 50.0
    print(f"{law} law: friction peaks at {result.friction[after].max():.5f} after the step")

# %%
# Friction against the load point's displacement
# ----------------------------------------------
# The step is at 50 µm. The dashed lines are the steady states before and after.
fig, ax = plt.subplots(figsize=(6.4, 4.2), layout="constrained")
for law, result in results.items():
    load_point = np.cumsum(np.r_[0.0, np.diff(result.t) * result.load_point_velocity[1:]])
    ax.plot(load_point * 1e6, result.friction, label=f"{law} law")
for v in (v1, v2):
    ax.axhline(model.steady_state_friction(v), color="grey", linestyle="--", linewidth=0.8)
ax.set_xlabel("load-point displacement [µm]")
ax.set_ylabel("friction coefficient μ [-]")
ax.set_xlim(30, 200)
ax.legend(title=r"$k$ = 2000 1/m, $a$ = 0.005, $b$ = 0.008, $D_\mathrm{c}$ = 10 µm")
plt.show()
