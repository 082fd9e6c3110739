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


def shared_data(*parts):
    """A path under shared/data; the test skips with the reason when shared/ is missing (a
    user's clone) and fails instead when the ``CI`` environment variable is set."""
    path = shared_dir().joinpath("data", *parts)
    if not path.exists():
        reason = f"{path} is missing: the shared data folder is not beside this clone"
        if os.environ.get("CI"):
            pytest.fail(reason)
        pytest.skip(reason)
    return path


# --------------------------------------------------------------------------- a small campaign

#: Material constants of the small synthetic campaign (mu_a, mu_d [-], alpha [1/m]).
SMALL_TRUTH = {"mu_a": 0.06, "mu_d": 0.2, "alpha": 5e4}
SMALL_NOISE = 3e-5  # N


def _startup_run(load, velocity, x0, rng, *, points=300):
    """A start-up at one load and velocity: Eq. 3 in slip, held at the initial force below x0,
    plus seeded Gaussian noise; sampled so that every velocity covers the same slip."""
    import numpy as np

    params = gf.Params(
        a=SMALL_TRUTH["mu_a"] * load,
        alpha=SMALL_TRUTH["alpha"],
        Fd=SMALL_TRUTH["mu_d"] * load,
        x0=x0,
    )
    dt = 300e-6 / (velocity * points)  # 300 µm of slip whatever the velocity
    t = np.arange(points) * dt
    slip = velocity * t
    clean = np.where(
        slip < x0, gf.initial_force(params), gf.friction_slip(np.maximum(slip, x0), params)
    )
    return gf.Run(
        t=t,
        slip=slip,
        velocity=np.full(points, velocity),
        force=clean + rng.normal(0.0, SMALL_NOISE, points),
        meta={"normal_load": load, "velocity": velocity, "sample": "PMMA 40 um"},
    )


def analyze_in_fresh_process(manifest, output, jobs=2):
    """Run ``analyze(manifest, output, jobs=jobs)`` in a new Python process (this checkout's
    ``src`` first on the path); returns ``(pandas loaded, matplotlib loaded)`` in that
    process's parent, the one that ran ``analyze`` and handed the work to its workers."""
    import subprocess
    import sys

    source = Path(__file__).resolve().parents[1] / "src"
    code = (
        "import sys\n"
        "from granflow.analysis import analyze\n"
        f"analyze({str(manifest)!r}, {str(output)!r}, jobs={jobs}, quiet=True)\n"
        "print('pandas' in sys.modules, 'matplotlib' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, "PYTHONPATH": str(source)},
        capture_output=True,
        text=True,
        check=True,
    )
    return tuple(word == "True" for word in out.stdout.split())


def write_small_campaign(folder, seed=0):
    """Write a small campaign of instrument exports and its manifest; returns the manifest.

    Start-ups at three loads (30, 60, 90 mN) with three repeats each at 0.86 µm/s (one
    RheoCompass file per load, the repeats as intervals), two more velocities at 60 mN (TRIOS
    files), a quasi-static stress ramp, a creep test and a switch after the peak (simulated).
    """
    import numpy as np
    import yaml

    from granflow.io import write_rheocompass, write_trios

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    entries = []
    for number, load in enumerate((0.03, 0.06, 0.09)):
        runs = [_startup_run(load, 0.86e-6, x0, rng) for x0 in (2.2e-7, 3.0e-7, 3.8e-7)]
        name = f"startup_{round(load * 1e3)}mN.txt"
        language = ("en", "fr", "de")[number]
        write_rheocompass(folder / name, runs, language=language, decimal="," if number else ".")
        for interval in (1, 2, 3):
            entries.append(
                {"file": name, "interval": interval, "normal_load": f"{round(load * 1e3)} mN"}
            )
    for velocity in (2e-6, 4e-6):
        run = _startup_run(0.06, velocity, 3.0e-7 * velocity / 0.86e-6, rng)
        name = f"velocity_{round(velocity * 1e6)}um_s.txt"
        write_trios(folder / name, run)
        entries.append({"file": name, "normal_load": "60 mN", "velocity": f"{velocity} m/s"})
    params = gf.Params(
        SMALL_TRUTH["mu_a"] * 0.06, SMALL_TRUTH["alpha"], SMALL_TRUTH["mu_d"] * 0.06, 3.0e-7
    )
    simulated = {
        "ramp.txt": ([gf.ForceRamp(rate=0.1e-3, duration=400.0)], {}, "ramp"),
        "creep.txt": (
            [gf.Force(level=0.9 * gf.peak(params).force, duration=300.0)],
            {"direct_effect": 0.2e-3},
            "creep",
        ),
        "switch.txt": (
            [gf.Velocity(0.86e-6, 80.0), gf.SwitchToForce(60.0, factor=1.01)],
            {},
            "switch",
        ),
    }
    for name, (segments, options, test) in simulated.items():
        run = gf.simulate(params, segments, **options).to_run()
        meta = {"normal_load": 0.06, "sample": "PMMA 40 um"}
        if test == "switch":
            meta["velocity"] = 0.86e-6
        run = gf.Run(run.t, run.slip, run.velocity, run.force, control=run.control, meta=meta)
        write_rheocompass(folder / name, run, encoding="utf-8")
        entries.append({"file": name, "normal_load": "60 mN", "test": test})
    manifest = folder / "manifest.yaml"
    document = {"defaults": {"preparation": "sieved", "notes": "synthetic"}, "runs": entries}
    manifest.write_text(yaml.safe_dump(document, sort_keys=False), encoding="utf-8")
    return manifest
