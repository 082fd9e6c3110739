"""The one codec (:mod:`granflow._codec`): ``to_dict``/``from_dict`` derived from a frozen
dataclass's fields, and the one equality by value.

Every result converted to it keeps the JSON it wrote by hand before: its keys, in their
order, are written here as literals (taken from the hand-written ``to_dict`` each replaced),
and each round-trips through JSON text to an equal result.
"""

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pytest

import granflow as gf
from granflow._codec import Codec, FrozenMap, ValueEquality, from_fields, same, to_fields
from granflow.analysis.forecasts import ForecastCut
from granflow.analysis.joint_results import Estimate, FitJudgement, GoodnessOfFit
from granflow.analysis.run_results import (
    CreepResult,
    ObservedPeak,
    RampFailure,
    StartupWindow,
    SwitchEvent,
)
from granflow.errors import InvalidParameterError
from granflow.fitting.amontons_test import RelationTest
from granflow.forecast.loading import fit_loading
from granflow.forecast.results import BaselineForecast, FailureForecast, PeakForecast
from granflow.simulation.events import Event, Origin, SegmentRecord

_CDF = {"time": [1.0, 2.0], "probability": [0.2, 0.9]}


@pytest.fixture(scope="module")
def creep_fit():
    t = np.linspace(0.1, 100.0, 40)
    slip = 2e-6 * np.log1p(t / 3.0) + np.random.default_rng(1).normal(0.0, 1e-9, t.size)
    return gf.fit_creep(t, slip)


def _samples(creep_fit):
    """Two or so of each converted type, with NaN, None and infinities where they may be."""
    t = np.linspace(0.0, 100.0, 21)
    loading = fit_loading(t, 1e-3 + 2e-4 * t)
    params = FrozenMap({"a": 1e-3, "alpha": 2e4, "Fd": 1e-2, "x0": 1e-5})
    return {
        StartupWindow: [
            StartupWindow("slip", 3, 1e-6, 2e-4, 120, 2),
            StartupWindow("x", 0, 0.0, 1.0, 5),
        ],
        ObservedPeak: [ObservedPeak(0.011, 3.2e-5), ObservedPeak(math.nan, 1.0)],
        CreepResult: [CreepResult(creep_fit, 0.01, 5.0, 2e-6, 95.0, ("slow",))],
        RampFailure: [RampFailure("velocity", 12, 3.5, None, 0.02, 3.6)],
        SwitchEvent: [SwitchEvent(80.0, "manifest", 40, 8.6e-7, 0.0, 0.0101, None, 60.0, "creep")],
        Estimate: [Estimate(0.3, 0.01, (0.28, 0.32)), Estimate()],
        FitJudgement: [FitJudgement(1e-5, 1.2), FitJudgement(math.nan, 0.9)],
        GoodnessOfFit: [
            GoodnessOfFit(
                FrozenMap({"r1": FitJudgement(1e-5, 1.2), "r2": FitJudgement(math.nan, 3.0)}),
                1.2,
                1.2,
                3.0,
                2.0,
                ("r2",),
                "plateau",
            )
        ],
        ForecastCut: [
            ForecastCut(100.0, 150.0, (140.0, math.inf), 0.02, (0.019, 0.021), "m"),
            ForecastCut(50.0, None),
        ],
        RelationTest: [
            RelationTest("a ∝ F_N", 0.3, 1.5, 2, 0.47),
            RelationTest("x", math.nan, math.inf, 0, 1.0),
        ],
        Event: [
            Event("failure", 12.0, 3e-5, 0.01, 0.011, 2, "runaway"),
            Event("peak", math.nan, 1.0, 0.01, 0.011, 0),
        ],
        Origin: [Origin("shear", 0.0, 1.2, 0.0), Origin("rest", None, 0.0, 1e-5)],
        SegmentRecord: [
            SegmentRecord(0, "velocity", "rate", 0.0, 80.0, 0.0, 6.9e-5, 0.0, 0.011, "completed")
        ],
        PeakForecast: [
            PeakForecast(
                0.012,
                (0.011, 0.013),
                3e-5,
                (2e-5, 4e-5),
                35.0,
                (30.0, math.inf),
                8.6e-7,
                20.0,
                0.9,
                params,
                1e-5,
                200,
                {"Fd": [0.01, 0.001]},
                "",
                cdf=_CDF,
            )
        ],
        FailureForecast: [
            FailureForecast(
                120.0,
                (110.0, 130.0),
                0.025,
                (0.024, 0.026),
                4e-5,
                (3e-5, math.inf),
                90.0,
                0.9,
                loading,
                params,
                1e-9,
                300,
                True,
                steps=None,
                cdf=_CDF,
            ),
            FailureForecast(
                None,
                (math.nan, math.nan),
                None,
                (math.nan, math.nan),
                None,
                (math.nan, math.nan),
                90.0,
                0.9,
                loading,
                FrozenMap(),
                math.nan,
                3,
                False,
                message="no date",
            ),
        ],
        BaselineForecast: [
            BaselineForecast("voight", 130.0, (120.0, 150.0), 90.0, 0.9, 1.8, 40, True)
        ],
    }


