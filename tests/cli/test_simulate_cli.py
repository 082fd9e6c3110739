"""The simulate and stability-map commands (in-process) and the simulation figures."""

import matplotlib.pyplot as plt
import pandas as pd
import pytest

import granflow as gf
from granflow.cli import main
from granflow.plotting import (
    plot_simulation,
    plot_simulation_force,
    plot_simulation_slip,
    plot_stability_map,
)

PARAMS = """\
a: 3.31 mN
k: 0.036 /s
t0: 0.23 s
Fd: 10 mN
velocity: 0.86 um/s
"""

SWITCH = """\
segments:
  - velocity: {velocity: 0.86 um/s, duration: 80 s}
  - switch_to_force: {duration: 60 s, factor: 1.01}
"""


@pytest.fixture
def files(tmp_path):
    params = tmp_path / "blue.yaml"
    params.write_text(PARAMS, encoding="utf-8")
    protocol = tmp_path / "switch.yaml"
    protocol.write_text(SWITCH, encoding="utf-8")
    return tmp_path, params, protocol


def test_simulate_command_writes_csv_and_figure(files, capsys):
    folder, params, protocol = files
    out, png = folder / "out.csv", folder / "out.png"
    code = main(
        ["simulate", str(protocol), "--params", str(params), "-o", str(out), "--plot", str(png)]
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert "failure" in printed and "[[Events]]" in printed
    frame = pd.read_csv(out)
    assert {"t_s", "slip_m", "velocity_m_s", "force_N", "state_N"} <= set(frame.columns)
    assert png.stat().st_size > 1000


def test_simulate_command_dynamic_options(files, capsys):
    _, params, protocol = files
    code = main(
        [
            "simulate",
            str(protocol),
            "--params",
            str(params),
            "--method",
            "dynamic",
            "--mass",
            "0.05kg",
            "--damping",
            "1N*s/m",
            "--v-fail",
            "1mm/s",
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert "mass       = 0.05 kg" in printed and "v_fail     = 1000 µm/s" in printed


def test_simulate_command_reports_bad_input(files, capsys):
    folder, params, _ = files
    bad = folder / "bad.yaml"
    bad.write_text("segments:\n  - force: {duration: 10}\n", encoding="utf-8")
    assert main(["simulate", str(bad), "--params", str(params)]) == 2
    assert "level is missing" in capsys.readouterr().err
    incomplete = folder / "params.yaml"
    incomplete.write_text("a: 3mN\nalpha: 4e4\n", encoding="utf-8")
    assert main(["simulate", str(bad), "--params", str(incomplete)]) == 2
    assert "missing parameter" in capsys.readouterr().err
    assert main(["simulate", str(bad), "--params", str(params), "--mass", "1kg"]) == 2


def test_stability_map_command(files, capsys):
    folder, params, _ = files
    out, png = folder / "map.csv", folder / "map.png"
    code = main(
        [
            "stability-map",
            "--params",
            str(params),
            "--switch-points",
            "5s,10s,80s",
            "--ratios",
            "0.95:1.3:4",
            "-o",
            str(out),
            "--plot",
            str(png),
        ]
    )
    assert code == 0
    assert "[[Stability map]]" in capsys.readouterr().out
    frame = pd.read_csv(out)
    assert len(frame) == 12 and set(frame["outcome"]) == {"stop", "failure"}
    assert png.stat().st_size > 1000
    assert (
        main(["stability-map", "--params", str(params), "--switch-points", "1:2", "--ratios", "1"])
        == 2
    )


def test_plots_return_axes():
    params = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    steps = gf.Protocol([gf.ForceSteps([4e-3, 8e-3, 12e-3, 14e-3], 20.0)])
    result = gf.simulate(params, steps)
    axes = plot_simulation(result)
    assert len(axes) == 2 and axes[0].get_ylabel() == "force [mN]"
    assert plot_simulation_force(result).get_xlabel() == "time [s]"
    assert plot_simulation_slip(result).get_ylabel() == "slip [µm]"
    smap = gf.stability_map(params, [5.0, 10.0, 20.0], [1.0, 1.1], velocity=0.86e-6)
    ax = plot_stability_map(smap)
    assert "quasistatic" in ax.get_title()
    plt.close("all")
