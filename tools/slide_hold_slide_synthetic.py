"""Synthetic slide-hold-slide records from an independent solver (not granflow's).

A rate-and-state spring-slider integrated with ``scipy.integrate.solve_ivp`` (Radau),
written here from the equations alone:

    dmu/dt = k (v_lp - v),       mu = mu0 + a ln(v / v0) + b ln(v0 theta / Dc)
    aging: dtheta/dt = 1 - v theta / Dc
    slip:  dtheta/dt = -(v theta / Dc) ln(v theta / Dc)

integrated in (mu, ln theta). The load point slides at ``velocity``, holds for each hold time
(1 to 3000 s by default), and slides again; each slide is ``slide`` metres long (300 µm at
2 µm/s by default: 30 Dc, so that each slide returns to steady sliding after the largest
peak). Sampling: 4 Hz while sliding and for the first 10 s of a hold, then 1 Hz (a logger
slowing down during long holds). Noise: Gaussian, ``noise`` on friction and
``displacement_noise`` [m] on the load point.

    python tools/slide_hold_slide_synthetic.py out.txt --law aging --seed 1

writes a record in the reader's format (``Time(s)``, ``Displ(microns)``, ``Friction``).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

HOLDS = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0)


@dataclass(frozen=True)
class Slider:
    """The true parameters: mu0 [-] at v0 [m/s], a, b [-], Dc [m], stiffness k [1/m]."""

    mu0: float = 0.6
    a: float = 0.010
    b: float = 0.015
    Dc: float = 10e-6
    k: float = 2e3
    v0: float = 2e-6


def _rhs(law, p):
    def rhs(_t, y, v_lp):
        mu, psi = y
        theta = math.exp(psi)
        v = p.v0 * math.exp((mu - p.mu0 - p.b * math.log(p.v0 * theta / p.Dc)) / p.a)
        omega = v * theta / p.Dc
        dpsi = (1.0 - omega) / theta if law == "aging" else -(v / p.Dc) * math.log(omega)
        return [p.k * (v_lp - v), dpsi]

    return rhs


def sample_times(duration, hold, rate=4.0, slow_rate=1.0, fast=10.0):
    """Sampling times within a piece of ``duration`` [s] from its start (excluded) to its
    end (included): ``rate`` [Hz] throughout, or for a hold ``rate`` during the first
    ``fast`` seconds then ``slow_rate``."""
    if not hold or duration <= fast:
        count = max(round(duration * rate), 1)
        return np.linspace(0.0, duration, count + 1)[1:]
    head = np.arange(1, round(fast * rate) + 1) / rate
    tail = np.arange(fast + 1.0 / slow_rate, duration + 1e-9, 1.0 / slow_rate)
    times = np.concatenate([head, tail])
    if times[-1] < duration - 1e-9:
        times = np.append(times, duration)
    return times


def simulate(law, slider=Slider(), holds=HOLDS, *, velocity=2e-6, slide=300e-6, rate=4.0):
    """Noise-free record: (t [s], load-point displacement [m], friction [-], hold starts [s]).

    The slider starts at steady state at ``velocity``; slides and holds alternate, starting
    and ending with a slide.
    """
    p = slider
    rhs = _rhs(law, p)
    theta = p.Dc / velocity
    y = np.array([p.mu0 + (p.a - p.b) * math.log(velocity / p.v0), math.log(theta)])
    pieces = [(velocity, slide / velocity)]
    for hold in holds:
        pieces += [(0.0, float(hold)), (velocity, slide / velocity)]
    times, load, friction, starts = [0.0], [0.0], [y[0]], []
    clock, position = 0.0, 0.0
    for v_lp, duration in pieces:
        if v_lp == 0.0:
            starts.append(clock)
        local = sample_times(duration, v_lp == 0.0, rate)
        solution = solve_ivp(
            rhs,
            (0.0, duration),
            y,
            method="Radau",
            t_eval=local,
            args=(v_lp,),
            rtol=1e-10,
            atol=[1e-13, 1e-10],
        )
        if not solution.success:
            raise RuntimeError(solution.message)
        times.extend(clock + solution.t)
        load.extend(position + v_lp * solution.t)
        friction.extend(solution.y[0])
        y = solution.y[:, -1]
        clock += duration
        position += v_lp * duration
    return np.array(times), np.array(load), np.array(friction), np.array(starts)


def noisy(record, seed, noise=3e-4, displacement_noise=5e-9):
    """The record with Gaussian noise added (friction ``noise`` [-], displacement [m])."""
    t, load, friction, starts = record
    rng = np.random.default_rng(seed)
    return (
        t,
        load + rng.normal(0.0, displacement_noise, t.size),
        friction + rng.normal(0.0, noise, t.size),
        starts,
    )


def table(t, load, friction, time_offset=1000.0):
    """The reader's format: tab-separated, ``Time(s)``, ``Displ(microns)``, ``Friction``."""
    rows = [
        f"{time_offset + ti:.6f}\t{xi * 1e6:.6f}\t{mi:.7f}"
        for ti, xi, mi in zip(t, load, friction, strict=True)
    ]
    return "Time(s)\tDispl(microns)\tFriction\n" + "\n".join(rows) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--law", choices=("aging", "slip"), default="aging")
    parser.add_argument("--seed", type=int, default=None, help="no noise without a seed")
    parser.add_argument("--noise", type=float, default=3e-4)
    args = parser.parse_args(argv)
    record = simulate(args.law)
    if args.seed is not None:
        record = noisy(record, args.seed, args.noise)
    with open(args.output, "w", encoding="utf-8") as handle:
        handle.write(table(*record[:3]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
