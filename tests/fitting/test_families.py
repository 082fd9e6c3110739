"""The seam between the generic machinery and the model families (:mod:`granflow.families`).

A fit read back from JSON is sampled like the fit itself (the likelihood is rebuilt from the
result, checked against the residuals the fit stored); a family module planted in the
package is found without editing any generic module; the generic modules name no family.
"""

import json
import re
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

import granflow
from granflow import ConvergenceWarning, families
from granflow.fitting.compare import ModelComparison

SOURCE = Path(__file__).resolve().parents[2] / "src" / "granflow"
GENERIC = ("fitting/compare.py", "fitting/mcmc.py", "analysis/engine.py", "analysis/report*.py")


@pytest.fixture(scope="module")
def eq3_fit():
    p = granflow.Params(a=3.1e-3, alpha=5e4, Fd=10e-3, x0=2.5e-7)
    x = np.linspace(p.x0, 4e-4, 300)
    y = granflow.friction_slip(x, p) + np.random.default_rng(5).normal(0, 5e-5, x.size)
    return granflow.fit((x, y), profile=False)


@pytest.fixture(scope="module")
def creep_fit():
    t = np.linspace(0.0, 300.0, 200)
    slip = 2e-6 * np.log1p(t / 5.0) + np.random.default_rng(6).normal(0, 2e-8, t.size)
    return granflow.fit_creep(t, slip)


def _short_chain(result, seed=4):
    emcee = pytest.importorskip("emcee")
    assert emcee
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        return granflow.sample_posterior(result, nwalkers=12, nsteps=30, seed=seed, progress=False)


@pytest.mark.parametrize("name", ["eq3_fit", "creep_fit"])
def test_a_fit_read_back_from_json_is_sampled_like_the_fit(name, request):
    fit = request.getfixturevalue(name)
    copy = type(fit).from_dict(json.loads(json.dumps(fit.to_dict())))
    assert copy == fit
    first, again = _short_chain(fit), _short_chain(copy)
    assert again.names == first.names
    np.testing.assert_array_equal(again.chain, first.chain)


@pytest.mark.parametrize("name", ["eq3_fit", "creep_fit"])
def test_the_rebuilt_likelihood_is_the_stored_residuals(name, request):
    """At the fitted values the log-likelihood is -chi2 / (2 redchi), chi2 summed here from
    the residuals the fit stored (not from the model the likelihood evaluates)."""
    fit = request.getfixturevalue(name)
    likelihood = type(fit).from_dict(fit.to_dict()).log_likelihood()
    assert set(likelihood.names) == {n for n in fit.names if n not in fit.fixed}
    chisqr = float(np.sum(np.asarray(fit.residuals) ** 2))
    natural = np.array([fit.params[n] for n in likelihood.names])
    assert likelihood(natural) == pytest.approx(-0.5 * chisqr / fit.redchi, rel=1e-9)
    assert likelihood(natural * 1.01) < likelihood(natural)  # the fit is a maximum


def test_a_compact_result_cannot_be_sampled_and_says_why(creep_fit):
    compact = type(creep_fit).from_dict(creep_fit.to_dict(include_arrays=False))
    with pytest.raises(granflow.InvalidParameterError, match="include_arrays=True"):
        compact.log_likelihood()


def test_every_fit_result_follows_the_protocol_and_names_its_family(eq3_fit, creep_fit):
    for fit, family in ((eq3_fit, "eq3"), (creep_fit, "creep")):
        assert isinstance(fit, families.FamilyFit)
        assert fit.to_dict()["family"] == family == families.family_of(fit)
        assert families.result_type(family) is type(fit)
        row = fit.comparison_row()
        assert {"model", "formula", "nfree", "chisqr", "aic", "bic", "success", "message"} <= set(
            row
        )
    assert not isinstance(object(), families.FamilyFit)
    with pytest.raises(granflow.InvalidParameterError, match="fit result of a model family"):
        granflow.sample_posterior(object())


def test_a_comparison_reads_each_fit_back_through_the_families(eq3_fit):
    comparison = granflow.compare_models((eq3_fit.x, eq3_fit.data))
    saved = json.loads(json.dumps(comparison.to_dict()))
    back = ModelComparison.from_dict(saved)
    assert back == comparison
    assert {type(f).__name__ for f in back.fits.values()} == {"FitResult", "CurveFitResult"}
    for fit in saved["fits"].values():  # written before fits stored their family
        fit.pop("family")
    assert ModelComparison.from_dict(saved) == comparison


