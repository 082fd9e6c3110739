"""The slip clock's closed form from any state: Eq. 3 with the general initial condition.

From a state (x_s, F_s) the layer, when it slides, follows
``F(x) = friction_slip(x, params.replace(x0=x_s), F_init=F_s)``; :class:`Curve` evaluates it,
finds its peak and inverts it on the rising branch (root finding). This is the one place the
simulator calls the compiled Eq. 3 point kernel
(:func:`granflow.model.kernel.general_value`).
"""

import numpy as np
from scipy.optimize import brentq

from granflow.model.friction import friction_slip, has_peak, peak
from granflow.model.kernel import general_value

__all__ = ["Curve", "offset_of", "offsets"]

_RTOL = 4 * np.finfo(float).eps  # the finest relative tolerance brentq accepts


class Curve:
    """The slip-clock solution through (z_s, F_s): F(z) along the coordinate z >= z_s."""

    def __init__(self, params, start, force):
        self.params = params.replace(x0=start)
        self.start = start
        self.force = force
        self._peak = None
        self._peak_known = False

    def __call__(self, z):
        p = self.params
        return general_value(z, p.a, p.alpha, p.Fd, self.start, self.force)

    def values(self, z):
        return friction_slip(np.maximum(z, self.start), self.params, F_init=self.force)

    def slope(self, z, F):
        p = self.params
        return p.a / z - p.alpha * (F - p.Fd)

    @property
    def peak(self):
        """(z, F) of the maximum ahead, or None when F does not rise from here."""
        if not self._peak_known:
            self._peak_known = True
            if has_peak(self.params, F_init=self.force):
                top = peak(self.params, F_init=self.force)
                self._peak = (top.slip, top.force)
        return self._peak

    def top(self):
        """(sup of F ahead, whether it is attained)."""
        if self.peak is not None:
            return self.peak[1], True
        p = self.params
        if p.a == 0 and self.force < p.Fd:
            return p.Fd, False
        return self.force, True

    def root(self, target, upper=None):
        """The first z >= z_s with F(z) = target on the rising branch (F(z_s) <= target)."""
        if upper is None:
            upper = self.peak[0] if self.peak is not None else 2.0 * self.start
            while self(upper) < target:
                upper = self.start + 2.0 * (upper - self.start)
        if self(upper) <= target:
            return upper
        return brentq(
            lambda z: self(z) - target,
            self.start,
            upper,
            xtol=self.start * 1e-16,
            rtol=_RTOL,
            maxiter=200,
        )


def offset_of(z_peak, z_of, duration):
    """The offset in [0, duration] where the increasing z_of(offset) equals z_peak."""
    if z_peak <= z_of(0.0):
        return 0.0
    return brentq(lambda u: z_of(u) - z_peak, 0.0, duration, xtol=1e-15 * duration, rtol=_RTOL)


def offsets(duration, points):
    """Sample offsets in [0, duration]: even spacing plus geometric refinement near 0."""
    even = np.linspace(0.0, duration, max(points, 2))
    fine = np.geomspace(duration * 1e-5, duration, max(points // 4, 2))
    return np.union1d(even, fine)
