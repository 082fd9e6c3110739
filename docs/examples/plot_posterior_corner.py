"""
Posterior of a start-up fit (emcee)
===================================

The least-squares fit gives values, standard errors and profile-likelihood intervals. For the
full shape of the uncertainty — the strong correlation between the aging amplitude ``a`` and
the initial state ``x0``, for instance — sample the posterior with emcee
(:func:`granflow.sample_posterior`, extra ``granflow[mcmc]``) and draw it with
:func:`granflow.plotting.plot_corner` (the ``corner`` package).

The chain here is kept short so that the page builds in seconds; a real analysis uses the
default 2000 steps and checks the autocorrelation time (granflow warns with a
``ConvergenceWarning`` when the chain is shorter than 50 of them).
"""

# %%
# A synthetic start-up with known parameters, and its fit
# --------------------------------------------------------
import warnings

import matplotlib.pyplot as plt
import numpy as np

import granflow as gf
from granflow.plotting import plot_corner

truth = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=3e-7)  # N, 1/m, N, m
slip = np.linspace(0.86e-6, 200e-6, 200)  # m
rng = np.random.default_rng(0)
force = gf.friction_slip(slip, truth) + rng.normal(0.0, 3e-5, slip.size)  # N
fit = gf.fit((slip, force))
print(fit.report())

# %%
# Sample the posterior (a short chain)
# ------------------------------------
with warnings.catch_warnings():
    warnings.simplefilter("ignore", gf.ConvergenceWarning)  # the chain is short on purpose
    posterior = gf.sample_posterior(fit, nwalkers=12, nsteps=250, seed=1)
print(posterior)

# %%
# Draw the corner plot
# --------------------
# One panel per pair of free parameters; the least-squares values are marked.
figure = plot_corner(posterior)
plt.show()
