"""The healing figure of the docs (``docs/_static/slide_hold_slide_healing.png``).

A noisy aging-law record of the independent generator (``slide_hold_slide_synthetic.py``,
seed 1) read and measured by granflow (:func:`granflow.rsf.healing`), with each law's curve
from the same independent solver with the true parameters (noise-free records over 15 hold
times from 1 to 3000 s, measured the same way), rate-and-state's rigid-slider approximation
b ln(1 + v t_h / Dc) and the paper's time-clock prediction fitted to the measured peaks.

    PYTHONPATH=src python tools/slide_hold_slide_figure.py docs/_static/slide_hold_slide_healing.png
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import slide_hold_slide_synthetic as synthetic

from granflow import rsf
from granflow.fitting.healing import aging_law_healing
from granflow.plotting.healing import plot_healing


def main(argv=None):
    import matplotlib

    matplotlib.use("Agg")
    output = Path((argv or sys.argv[1:])[0])
    measured = rsf.healing(
        rsf.parse_slide_hold_slide(
            synthetic.table(*synthetic.noisy(synthetic.simulate("aging"), 1)[:3])
        )
    )
    dense = tuple(float(h) for h in np.geomspace(1.0, 3000.0, 15))
    curves = {}
    for law in ("aging", "slip"):
        record = rsf.parse_slide_hold_slide(
            synthetic.table(*synthetic.simulate(law, holds=dense)[:3])
        )
        curves[law] = (dense, rsf.healing(record).delta_mu_peak)
    ax = plot_healing(measured, curves=curves)
    slider = synthetic.Slider()
    ax.semilogx(
        dense,
        aging_law_healing(dense, slider.b, slider.Dc / 2e-6),
        ":",
        color="C0",
        label=r"$b\,\ln(1 + v t_\mathrm{h}/D_c)$ (rigid slider)",
    )
    ax.legend(fontsize="small", loc="upper left")
    ax.set_title("aging-law record (independent solver, seed 1)")
    ax.figure.savefig(output, dpi=110)
    print(measured.summary())
    print(f"paper fit: mu_a = {measured.paper_mu_a:.4g}, age at start = {measured.paper_age:.3g} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
