"""Shared fixtures: the paper's parameter sets (SPEC §4) and the shared data folder."""

import os
from pathlib import Path

import pytest

import granflow as gf

#: Fig. 2a fits at v = 0.86 µm/s: (a [N], k [1/s], t0 [s])
PAPER_SETS = {
    "blue": (3.31e-3, 0.036, 0.23),
    "gray": (2.99e-3, 0.051, 0.39),
    "black": (2.67e-3, 0.058, 0.55),
}
PAPER_VELOCITY = 0.86e-6  # m/s


def paper_params(name="blue", Fd=10e-3):
    """SPEC §4 parameter set ``name`` with steady friction Fd [N]."""
    a, k, t0 = PAPER_SETS[name]
    return gf.Params.from_time_domain(a=a, k=k, t0=t0, Fd=Fd, velocity=PAPER_VELOCITY)


@pytest.fixture
def blue():
    return paper_params("blue")


def shared_dir():
    """The shared/ folder beside the repository (or $GRANFLOW_SHARED)."""
    if "GRANFLOW_SHARED" in os.environ:
        return Path(os.environ["GRANFLOW_SHARED"])
    return Path(__file__).resolve().parents[1].parent / "shared"
