"""Model comparison on one curve: Eq. 3 against pure logarithmic aging and a single exponential.

Each model is fitted by least squares to the same points; the table ranks them by AIC and
BIC (lmfit's definitions, ``n ln(chi2/n) + 2 k`` and ``n ln(chi2/n) + k ln n``). A model that
cannot be fitted (Eq. 3 on a curve without overshoot) stays in the table with its reason.

Other model families add their rows through :mod:`granflow.families` (a family's
``compare`` hooks): on a record with a load-point protocol, the family whose ``"record"``
hook takes it; on a start-up curve with ``rate_and_state=True``, every ``"startup"`` hook.
Each fit's row is its own ``comparison_row()``, and a comparison read back finds each fit's
class from the ``"family"`` its ``to_dict`` stored.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import families
from granflow.errors import GranflowError, InvalidParameterError
from granflow.fitting.creep import fit_curve
from granflow.fitting.curves import prepare
from granflow.fitting.engine import Model
from granflow.fitting.results import FrozenMap, ValueEquality, decode, encode
from granflow.fitting.single import FORMULA, fit
from granflow.model.units import si_unit

if TYPE_CHECKING:
    import pandas as pd

    from granflow._typing import ArrayLike
    from granflow.model.run import Run

__all__ = ["ModelComparison", "compare_models"]

MODELS = ("eq3", "log_aging", "exponential")
_FORMULAS = {
    "eq3": FORMULA,
    "log_aging": "F = F1 + a ln(x / x1), x1 the first point (alpha -> 0)",
    "exponential": "F = Fd + (F_init - Fd) e^(-alpha x)",
}


@dataclass(frozen=True, eq=False)
class ModelComparison(ValueEquality):
    """An AIC/BIC table of the models fitted to one curve.

    Attributes
    ----------
    rows : tuple of dict
        Per model: ``model``, ``formula``, ``nfree``, ``chisqr``, ``aic``, ``bic``,
        ``delta_aic``, ``delta_bic`` (from the best), ``success``, ``message``.
    fits : mapping
        The fit result of each model (None where it could not be fitted).
    best_aic, best_bic : str
        The model with the smallest AIC, BIC.
    """

    rows: tuple
    fits: FrozenMap
    best_aic: str
    best_bic: str

    def __repr__(self):
        ranked = ", ".join(
            f"{row['model']} dAIC={row['delta_aic']:.3g}"
            if row["aic"] is not None
            else f"{row['model']} not fitted"
            for row in self.rows
        )
        return f"ModelComparison(best_aic={self.best_aic!r}, best_bic={self.best_bic!r}: {ranked})"

    def _repr_html_(self) -> str:
        """The table as HTML (Jupyter)."""
        from granflow._format import DASH, format_number
        from granflow._html import result_html, table

        def number(value, significant=6):
            return DASH if value is None else format_number(value, significant=significant)

        rows = [
            (
                row["model"],
                row["formula"],
                row["nfree"],
                number(row["chisqr"], 5),
                number(row["aic"]),
                number(row["delta_aic"], 3),
                number(row["bic"]),
                number(row["delta_bic"], 3),
                "fitted" if row["aic"] is not None else f"not fitted: {row['message']}",
            )
            for row in self.rows
        ]
        header = ("model", "formula", "k", "chi-square", "AIC", "ΔAIC", "BIC", "ΔBIC", "")
        return result_html(
            f"ModelComparison: best by AIC {self.best_aic}, by BIC {self.best_bic}",
            [table(rows, header=header, numeric=(2, 3, 4, 5, 6, 7))],
        )

    def report(self) -> str:
        """The table as text."""
        lines = [f"{'model':<12} {'k':>2} {'chi-square':>12} {'AIC':>12} {'dAIC':>9} {'dBIC':>9}"]
        for row in self.rows:
            if row["aic"] is None:
                lines.append(f"{row['model']:<12} {row['nfree']:>2}  not fitted: {row['message']}")
                continue
            lines.append(
                f"{row['model']:<12} {row['nfree']:>2} {row['chisqr']:12.5g} {row['aic']:12.6g} "
                f"{row['delta_aic']:9.2f} {row['delta_bic']:9.2f}"
            )
        lines.append(f"best by AIC: {self.best_aic}; by BIC: {self.best_bic}")
        return "\n".join(lines)

    def to_dict(self, include_arrays: bool = True) -> dict[str, Any]:
        """JSON-safe mapping: the rows, the winners and each model's fit; :meth:`from_dict`
        inverts it.

        Parameters
        ----------
        include_arrays : bool
            Include each fit's per-point arrays (False: a compact summary, which
            :meth:`from_dict` rebuilds with empty arrays).
        """
        return encode(
            {
                "rows": [dict(r) for r in self.rows],
                "best_aic": self.best_aic,
                "best_bic": self.best_bic,
                "fits": {
                    model: None if result is None else result.to_dict(include_arrays=include_arrays)
                    for model, result in self.fits.items()
                },
            }
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> ModelComparison:
        """The comparison a :meth:`to_dict` output (or its JSON) describes."""
        d = decode(d, cls)
        fits = {}
        for model, result in d.get("fits", {}).items():
            fits[model] = None if result is None else _fit_from_dict(model, result)
        return cls(
            rows=tuple(dict(row) for row in d["rows"]),
            fits=FrozenMap(fits),
            best_aic=d["best_aic"],
            best_bic=d["best_bic"],
        )

    def to_frame(self) -> pd.DataFrame:
        """The table as a pandas DataFrame."""
        import pandas as pd

        return pd.DataFrame(list(self.rows)).set_index("model")


def _fit_from_dict(model, saved):
    """The fit result a comparison's ``saved`` fit describes: the class its ``"family"``
    names (or, written before results stored it, the family that lists ``model``)."""
    if "family" in saved:
        kind = families.result_type(saved["family"])
    else:
        kind = families.result_type_of_model(model)
        if kind is None:
            raise InvalidParameterError(
                f"the comparison's fit {model!r} names no model family: it cannot be read"
            )
    return kind.from_dict(saved)


def _hooks(kind):
    """The ``compare`` hooks of this kind (``"record"``, ``"startup"``), family by family."""
    return [
        families.resolve(family.compare[kind])
        for family in families.families()
        if kind in family.compare
    ]


def _record_hook(data):
    """The ``"record"`` hook of the family that takes this record: the one declared for its
    type (``"record:module:Class"``), else the first plain ``"record"`` one."""
    kind = type(data)
    specific = f"record:{kind.__module__}:{kind.__qualname__}"
    for key in (specific, "record"):
        hooks = _hooks(key)
        if hooks:
            return hooks[0]
    raise InvalidParameterError(
        "no model family compares records with a load-point protocol (none declares a "
        "'record' comparison)"
    )


def failed_row(model: str, formula: str, nfree: int, reason: object) -> dict[str, Any]:
    """The comparison's row of a model that could not be fitted (``reason``: the exception
    or a sentence)."""
    return {
        "model": model,
        "formula": formula,
        "nfree": nfree,
        "chisqr": None,
        "aic": None,
        "bic": None,
        "success": False,
        "message": str(reason),
    }


def _log_aging(x, a, F1):
    return F1 + a * np.log(x / x[0])


def _log_aging_jacobian(x, a, F1):
    shape = np.log(x / x[0])
    return F1 + a * shape, np.column_stack([shape, np.ones_like(x)])


def _exponential(x, Fd, F_init, alpha):
    return Fd + (F_init - Fd) * np.exp(-alpha * x)


def _exponential_jacobian(x, Fd, F_init, alpha):
    decay = np.exp(-alpha * x)
    return (
        Fd + (F_init - Fd) * decay,
        np.column_stack([-np.expm1(-alpha * x), decay, -(F_init - Fd) * x * decay]),
    )


#: Pure logarithmic aging F1 + a ln(x / x1), x1 the first point.
LOG_AGING = Model(("a", "F1"), _log_aging, _log_aging_jacobian, log=(False, False))
#: A single exponential approach Fd + (F_init - Fd) exp(-alpha x).
EXPONENTIAL = Model(
    ("Fd", "F_init", "alpha"), _exponential, _exponential_jacobian, log=(False, False, True)
)


def _fit_log_aging(z, y, sigma):
    design = np.column_stack([np.log(z / z[0]), np.ones_like(z)])
    (a, F1), *_ = np.linalg.lstsq(design, y, rcond=None)
    return fit_curve(
        LOG_AGING,
        name="log_aging",
        formula=_FORMULAS["log_aging"],
        units={"a": si_unit("a"), "F1": si_unit("force")},
        start=(a, F1),
        x=z,
        y=y,
        sigma=sigma,
        function=f"{__name__}:LOG_AGING",
    )


def _fit_exponential(z, y, sigma):
    Fd = float(np.mean(y[int(0.9 * y.size) :]))
    best = None
    for alpha in np.geomspace(0.1 / z[-1], 100 / z[-1], 13):
        decay = np.exp(-alpha * z)
        design = np.column_stack([1 - decay, decay])
        coefficients, *_ = np.linalg.lstsq(design, y, rcond=None)
        cost = float(np.sum((design @ coefficients - y) ** 2))
        if best is None or cost < best[0]:
            best = (cost, coefficients, alpha)
    _, (Fd, F_init), alpha = best
    return fit_curve(
        EXPONENTIAL,
        name="exponential",
        formula=_FORMULAS["exponential"],
        units={name: si_unit(name) for name in EXPONENTIAL.slots},
        start=(Fd, F_init if F_init != 0 else 1e-12, alpha),
        x=z,
        y=y,
        sigma=sigma,
        function=f"{__name__}:EXPONENTIAL",
    )


def compare_models(
    data: Run | tuple[ArrayLike, ArrayLike] | Any,
    *,
    domain: str = "slip",
    velocity: float | None = None,
    window: tuple[float, float] | None = None,
    sigma: float | None = None,
    protocol: Any = None,
    rate_and_state: bool = False,
    detrend: bool = False,
    correlated_noise: bool = False,
) -> ModelComparison:
    """Compare Eq. 3 with pure logarithmic aging and a single-exponential approach; or, on a
    record with its load-point protocol, the models of the family that compares such
    records (:mod:`granflow.families`).

    Parameters
    ----------
    data : Run or (array_like, array_like)
        As for :func:`granflow.fit`.
    domain : {"slip", "time"}
        Abscissa slip [m] or time [s]; the rival models are written in the same variable.
    velocity : float, optional
        Sliding velocity [m/s] (time domain).
    window : (float, float), optional
        Fit window, the same for every model.
    sigma : float, optional
        Known noise [N].
    protocol : Protocol, optional
        The load-point velocity history of a record (``data`` then holds time [s] and
        friction; a record read by the family's reader brings its own): the rows are those
        of the family's ``"record"`` comparison (velocity steps: the two laws of the
        friction family, the paper's Eq. 2 with and without the direct effect, each row
        with its residual pattern and the likelihood-ratio test against the model it
        extends). ``window`` is then a list of fit windows [s].
    rate_and_state : bool
        On a start-up curve, add the rows of every family's ``"startup"`` comparison (the
        aging and slip laws of friction on a spring, a step of the load point from a slow
        steady sliding to ``velocity``).
    detrend, correlated_noise : bool
        Records: a linear trend in load-point displacement in every model; the
        likelihood-ratio tests with n divided by the residuals' correlation time.

    Returns
    -------
    ModelComparison

    Examples
    --------
    >>> import numpy as np, granflow
    >>> p = granflow.Params(3.3e-3, 4.2e4, 10e-3, 2e-7)
    >>> x = np.linspace(3e-7, 5e-4, 500)
    >>> y = granflow.friction_slip(x, p) + np.random.default_rng(0).normal(0, 5e-5, 500)
    >>> granflow.compare_models((x, y)).best_aic
    'eq3'
    """
    if domain not in ("slip", "time"):
        raise InvalidParameterError(f"domain must be 'slip' or 'time', got {domain!r}")
    if protocol is not None or hasattr(data, "protocol"):
        rows_of = _record_hook(data)
        if isinstance(data, tuple | list):
            t, friction = data
        else:  # a record or a Run: the friction comes with it
            t, friction = data, None
        rows, fits, _ = rows_of(
            t, friction, protocol, windows=window, detrend=detrend, correlated=correlated_noise
        )
        return _ranked(rows, fits)
    prepared = prepare(data, domain, velocity, window, None, sigma)
    z, y = prepared.z, prepared.y
    fits, rows = {}, []
    for model in MODELS:
        try:
            if model == "eq3":
                result = fit(
                    (z, y), domain=domain, velocity=prepared.velocity, sigma=sigma, profile=False
                )
            elif model == "log_aging":
                result = _fit_log_aging(z, y, sigma)
            else:
                result = _fit_exponential(z, y, sigma)
        except GranflowError as exc:
            fits[model] = None
            nfree = {"eq3": 4, "log_aging": 2, "exponential": 3}[model]
            rows.append(failed_row(model, _FORMULAS[model], nfree, exc))
            continue
        fits[model] = result
        rows.append(result.comparison_row())
    if rate_and_state:
        for rows_of in _hooks("startup"):
            more_rows, more_fits = rows_of(z, y, domain=domain, velocity=prepared.velocity)
            rows += more_rows
            fits.update(more_fits)
    return _ranked(rows, fits)


def _ranked(rows, fits):
    """The comparison of these rows: AIC and BIC differences from the best, the winners."""
    fitted = [r for r in rows if r["aic"] is not None]
    best_aic = min(fitted, key=lambda r: r["aic"])
    best_bic = min(fitted, key=lambda r: r["bic"])
    for row in rows:
        row["delta_aic"] = None if row["aic"] is None else row["aic"] - best_aic["aic"]
        row["delta_bic"] = None if row["bic"] is None else row["bic"] - best_bic["bic"]
    return ModelComparison(
        rows=tuple(rows),
        fits=FrozenMap(fits),
        best_aic=best_aic["model"],
        best_bic=best_bic["model"],
    )
