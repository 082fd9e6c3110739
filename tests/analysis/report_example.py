"""A realistic results dict (the layout of results.json) for the report tests.

Built from granflow's own results on a small synthetic campaign: nine start-up runs over three
normal loads at 0.86 µm/s, two more at 2.58 µm/s, a creep run, a stress ramp, a switch and one
corrupt file; figures drawn with matplotlib (Agg) into the output folder and referenced by
relative paths, as the analysis writes them.
"""

import hashlib
import json

import numpy as np

import granflow as gf

VELOCITY = 0.86e-6  # m/s
FAST = 2.58e-6  # m/s
LOADS = (0.03, 0.06, 0.09)  # N
MU_A, MU_D, ALPHA = 0.06, 0.2, 5e4
NOISE = 3e-5  # N
FAILED = {
    "name": "corrupt-07",
    "source": "exports/corrupt-07.csv",
    "reason": "line 14 of exports/corrupt-07.csv: torque column 'Torque [µN·m]' has a "
    "non-numeric value 'abc'",
}


def _startup(load, x0, rng, points=120):
    params = gf.Params(a=MU_A * load, alpha=ALPHA, Fd=MU_D * load, x0=x0)
    slip = np.linspace(3 * x0, 150e-6, points)
    return slip, gf.friction_slip(slip, params) + rng.normal(0.0, NOISE, points)


def _run_entry(name, source, test, load, velocity, preparation, fit=None):
    return {
        "name": name,
        "source": source,
        "interval": 1,
        "test": test,
        "normal_load": load,
        "velocity": velocity,
        "preparation": preparation,
        "status": "ok",
        "fit": fit,
    }


def _save(figure, directory, stem):
    """PNG (and SVG) of a figure under directory/figures; paths relative to directory."""
    folder = directory / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    figure.savefig(folder / f"{stem}.png", dpi=80)
    figure.savefig(folder / f"{stem}.svg")
    return {"png": f"figures/{stem}.png", "svg": f"figures/{stem}.svg"}


def _figures(directory, fits, amontons):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    startup = fits[0].plot().figure
    entries = [
        {
            "name": "startup",
            "title": "Start-up curves with fits and residuals",
            "caption": "Friction force against slip at 0.86 µm/s; lines: Eq. 3.",
            **_save(startup, directory, "startup"),
        }
    ]
    plt.close(startup)
    axes = gf.plotting.plot_amontons(amontons)
    entries.append(
        {
            "name": "amontons",
            "title": "Amontons' law",
            "caption": "a, α and F_d against the normal load (mean ± standard error).",
            **_save(axes[0].figure, directory, "amontons"),
        }
    )
    plt.close(axes[0].figure)
    return entries


