"""Two independent random streams from one seed (NumPy's ``SeedSequence``)."""

import numpy as np

__all__ = ["two_streams"]


def two_streams(seed: int | None) -> tuple[np.random.Generator, int]:
    """A generator (the first spawned child of ``SeedSequence(seed)``) and a 32-bit integer
    seed drawn from the sequence's own pool: two streams that do not overlap."""
    seeds = np.random.SeedSequence(seed)
    return np.random.default_rng(seeds.spawn(1)[0]), int(seeds.generate_state(1)[0])
