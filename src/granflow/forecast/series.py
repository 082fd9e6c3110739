"""What an observer would have said at each cut time of a finished record: the frozen
:class:`ForecastSeries` of :func:`granflow.forecast.running_forecast`."""

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from granflow.fitting.results import decode, encode

__all__ = ["ForecastSeries"]


@dataclass(frozen=True)
class ForecastSeries:
    """What an observer would have said at each cut time: each method's t_f and interval
    (:func:`granflow.forecast.running_forecast`; called ``RunningForecast`` before that name
    went to the live forecast, :class:`granflow.RunningForecast`).

    Attributes
    ----------
    cuts : numpy.ndarray
        Cut times [s].
    methods : dict
        Method name -> {"time", "low", "high"}: arrays [s] over the cuts (NaN: no date).
    observed : float or None
        The observed failure time [s], when known.
    level : float
        Level of the intervals [-].
    """

    cuts: np.ndarray
    methods: dict
    observed: float | None
    level: float

    def rows(self) -> list[dict[str, Any]]:
        """The table: one dict per cut and method (SI units)."""
        rows = []
        for k, cut in enumerate(self.cuts):
            for name, values in self.methods.items():
                rows.append(
                    {
                        "cut": float(cut),
                        "method": name,
                        "time": float(values["time"][k]),
                        "low": float(values["low"][k]),
                        "high": float(values["high"][k]),
                    }
                )
        return rows

    def _repr_html_(self) -> str:
        """The table as HTML (Jupyter), times in s."""
        from granflow._format import format_number
        from granflow._html import result_html, table

        observed = "unknown" if self.observed is None else f"{self.observed:.4g} s"
        rows = [
            (
                format_number(row["cut"]),
                row["method"],
                format_number(row["time"]),
                f"[{format_number(row['low'])}, {format_number(row['high'])}]",
            )
            for row in self.rows()
        ]
        header = ("cut [s]", "method", "t_f [s]", f"{self.level:.0%} interval [s]")
        return result_html(
            f"ForecastSeries: observed failure {observed}",
            [table(rows, header=header, numeric=(0, 2))],
        )

    def report(self) -> str:
        """The table as text, times in s."""
        observed = "unknown" if self.observed is None else f"{self.observed:.4g} s"
        lines = [f"[[Forecast series]] observed failure: {observed}"]
        lines.append(
            f"    {'cut [s]':>9} {'method':<17} {'t_f [s]':>9}   {self.level:.0%} interval"
        )
        for row in self.rows():
            lines.append(
                f"    {row['cut']:9.4g} {row['method']:<17} {row['time']:9.4g}   "
                f"[{row['low']:.4g}, {row['high']:.4g}]"
            )
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe mapping (SI units)."""
        methods = {
            name: {key: np.asarray(v, dtype=float).tolist() for key, v in values.items()}
            for name, values in self.methods.items()
        }
        return encode(
            {
                "cuts": np.asarray(self.cuts, dtype=float).tolist(),
                "methods": methods,
                "observed": self.observed,
                "level": self.level,
            }
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "ForecastSeries":
        """Inverse of :meth:`to_dict`."""
        d = decode(d, cls)

        def array(values):
            return np.array([math.nan if v is None else v for v in values], dtype=float)

        return cls(
            cuts=array(d["cuts"]),
            methods={
                name: {key: array(v) for key, v in values.items()}
                for name, values in d["methods"].items()
            },
            observed=None if d.get("observed") is None else float(d["observed"]),
            level=float(d["level"]),
        )
