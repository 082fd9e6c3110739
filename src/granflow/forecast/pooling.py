"""A record held in bounded memory: its samples pooled in equal runs, so that a forecast that
follows a record for hours costs the same at every update.

A :class:`Pool` keeps at most ``2 * max_points`` points. While the record is shorter each
point is one sample; when it grows past that, neighbouring points are merged in pairs, so
every point is the mean (of time, slip and force alike) of ``width`` consecutive samples,
``width`` a power of two, the same for all points: the pooled record is homoscedastic (each
point's noise the samples' over sqrt(width)), as the forecasts' likelihoods assume. The
samples of the run not yet complete make one more point, their mean, so the pooled record
ends at the latest sample's information (its last point carries fewer samples: one point of
hundreds, whose greater noise the fit does not weigh).

Pooling keeps what a smooth record says (a bin's mean is the curve at the bin's mean time up
to the curve's second derivative times the bin's duration squared over 24); it blurs what
happens within one bin, so ``max_points`` should leave bins short beside the time scale of
the acceleration before failure (at 10 Hz and 2048 points, a day of record pools 64 or 128
samples, 6.4 or 12.8 s, a point).
"""

from __future__ import annotations

import numpy as np

__all__ = ["Pool"]


class Pool:
    """Columns of a growing record pooled in equal runs of ``width`` samples.

    Parameters
    ----------
    names : sequence of str
        The columns ("t", "slip", "force", ...).
    max_points : int
        Most complete points kept before pairs are merged (at least 16); the pooled record
        has between ``max_points / 2`` and ``max_points`` of them, plus the incomplete one.

    Examples
    --------
    >>> import numpy as np
    >>> pool = Pool(["t"], max_points=16)
    >>> pool.add({"t": np.arange(40.0)})
    >>> pool.width, pool.column("t")[:3], pool.size
    (4, array([1.5, 5.5, 9.5]), 10)
    """

    def __init__(self, names, max_points):
        if int(max_points) < 16:
            raise ValueError(f"max_points must be at least 16, got {max_points}")
        self.names = tuple(names)
        self.max_points = int(max_points)
        self.width = 1
        self.samples = 0
        self._full = {name: np.empty(2 * self.max_points + 2) for name in self.names}
        self._count = 0  # complete points
        self._partial = {name: [] for name in self.names}  # samples of the incomplete point

    @property
    def size(self):
        """Points in the pooled record (the incomplete one included)."""
        return self._count + (1 if self._partial[self.names[0]] else 0)

    def add(self, columns):
        """Take new samples: ``{name: 1-d array}``, all of one length."""
        length = len(columns[self.names[0]])
        self.samples += length
        pending = {
            name: np.concatenate([self._partial[name], np.asarray(columns[name], float)])
            for name in self.names
        }
        while True:
            whole = len(pending[self.names[0]]) // self.width
            room = 2 * self.max_points + 2 - self._count
            take = min(whole, room)
            for name in self.names:
                values = pending[name][: take * self.width].reshape(take, self.width)
                self._full[name][self._count : self._count + take] = values.mean(axis=1)
                pending[name] = pending[name][take * self.width :]
            self._count += take
            if self._count > self.max_points:
                self._merge(pending)
            if len(pending[self.names[0]]) < self.width:
                break
        self._partial = {name: list(pending[name]) for name in self.names}

    def _merge(self, pending):
        """Pairs of points merged: the width doubles; an odd last point goes back to the
        pending samples, as ``width`` copies of its mean (its samples' sum is kept)."""
        pairs = self._count // 2
        for name in self.names:
            full = self._full[name]
            merged = 0.5 * (full[0 : 2 * pairs : 2] + full[1 : 2 * pairs : 2])
            if self._count % 2:
                pending[name] = np.concatenate(
                    [np.full(self.width, full[self._count - 1]), pending[name]]
                )
            full[:pairs] = merged
        self._count = pairs
        self.width *= 2

    def column(self, name):
        """The pooled column: the complete points' means and the incomplete point's (a new
        array)."""
        full = self._full[name][: self._count]
        partial = self._partial[name]
        return np.append(full, np.mean(partial)) if partial else full.copy()
