"""A quasi-static staircase's failure step by step.

Under a staircase the layer fails at the start of the first step whose level reaches F_peak,
so the outcome is discrete: the continued step j (level ``L_j = L_last + j step``, j = 1,
2, ...) breaks the layer when ``L_(j-1) < P <= L_j``, P the force at which the fitted history
stands when the true one reaches F_peak. Its probability is ``C(L_j) - C(L_(j-1))``, C the
confidence distribution of P (:class:`~granflow.forecast.distribution.Distribution`); the
record has held ``L_last``, so the first step takes all the probability below its level.
"""

import math

import numpy as np

__all__ = ["step_cdf", "step_table"]

_STEP_MASS = 1e-4  # steps less likely than this end the table
_TABLE_STEPS = 1000  # at most this many steps are listed


def step_table(distribution, loading, level):
    """The steps' probabilities and the time interval of whole steps.

    Parameters
    ----------
    distribution : Distribution
        The confidence distribution of P [N].
    loading : Loading
        The staircase (``kind == "steps"``).
    level : float
        The interval's level [-].

    Returns
    -------
    tuple of (dict, tuple of float)
        ``(table, interval)``: the table {"step": number of the step, the record's first as
        1; "level" [N]; "earliest", "latest": the range of its start [s]; "probability" [-];
        "below": the probability of the earlier steps left out (together under 1e-4);
        "beyond": the probability above the last step listed}; the interval [s] is the
        smallest run of whole steps about the most likely ones whose probability reaches
        ``level``, open above where the steps listed do not hold it.
    """
    last, step = loading.levels[-1], loading.step

    def cumulative(j):
        return float(distribution.cdf(last + j * step)) if j > 0 else 0.0

    # C is monotone in j: the steps before the first with probability are left out
    before, first = 0, 1
    while cumulative(first) < _STEP_MASS and first < 2**40:
        before, first = first, 2 * first
        if cumulative(first) >= distribution.top - 1e-12:
            break
    while first - before > 1:
        middle = (before + first) // 2
        before, first = (before, middle) if cumulative(middle) >= _STEP_MASS else (middle, first)
    below = cumulative(before)
    rows, held = [], below
    for j in range(first, first + _TABLE_STEPS):
        value = max(cumulative(j), held)
        rows.append((len(loading.levels) + j, last + j * step, value - held))
        held = value
        if distribution.top - held < _STEP_MASS:
            break
    beyond = max(1.0 - held, 0.0)
    earliest, latest = loading.step_starts(len(loading.levels) - 1 + first, len(rows))
    table = {
        "step": [row[0] for row in rows],
        "level": [row[1] for row in rows],
        "earliest": earliest.tolist(),
        "latest": latest.tolist(),
        "probability": [row[2] for row in rows],
        "below": float(below),
        "beyond": float(beyond),
    }
    probability = np.array(table["probability"])
    chosen = np.argsort(-probability, kind="stable")
    enough = np.flatnonzero(np.cumsum(probability[chosen]) >= level - 1e-12)
    if not enough.size:
        # the steps listed hold less than the level: open above, from the first likely one
        start = table["earliest"][0] if rows else math.inf
        return table, (start, math.inf)
    kept = chosen[: enough[0] + 1]
    return table, (table["earliest"][int(kept.min())], table["latest"][int(kept.max())])


def step_cdf(table):
    """(times [s], probabilities [-]) of the failure time's CDF under a staircase: each step's
    probability added across the window of its start (linearly; where the window is a
    point, at once)."""
    times, values = [], []
    held = table["below"]
    for start, end, p in zip(table["earliest"], table["latest"], table["probability"], strict=True):
        times.append(float(start))
        values.append(held)
        held += p
        times.append(float(end) if end > start else float(start) * (1 + 1e-12) + 1e-12)
        values.append(held)
    return times, values