#: The keys each type's hand-written ``to_dict`` wrote, in order (without ``nonfinite``).
KEYS = {
    StartupWindow: ["abscissa", "elastic_points", "start", "stop", "points", "non_finite"],
    ObservedPeak: ["force", "slip"],
    CreepResult: [
        "fit", "stress", "creep_start", "creep_slip", "duration", "warnings", "status", "reason",
    ],
    RampFailure: ["criterion", "index", "time", "slip", "force", "runaway_time"],
    SwitchEvent: [
        "switch_time", "found_by", "index", "velocity", "switch_force", "imposed_force",
        "factor", "hold_time", "outcome",
    ],
    Estimate: ["value", "stderr", "ci95"],
    FitJudgement: ["noise", "chi2"],
    GoodnessOfFit: ["runs", "median", "min", "max", "limit", "poor", "method"],
    ForecastCut: ["cut", "time", "time_interval", "force", "force_interval", "message"],
    RelationTest: ["name", "mean", "statistic", "df", "p_value"],
    Event: ["kind", "time", "slip", "force", "state", "segment", "message"],
    Origin: ["kind", "shear_start", "model_start", "slip_offset"],
    SegmentRecord: [
        "index", "kind", "control", "start_time", "end_time", "start_slip", "end_slip",
        "start_force", "end_force", "outcome",
    ],
    PeakForecast: [
        "force", "force_interval", "slip", "slip_interval", "time", "time_interval",
        "velocity", "until", "level", "params", "sigma", "n_points", "prior", "message",
        "clock", "cdf",
    ],
    FailureForecast: [
        "time", "time_interval", "force", "force_interval", "slip", "slip_interval", "until",
        "level", "loading", "params", "sigma", "n_points", "approaching", "prior", "message",
        "method", "clock", "steps", "cdf", "observed_failure", "observed", "declined",
    ],
    BaselineForecast: [
        "method", "time", "time_interval", "until", "level", "exponent", "n_points",
        "approaching", "message", "cdf",
    ],
}  # fmt: skip


@pytest.mark.parametrize("cls", list(KEYS), ids=lambda cls: cls.__name__)
def test_each_converted_result_keeps_its_json_and_round_trips(cls, creep_fit):
    assert "to_dict" not in vars(cls) and issubclass(cls, Codec)  # derived, not hand-written
    for result in _samples(creep_fit)[cls]:
        written = result.to_dict()
        assert [key for key in written if key != "nonfinite"] == KEYS[cls]
        text = json.dumps(written, allow_nan=False)  # JSON-safe: no NaN, no Infinity
        back = cls.from_dict(json.loads(text))
        assert type(back) is cls
        assert back == result
        assert back.to_dict() == written


def test_the_creep_result_keeps_its_fit_compact_unless_asked(creep_fit):
    result = _samples(creep_fit)[CreepResult][0]
    assert "x" not in result.to_dict()["fit"]  # the analysis's default: the compact form
    assert len(result.to_dict(include_arrays=True)["fit"]["x"]) == 40
    back = CreepResult.from_dict(result.to_dict())
    assert back.fit.x.size == 0 and back.fit.params == result.fit.params


