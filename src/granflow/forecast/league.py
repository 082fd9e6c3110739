"""The forecast league: every method on every family of records, at each lead, scored as
forecasts are scored (:func:`granflow.forecast.score`).

The methods (:data:`METHODS`): granflow's ``forecast_failure`` and the field's references
of :mod:`granflow.forecast.references` (the inverse-velocity method, the failure forecast
method with its exponent fitted by maximum likelihood, the current rate extrapolated). The
records: :func:`granflow.forecast.families.family_record`, each cut at leads of 50, 25 and
10 % of its time to failure (the cut ``(1 - lead) t_f``).

``benchmarks/bench_forecast.py league`` runs it at scale and draws the figures; the test
suite runs it on a few records a cell.
"""

from __future__ import annotations

import math
import time as clock
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from granflow.forecast.families import FAMILIES, Record, family_record

__all__ = ["LEADS", "METHODS", "Entry", "league", "one_record", "table"]

LEADS = (0.5, 0.25, 0.1)
METHODS = ("granflow", "inverse velocity", "ffm", "current rate")


@dataclass(frozen=True)
class Entry:
    """One method's forecast of one record at one lead, kept light (what scoring reads).

    Attributes
    ----------
    family, seed, lead, method : str, int, float, str
        Which record, cut where, by whom.
    until : float
        The cut [s].
    truth : float
        The true failure time [s].
    level : float
        The interval's level [-].
    time_interval : tuple
        The forecast's interval [s].
    cdf : dict
        The forecast's table of its failure time's CDF.
    declined : bool
        Whether the forecast declined (the record does not follow its model).
    time : float or None
        Its point forecast [s].
    cpu : float
        CPU time of the forecast [s].
    message : str
        The forecast's message (or the error it raised).
    would_cover : bool or None
        Where the forecast declined: whether the interval it would have given
        (:func:`~granflow.forecast.discrepancy.unreviewed`) held the truth; None otherwise.
    """

    family: str
    seed: int
    lead: float
    method: str
    until: float
    truth: float
    level: float
    time_interval: tuple
    cdf: dict = field(repr=False)
    declined: bool = False
    time: float | None = None
    cpu: float = 0.0
    message: str = ""
    would_cover: bool | None = None


def _granflow(record, until):
    from granflow.forecast.failure import forecast_failure

    return forecast_failure(record.t, record.slip, record.force, until=until)


def _would_cover(record, until):
    """Whether granflow's forecast, not declined, would have held the truth."""
    from granflow.forecast.discrepancy import unreviewed

    with unreviewed():
        low, high = _granflow(record, until).time_interval
    return bool(low <= record.failure <= high)


def _reference(name):
    from granflow.forecast import references

    function = {
        "inverse velocity": references.fukuzono_forecast,
        "ffm": references.ffm_forecast,
        "current rate": references.current_rate_forecast,
    }[name]

    def run(record, until):
        return function(record.t, record.slip, until=until)

    return run


def _method(name):
    if callable(name):
        return name
    if name == "granflow":
        return _granflow
    return _reference(name)


def one_record(
    record: Record,
    leads: Sequence[float] = LEADS,
    methods: Sequence[str | Callable] = METHODS,
    names: Sequence[str] | None = None,
) -> list[Entry]:
    """Every method's :class:`Entry` for one record at each lead. A method is a name of
    :data:`METHODS` or a callable ``(record, until) -> forecast`` (named by ``names``); a
    forecast that raises is an entry with an empty distribution and the error as its
    message (scored as uninformative)."""
    names = list(names or [m if isinstance(m, str) else m.__name__ for m in methods])
    out = []
    for lead in leads:
        until = (1.0 - lead) * record.failure
        for name, method in zip(names, methods, strict=True):
            started = clock.process_time()
            try:
                forecast = _method(method)(record, until)
            except Exception as exc:  # a failed forecast is an outcome, not the league's end
                forecast = None
                message = f"error: {type(exc).__name__}: {exc}"
            cpu = clock.process_time() - started
            if forecast is None:
                out.append(
                    Entry(record.family, record.seed, lead, name, until, record.failure, 0.9,
                          (math.nan, math.nan), {"time": [], "probability": []}, False, None,
                          cpu, message)
                )  # fmt: skip
                continue
            declined = bool(getattr(forecast, "declined", False))
            would = _would_cover(record, until) if declined and method == "granflow" else None
            out.append(
                Entry(
                    record.family,
                    record.seed,
                    lead,
                    name,
                    float(forecast.until),
                    record.failure,
                    float(forecast.level),
                    tuple(float(v) for v in forecast.time_interval),
                    dict(forecast.cdf),
                    declined,
                    forecast.time,
                    cpu,
                    forecast.message,
                    would,
                )
            )
    return out


def _one(arguments):
    seed, family, leads, methods = arguments
    return one_record(family_record(seed, family), leads, methods)


def league(
    seeds: Iterable[int],
    families: Sequence[str] = FAMILIES,
    leads: Sequence[float] = LEADS,
    methods: Sequence[str] = METHODS,
    executor: Any = None,
) -> list[Entry]:
    """The :class:`Entry` s of every method on each seed's record of every family, at every
    lead (a process pool's ``map`` when ``executor`` is given)."""
    mapper = map if executor is None else executor.map
    work = [(seed, family, tuple(leads), tuple(methods)) for family in families for seed in seeds]
    options = {} if executor is None else {"chunksize": max(1, min(8, len(work) // 64))}
    return [entry for rows in mapper(_one, work, **options) for entry in rows]


def table(entries: Sequence[Entry], **options: Any) -> dict:
    """``{(family, lead, method): Scores}`` of the entries (keyword ``options`` go to
    :func:`~granflow.forecast.score`), each cell's records in seed order (so that two
    methods' cells pair record by record)."""
    from granflow.forecast.scoring import score

    cells: dict = {}
    for entry in sorted(entries, key=lambda e: (e.family, e.lead, e.method, e.seed)):
        cells.setdefault((entry.family, entry.lead, entry.method), []).append(entry)
    return {key: score(rows, [row.truth for row in rows], **options) for key, rows in cells.items()}
