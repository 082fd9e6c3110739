"""Shared helpers of the plotting functions."""

MILLI = 1e3  # N -> mN
MICRO = 1e6  # m -> µm, m/s -> µm/s


def new_axes(ax=None, *, figsize=(6.0, 4.0)):
    """Return ``ax``, or a fresh Axes on a new figure when ``ax`` is None."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax
