"""The confidence distribution of a profiled quantity: one distribution behind a forecast's
interval, its ``probability_within`` and its step probabilities.

The signed root of the profile likelihood, ``r(q) = sign(q - q_hat) sqrt(delta chi-square)``,
is Student's t with the fit's degrees of freedom when the noise is estimated (standard normal
when it is known), so ``C(q) = T(r(q))`` is a confidence distribution of q: its quantiles
are the ends of the profile-likelihood intervals at every level. r is interpolated linearly
in the optimiser's coordinate of q (nearly linear there) between the profile's points, and
extrapolated from the outermost two on a side that reached its last height. A side whose
profile ran into the end of the search range without reaching it keeps the rest of the
probability beyond that end: above, "the record does not bound the failure"; below, at the
floor (the least the quantity can be).
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr, ndtri, stdtr, stdtrit

__all__ = ["Distribution"]


@dataclass(frozen=True)
class Distribution:
    """C(q) of a quantity q = ``offset + scale exp(u)`` (``log``) or ``offset + scale u``.

    Attributes
    ----------
    u, r : numpy.ndarray
        The profile's nodes: optimiser coordinates (increasing) and signed roots
        (non-decreasing).
    offset, scale : float
        The map from u to q [the quantity's unit].
    log : bool
        Whether the map is exponential.
    dof : int or None
        Student's t degrees of freedom; None for the normal.
    open_below, open_above : bool
        Whether a side's profile ran to the end of its range without reaching its height.
    low_end, high_end : float
        The search range's ends in u.
    """

    u: np.ndarray
    r: np.ndarray
    offset: float
    scale: float
    log: bool
    dof: int | None
    open_below: bool
    open_above: bool
    low_end: float
    high_end: float

    def _quantity(self, u):
        return self.offset + self.scale * (np.exp(u) if self.log else u)

    def _coordinate(self, q):
        q = np.asarray(q, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.log:
                return np.log((q - self.offset) / self.scale)
            return (q - self.offset) / self.scale

    def _cdf_of_root(self, r):
        return stdtr(self.dof, r) if self.dof is not None else ndtr(r)

    def _root_of_probability(self, p):
        return stdtrit(self.dof, p) if self.dof is not None else ndtri(p)

    def _root(self, u):
        """r at coordinates u: interpolated, extrapolated on a closed side, held on an open
        one (with -inf below the low end and +inf... see :meth:`cdf`)."""
        u = np.asarray(u, dtype=float)
        nodes_u, nodes_r = self.u, self.r
        out = np.interp(u, nodes_u, nodes_r)
        if nodes_u.size >= 2:
            for side in (-1, 1):
                i, j = (0, 1) if side < 0 else (-1, -2)
                du = nodes_u[i] - nodes_u[j]
                slope = (nodes_r[i] - nodes_r[j]) / du if du != 0 else 0.0
                beyond = (u < nodes_u[0]) if side < 0 else (u > nodes_u[-1])
                if slope > 0 and not (self.open_below if side < 0 else self.open_above):
                    out = np.where(beyond, nodes_r[i] + slope * (u - nodes_u[i]), out)
        return out

    def cdf(self, q):
        """C(q) [-]: the probability that the quantity is at most q. Below the floor 0;
        above the end of an open range, what the profile reached there (the rest lies
        beyond every finite q). NaN where the profile has fewer than two points (it says
        nothing)."""
        if self.u.size < 2:
            return math.nan if np.ndim(q) == 0 else np.full(np.shape(q), math.nan)
        u = self._coordinate(q)
        r = self._root(np.where(np.isfinite(u), u, 0.0))
        out = self._cdf_of_root(r)
        out = np.where(np.isnan(u) | (u == -np.inf), 0.0, out)
        out = np.where(u == np.inf, self.top, out)
        if self.open_below:
            out = np.where(u < self.u[0], self._cdf_of_root(self.r[0]), out)
        return float(out) if np.ndim(out) == 0 else out

    @property
    def top(self):
        """C at the end of the range: 1, or less where the profile is open above."""
        if not self.open_above:
            return 1.0
        return float(self._cdf_of_root(self.r[-1]))

    @property
    def bottom(self):
        """The probability held at the floor: 0, or more where the profile is open below."""
        if not self.open_below:
            return 0.0
        return float(self._cdf_of_root(self.r[0]))

    def quantile(self, p):
        """q at which C reaches p; the floor (``offset``) where the probability held there
        already exceeds p, inf where C never reaches it."""
        if p <= self.bottom:
            return float(self.offset)
        if p >= self.top:
            return math.inf
        target = float(self._root_of_probability(p))
        nodes_u, nodes_r = self.u, self.r
        if nodes_r[0] <= target <= nodes_r[-1]:
            # the first node at or above the target, interpolated from the one before
            k = int(np.searchsorted(nodes_r, target, side="left"))
            if k == 0 or nodes_r[k] == target:
                return float(self._quantity(nodes_u[k]))
            r0, r1 = nodes_r[k - 1], nodes_r[k]
            u = nodes_u[k - 1] + (target - r0) * (nodes_u[k] - nodes_u[k - 1]) / (r1 - r0)
            return float(self._quantity(u))
        side = -1 if target < nodes_r[0] else 1
        i, j = (0, 1) if side < 0 else (-1, -2)
        du = nodes_u[i] - nodes_u[j] if nodes_u.size >= 2 else 0.0
        slope = (nodes_r[i] - nodes_r[j]) / du if du != 0 else 0.0
        if slope <= 0:
            return float(self.offset) if side < 0 else math.inf
        # extrapolated, but not past the search range: the tails stay where q can be
        u = min(max(nodes_u[i] + (target - nodes_r[i]) / slope, self.low_end), self.high_end)
        return float(self._quantity(u))

    def interval(self, level):
        """The level interval of q: the central one ``[q((1 - level)/2), q((1 + level)/2)]``
        where both ends exist; one-sided ``[q(1 - level), inf)`` where the upper end does
        not (the profile open above), ``[floor, q(level)]`` where the floor holds more than
        the lower tail; ``[floor, inf)`` where neither side says anything."""
        low, high = self.quantile(0.5 * (1 - level)), self.quantile(0.5 * (1 + level))
        p_floor = self.bottom
        if math.isinf(high) and p_floor >= 0.5 * (1 - level):
            return (float(self.offset), math.inf)
        if math.isinf(high):
            return (self.quantile(1 - level), math.inf)
        if p_floor >= 0.5 * (1 - level):
            return (float(self.offset), self.quantile(level))
        return (low, high)

    def median(self):
        """q at C = 1/2 (the best fit where the profile is smooth); inf where the profile
        does not bound it."""
        return self.quantile(0.5)

    def table(self, count=49):
        """(q, C) at ``count`` nodes spread over the distribution (its quantiles from 0.1 % to
        99.9 % where they exist, and the range's ends on an open side): a table from which
        the CDF can be read back by linear interpolation."""
        probabilities = ndtr(np.linspace(-3.1, 3.1, count))
        lo, hi = self.bottom, self.top
        keep = probabilities[(probabilities > lo) & (probabilities < hi)]
        q = [self.quantile(float(p)) for p in keep]
        pairs = [(qq, float(p)) for qq, p in zip(q, keep, strict=True) if math.isfinite(qq)]
        if self.open_below:
            pairs.insert(0, (float(self.offset), lo))
        if self.open_above:
            pairs.append((float(self._quantity(self.high_end)), hi))
        pairs.sort()
        return [p[0] for p in pairs], [p[1] for p in pairs]
