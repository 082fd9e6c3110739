"""The test of Amontons' law over normal loads: a ∝ F_N, F_d ∝ F_N and α independent of F_N.

:func:`amontons_test` tests each relation on the per-load means of the repeats' separate fits
(:attr:`granflow.AmontonsResult.per_load`) and combines the three into one verdict; the
result, :class:`AmontonsTest`, is the ``test`` field of :class:`granflow.AmontonsResult`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from granflow.fitting.results import Codec, ValueEquality, number

__all__ = ["AmontonsTest", "RelationTest", "amontons_test"]

#: The relations tested: (name, key of the per-load row, divided by the load).
RELATIONS = (
    ("a ∝ F_N", "a", True),
    ("F_d ∝ F_N", "Fd", True),
    ("α independent of F_N", "alpha", False),
)
#: The level below which a p-value rejects a relation.
LEVEL = 0.05


@dataclass(frozen=True, eq=False)
class RelationTest(Codec):
    """One relation of Amontons' law tested on the per-load means.

    Attributes
    ----------
    name : str
        ``"a ∝ F_N"``, ``"F_d ∝ F_N"`` or ``"α independent of F_N"``.
    mean : float
        The weighted mean of the per-load ratios: μ_a or μ_d [-], or α [1/m].
    statistic : float
        χ² of the per-load ratios about that mean [-].
    df : int
        Its degrees of freedom (loads − 1).
    p_value : float
        Probability of a χ² at least as large if the relation holds.
    """

    name: str
    mean: float
    statistic: float
    df: int
    p_value: float


@dataclass(frozen=True, eq=False)
class AmontonsTest(ValueEquality):
    """Amontons' law tested over the loads: its three relations and one verdict.

    The three relations rest on the same fits, so they are not independent; they are
    combined by Bonferroni's rule, which holds whatever their correlation: the law is
    rejected at level ``LEVEL`` when the smallest p-value times the number of relations is
    below it.

    Attributes
    ----------
    statistic : float
        χ² of the relation furthest from holding (the smallest p-value) [-].
    df : int
        Its degrees of freedom.
    p_value : float
        That relation's p-value times the number of relations, at most 1 (Bonferroni).
    relations : tuple of RelationTest
        Each relation's own test, in the order a, F_d, α.
    loads : int
        Loads tested.
    """

    statistic: float
    df: int
    p_value: float
    relations: tuple[RelationTest, ...]
    loads: int

    @property
    def holds(self) -> bool:
        """Whether the law is not rejected at the 5 % level."""
        return self.p_value >= LEVEL

    def __repr__(self) -> str:
        return (
            f"AmontonsTest({self.loads} loads, statistic={self.statistic:.3g}, df={self.df}, "
            f"p_value={self.p_value:.2g}, holds={self.holds})"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe mapping (``holds`` included for readers of ``results.json``)."""
        return {
            "statistic": self.statistic,
            "df": self.df,
            "p_value": self.p_value,
            "holds": self.holds,
            "loads": self.loads,
            "relations": [relation.to_dict() for relation in self.relations],
        }

    @classmethod
    def from_dict(cls, saved: Mapping[str, Any]) -> AmontonsTest:
        """The test of :meth:`to_dict`."""
        return cls(
            statistic=number(saved["statistic"]),
            df=int(saved["df"]),
            p_value=number(saved["p_value"]),
            relations=tuple(RelationTest.from_dict(r) for r in saved["relations"]),
            loads=int(saved["loads"]),
        )


def _normal_deviate(t_value: float, df: int | None) -> float:
    """A Student's t deviate with ``df`` degrees of freedom as the normal deviate of the same
    tail probability (a few repeats make their standard error uncertain)."""
    from scipy.stats import norm, t

    if df is None or df < 1:
        return float(t_value)
    return float(norm.isf(t.sf(t_value, df)))


def _relation(
    name: str, key: str, per_load_of: bool, rows: Sequence[Mapping[str, Any]]
) -> RelationTest | None:
    values, errors, repeats = [], [], []
    for row in rows:
        pair, load = row.get(key), row.get("normal_load")
        if pair is None or load is None or not load > 0:
            continue
        value, error = float(pair[0]), float(pair[1])
        if not (math.isfinite(value) and math.isfinite(error) and error > 0):
            continue
        divisor = load if per_load_of else 1.0
        values.append(value / divisor)
        errors.append(error / divisor)
        count = row.get("repeats")
        repeats.append(int(count) if isinstance(count, int) and count > 1 else None)
    if len(values) < 3:
        return None
    from scipy.stats import chi2

    weights = [1.0 / e**2 for e in errors]
    mean = sum(w * v for w, v in zip(weights, values, strict=True)) / sum(weights)
    statistic = sum(
        _normal_deviate((v - mean) / e, None if n is None else n - 1) ** 2
        for v, e, n in zip(values, errors, repeats, strict=True)
    )
    df = len(values) - 1
    return RelationTest(name, mean, statistic, df, float(chi2.sf(statistic, df)))


def amontons_test(per_load: Sequence[Mapping[str, Any]]) -> AmontonsTest | None:
    """Amontons' law tested on the per-load means: a/F_N, F_d/F_N and α each constant.

    For each relation, the per-load values r_i (standard errors s_i from n_i repeats) are
    compared with their weighted mean r̄: t_i = (r_i − r̄)/s_i is turned into the normal
    deviate z_i of the same Student's-t tail probability (n_i − 1 degrees of freedom), and
    χ² = Σ z_i² has (loads − 1) degrees of freedom. The three relations are combined by
    Bonferroni's rule (see :class:`AmontonsTest`).

    Parameters
    ----------
    per_load : sequence of mapping
        Rows of :attr:`granflow.AmontonsResult.per_load`: ``normal_load`` [N], ``repeats``,
        and (mean, standard error) of ``a`` [N], ``Fd`` [N] and ``alpha`` [1/m].

    Returns
    -------
    AmontonsTest or None
        None with fewer than three loads whose means have a standard error.

    Examples
    --------
    >>> rows = [{"normal_load": F, "repeats": 8, "a": (0.06 * F, 1e-5), "Fd": (0.2 * F, 1e-5),
    ...          "alpha": (5e4, 100.0)} for F in (0.02, 0.05, 0.1)]
    >>> amontons_test(rows).holds
    True
    """
    relations = []
    for name, key, per_load_of in RELATIONS:
        relation = _relation(name, key, per_load_of, per_load)
        if relation is None:
            return None
        relations.append(relation)
    worst = min(relations, key=lambda relation: relation.p_value)
    return AmontonsTest(
        statistic=worst.statistic,
        df=worst.df,
        p_value=min(1.0, len(relations) * worst.p_value),
        relations=tuple(relations),
        loads=len(per_load),
    )
