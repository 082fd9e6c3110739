"""The prior of a watch's forecasts (``--prior results.json``): the campaign's material
constants, taken at each record's normal load, or a fixed prior on a, alpha, Fd."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from granflow.errors import InvalidParameterError

__all__ = ["MaterialPrior", "prior_for", "read_prior"]


@dataclass(frozen=True)
class MaterialPrior:
    """Amontons' material constants with their standard errors: the prior at a load.

    Attributes
    ----------
    mu_a, mu_d : tuple of float
        (value, standard error) of a / F_N and Fd / F_N [-].
    alpha : tuple of float
        (value, standard error) [1/m].
    source : str
        Where they come from.
    """

    mu_a: tuple
    mu_d: tuple
    alpha: tuple
    source: str

    def at(self, normal_load):
        """The :class:`~granflow.forecast.Prior` at a normal load [N]."""
        from granflow.forecast.prior import Prior

        return Prior.from_material(self.mu_a, self.mu_d, self.alpha, normal_load)


def read_prior(path):
    """A :class:`MaterialPrior` from a ``granflow analyze`` results.json (its ``material``),
    or a :class:`~granflow.forecast.Prior` from a JSON mapping ``{"a": [value, stderr],
    "alpha": [...], "Fd": [...]}`` (SI)."""
    from granflow.forecast.prior import Prior

    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InvalidParameterError(f"--prior {path}: cannot read it ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise InvalidParameterError(f"--prior {path}: not JSON ({exc})") from None
    material = data.get("material") if isinstance(data, dict) else None
    if isinstance(material, dict):
        if material.get("source") is None or not isinstance(material.get("mu_a"), dict):
            reason = material.get("reason") or "not determined"
            raise InvalidParameterError(
                f"--prior {path}: the campaign has no material constants ({reason})"
            )
        pairs = {
            name: (float(material[name]["value"]), float(material[name]["stderr"]))
            for name in ("mu_a", "mu_d", "alpha")
        }
        return MaterialPrior(**pairs, source=f"{path} ({material['source']})")
    if isinstance(data, dict) and set(data) & {"a", "alpha", "Fd"}:
        return Prior.from_dict(data)
    raise InvalidParameterError(
        f"--prior {path}: expected a granflow analyze results.json (with 'material') or a "
        "mapping of a, alpha, Fd to [value, stderr]"
    )


def prior_for(prior, metadata):
    """(the prior for a record, a sentence when it cannot be had): a MaterialPrior is taken
    at the record's normal load (its metadata's ``normal_load`` [N])."""
    if not isinstance(prior, MaterialPrior):
        return prior, None
    load = metadata.get("normal_load")
    if not isinstance(load, float) or not load > 0:
        return None, "no prior: the record gives no normal load for the material constants"
    return prior.at(load), None