def example_results(directory, *, seed=0):
    """Write the figures and input files of a small campaign under ``directory`` and return
    its results dict (JSON round-tripped, as read back from results.json)."""
    rng = np.random.default_rng(seed)
    exports = directory / "exports"
    exports.mkdir(parents=True, exist_ok=True)
    datasets, loads, velocities, runs = [], [], [], []
    for load in LOADS:
        for repeat in range(3):
            datasets.append(_startup(load, (0.2 + 0.1 * repeat) * 1e-6, rng))
            loads.append(load)
            velocities.append(VELOCITY)
            runs.append((f"N{load * 1e3:.0f}-r{repeat + 1}", f"prep-{repeat + 1}"))
    for repeat in range(2):
        datasets.append(_startup(0.06, (0.2 + 0.1 * repeat) * 1e-6, rng))
        loads.append(0.06)
        velocities.append(FAST)
        runs.append((f"fast-r{repeat + 1}", f"prep-{repeat + 1}"))
    fits = [gf.fit(data) for data in datasets]
    amontons = gf.fit_amontons(datasets[:9], loads[:9])
    collapse = gf.velocity_collapse(datasets[3:6] + datasets[9:], velocities[3:6] + velocities[9:])
    spread = gf.preparation_spread(fits[3:6])
    comparison = gf.compare_models(datasets[0])
    time = np.linspace(0.0, 200.0, 120)
    creep_fit = gf.fit_creep(time, 0.8e-6 * np.log1p(time / 4.0) + rng.normal(0, 5e-9, time.size))

    entries = []
    for (name, preparation), result, load, velocity in zip(
        runs, fits, loads, velocities, strict=True
    ):
        entries.append(
            _run_entry(
                name,
                f"exports/{name}.csv",
                "startup",
                load,
                velocity,
                preparation,
                {**result.to_dict(), "name": name},
            )
        )
    entries.append(
        _run_entry(
            "creep-1", "exports/creep-1.csv", "creep", 0.06, None, "prep-1", creep_fit.to_dict()
        )
    )
    entries[-1]["force"] = 0.0125
    entries.append(_run_entry("ramp-1", "exports/ramp-1.csv", "ramp", 0.06, None, "prep-1"))
    entries.append(_run_entry("switch-1", "exports/switch-1.csv", "switch", 0.06, VELOCITY, "p1"))
    entries.append({**FAILED, "test": "startup", "status": "failed", "fit": None})

    joint = amontons.joint
    material = {
        name: {
            "value": joint.params[name],
            "stderr": joint.stderr[name],
            "ci95": list(joint.ci95[name]),
        }
        for name in ("mu_a", "mu_d", "alpha")
    }
    material["source"] = "amontons joint fit"
    static_yield = []
    for load in LOADS:
        peak = gf.peak(gf.Params(a=MU_A * load, alpha=ALPHA, Fd=MU_D * load, x0=0.3e-6))
        static_yield.append(
            {"normal_load": load, "F_peak": peak.force, "stderr": 4e-5, "x_peak": peak.slip}
        )
    stability = gf.stability_map(
        gf.Params(a=MU_A * 0.06, alpha=ALPHA, Fd=MU_D * 0.06, x0=0.3e-6),
        [10.0, 80.0],
        [0.99, 1.01],
        velocity=VELOCITY,
    )

    for name in ("manifest.yaml", *(f"{n}.csv" for n, _ in runs)):
        (exports / name).write_text(f"synthetic export {name}\n", encoding="utf-8")
    inputs = [
        {
            "file": f"exports/{path.name}",
            "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
        }
        for path in sorted(exports.iterdir())
    ]
    results = {
        "granflow_version": gf.__version__,
        "synthetic": True,
        "campaign": {"name": "demo campaign", "manifest": "exports/manifest.yaml"},
        "runs": entries,
        "failed_runs": [FAILED],
        "material": material,
        "analyses": {
            "velocity_collapse": collapse.to_dict(),
            "amontons": amontons.to_dict(),
            "preparation_spread": spread.to_dict(),
            "model_comparison": comparison.to_dict(),
            "creep": [{"name": "creep-1", "force": 0.0125, "fit": creep_fit.to_dict()}],
            "stress_ramp": {
                "run": "ramp-1",
                "observed": {"failure_force": 0.01652, "failure_time": 412.0},
                "predicted": {"failure_force": 0.01633, "failure_time": 408.3},
            },
            "switch": {
                "run": "switch-1",
                "observed": {"outcome": "failure", "failure_time": 3.1},
                "predicted": {"outcome": "failure", "failure_time": 2.7},
                "switch_time": 80.0,
            },
        },
        "predictions": {"static_yield": static_yield, "stability_map": stability.to_dict()},
        "warnings": ["run fast-r2: 3 points below x0 were compared with the initial force"],
        "figures": _figures(directory, fits, amontons),
        "tables": {"runs": {"csv": "tables/runs.csv", "parquet": "tables/runs.parquet"}},
        "provenance": {"inputs": inputs, "options": {"mcmc": False, "seed": seed, "window": None}},
        "timing": {
            "started": "2025-01-01T10:00:00+00:00",
            "finished": "2025-01-01T10:00:42+00:00",
            "elapsed_s": 42.0,
            "jobs": 2,
            "scheduler": None,
            "fitted_now": 12,
            "reused": 0,
        },
    }
    return json.loads(json.dumps(results))