PLANTED = '''
"""A family planted by a test."""
import math
from dataclasses import dataclass

from granflow.families import Family, Likelihood

FAMILY = Family(
    name="planted",
    description="a constant with unit noise",
    result_types=("granflow.families.planted_family:PlantedFit",),
    models=("planted",),
)


@dataclass(frozen=True)
class PlantedFit:
    mean: float

    def log_likelihood(self):
        return Likelihood(
            names=("mean",),
            values={"mean": self.mean},
            stderr={"mean": 0.1},
            priors={"mean": ("uniform", self.mean - 5.0, self.mean + 5.0)},
            function=lambda natural: -0.5 * float((natural[0] - self.mean) / 0.1) ** 2,
        )

    def comparison_row(self):
        return {"model": "planted", "formula": "mu", "nfree": 1, "chisqr": 1.0,
                "aic": 2.0, "bic": 2.0, "success": True, "message": ""}

    def plot(self, ax=None):
        return ax

    def to_dict(self, include_arrays=True):
        return {"family": "planted", "mean": self.mean}

    @classmethod
    def from_dict(cls, d):
        return cls(mean=d["mean"])
'''


@pytest.fixture
def planted(tmp_path, monkeypatch):
    """A module ``planted_family`` in a folder added to the package's search path only."""
    (tmp_path / "planted_family.py").write_text(textwrap.dedent(PLANTED), encoding="utf-8")
    monkeypatch.setattr(families, "__path__", [*families.__path__, str(tmp_path)])
    yield "granflow.families.planted_family"
    sys.modules.pop("granflow.families.planted_family", None)


def test_a_planted_family_module_is_found_and_used(planted):
    assert "planted" in {f.name for f in families.families()}
    kind = families.result_type("planted")
    assert kind.__module__ == planted
    fit = kind(mean=2.0)
    assert families.family_of(fit) == "planted"
    comparison = ModelComparison.from_dict(
        {"rows": [fit.comparison_row()], "best_aic": "planted", "best_bic": "planted",
         "fits": {"planted": fit.to_dict()}}
    )  # fmt: skip
    assert comparison.fits["planted"] == fit
    posterior = _short_chain(fit)
    assert posterior.names == ("mean",)
    assert abs(posterior.medians["mean"] - 2.0) < 0.3


def test_the_generic_modules_name_no_family():
    found = []
    for pattern in GENERIC:
        for path in sorted(SOURCE.glob(pattern)):
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if re.search(r"RateState|rsf|rate_state", line):
                    found.append(f"{path.relative_to(SOURCE)}:{number}: {line.strip()}")
    assert found == []


PLANTED_RECORDS = '''
"""A record family planted by a test: one record, analysed to a count."""
from granflow.families import Family

FAMILY = Family(
    name="planted_records",
    description="records counted",
    result_types=(),
    test_kind="planted_kind",
    entries="granflow.families.planted_records:entries",
    analyse="granflow.families.planted_records:analyse",
    results="granflow.families.planted_records:Counted",
)


def entries(manifest, allow_outside):
    return [{"file": "one.txt"}]


def analyse(manifest, output, figures_dir, allow_outside):
    return {"records": [{"name": "one.txt", "figure": None}], "failed": []}


class Counted:
    def __init__(self, records=(), failed=()):
        self.records, self.failed = tuple(records), tuple(failed)

    def __bool__(self):
        return bool(self.records or self.failed)

    @classmethod
    def from_dict(cls, saved):
        saved = saved or {}
        return cls(saved.get("records", ()), saved.get("failed", ()))

    def to_dict(self):
        return {"records": list(self.records), "failed": list(self.failed)} if self else {}
'''


class _InProcess:
    """An executor that runs each task here."""

    def call(self, function, task):
        return function(task)

    def recycle(self):
        pass


class _Quiet:
    def stage(self, name):
        self.last = name


def test_a_planted_record_family_is_analysed_by_the_campaign_stage(tmp_path, monkeypatch):
    from granflow.analysis.record_stage import analyse_records
    from granflow.analysis.result import record_analyses
    from granflow.io.manifest import RECORD_KINDS

    (tmp_path / "planted_records.py").write_text(textwrap.dedent(PLANTED_RECORDS), "utf-8")
    monkeypatch.setattr(families, "__path__", [*families.__path__, str(tmp_path)])
    try:
        assert "planted_kind" in {f.test_kind for f in families.record_families()}
        stages = {}
        analysed = analyse_records(None, tmp_path, False, _InProcess(), _Quiet(), stages)
        assert analysed["files"] and ["one.txt"] in analysed["files"]
        assert analysed["planted_kind"]["records"][0]["name"] == "one.txt"
        assert "planted_kind_s" in stages
        parts = record_analyses(analysed)
        assert type(parts["planted_kind"]).__name__ == "Counted"
        assert "velocity_steps" in RECORD_KINDS  # the manifest's kinds are the families'
    finally:
        sys.modules.pop("granflow.families.planted_records", None)