# --------------------------------------------------------------------------- the codec itself


@dataclass(frozen=True, eq=False)
class _Inner(Codec):
    value: float
    label: str | None = None


@dataclass(frozen=True, eq=False)
class _Outer(Codec):
    inner: _Inner
    maybe: _Inner | None
    count: int
    flag: bool
    pair: tuple[float, float]
    words: tuple[str, ...]
    by_name: Mapping[str, _Inner]
    loose: FrozenMap
    x: np.ndarray
    y: np.ndarray
    optional: float | None = None

    ARRAYS = ("x",)


def _outer():
    return _Outer(
        inner=_Inner(math.inf, "up"),
        maybe=None,
        count=3,
        flag=True,
        pair=(math.nan, -math.inf),
        words=("a", "b"),
        by_name=FrozenMap({"k": _Inner(2.5)}),
        loose=FrozenMap({"note": None}),
        x=np.array([1.0, math.nan, 3.0]),
        y=np.array([math.inf, 0.0]),
    )


def test_the_codec_writes_each_field_by_its_type():
    written = _outer().to_dict()
    assert list(written) == [
        "inner", "maybe", "count", "flag", "pair", "words", "by_name", "loose", "x", "y",
        "optional", "nonfinite",
    ]  # fmt: skip
    assert written["inner"] == {"value": None, "label": "up", "nonfinite": [[["value"], "inf"]]}
    assert written["pair"] == [None, None]
    assert written["x"] == [1.0, None, 3.0]
    assert written["nonfinite"] == [[["pair", 1], "-inf"], [["y", 0], "inf"]]
    assert "x" not in _outer().to_dict(include_arrays=False)


def test_the_codec_reads_each_field_back_by_its_type():
    original = _outer()
    back = _Outer.from_dict(json.loads(json.dumps(original.to_dict(), allow_nan=False)))
    assert back == original
    assert back.inner.value == math.inf and back.maybe is None and back.optional is None
    assert math.isnan(back.pair[0]) and back.pair[1] == -math.inf
    assert isinstance(back.words, tuple) and isinstance(back.by_name, FrozenMap)
    assert type(back.by_name["k"]) is _Inner and type(back.count) is int
    assert back.loose == {"note": None}
    assert not back.x.flags.writeable
    compact = _Outer.from_dict(original.to_dict(include_arrays=False))
    assert compact.x.size == 0 and compact.y.size == 2  # only ARRAYS are left out


def test_the_codec_names_a_missing_field():
    written = _outer().to_dict()
    del written["count"]
    missing = r"_Outer\.from_dict: the mapping has no 'count'"
    with pytest.raises(InvalidParameterError, match=missing):
        _Outer.from_dict(written)
    with pytest.raises(InvalidParameterError, match="needs a mapping"):
        _Outer.from_dict([1, 2])


def test_the_codec_adds_constant_keys_and_may_write_infinities_as_null():
    @dataclass(frozen=True, eq=False)
    class Done(Codec):
        level: float
        JSON_EXTRA = {"status": "ok"}  # noqa: RUF012
        KEEP_INFINITIES = False

    assert Done(math.inf).to_dict() == {"level": None, "status": "ok"}
    assert to_fields(Done(1.0)) == {"level": 1.0, "status": "ok"}
    assert math.isnan(from_fields(Done, {"level": None, "status": "ok"}).level)


def test_one_equality_by_value():
    assert same(np.array([1.0, math.nan]), np.array([1.0, math.nan]))
    assert not same(np.array([1.0]), np.array([1.0, 1.0]))
    assert _Inner(math.nan) == _Inner(math.nan)
    assert _Inner(1.0) != _Inner(1.0, "other")
    assert _Inner(1.0) != 1.0
    with pytest.raises(TypeError):
        hash(_Inner(1.0))

    @dataclass(frozen=True, eq=False)
    class ByJson(ValueEquality):
        value: float
        EQUAL_BY_JSON = True

        def to_dict(self):
            return {"value": round(self.value, 3)}

    assert ByJson(1.0001) == ByJson(1.0002)  # equal where their JSON is
    assert ByJson(1.0) != ByJson(1.1)
