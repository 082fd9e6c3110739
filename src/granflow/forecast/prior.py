"""A prior from other runs of the campaign: Gaussian constraints on a, alpha and Fd."""

import math
from dataclasses import dataclass

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidParameterError

__all__ = ["Prior"]

_NAMES = ("a", "alpha", "Fd")
_UNITS = {"a": "N", "alpha": "1/m", "Fd": "N"}


def _pair(value, name):
    if value is None:
        return None
    try:
        mean, stderr = value
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"prior {name} must be a (value, standard error) pair, got {value!r}"
        ) from None
    unit = _UNITS[name]
    return (
        check.positive(mean, f"prior {name}", unit),
        check.positive(stderr, f"prior {name} stderr", unit),
    )


@dataclass(frozen=True)
class Prior:
    """Independent Gaussian priors on the parameters of one run, each (value, standard error).

    Parameters
    ----------
    a : tuple of float, optional
        Aging amplitude and its standard error [N].
    alpha : tuple of float, optional
        Rejuvenation constant and its standard error [1/m].
    Fd : tuple of float, optional
        Steady-state friction and its standard error [N] (e.g. a previous run's F_d).

    Examples
    --------
    >>> from granflow.forecast import Prior
    >>> Prior(Fd=(11e-3, 0.2e-3)).names
    ('Fd',)
    """

    a: tuple | None = None
    alpha: tuple | None = None
    Fd: tuple | None = None

    def __post_init__(self):
        for name in _NAMES:
            object.__setattr__(self, name, _pair(getattr(self, name), name))
        if not self.names:
            raise InvalidParameterError("a Prior needs at least one of a, alpha, Fd")

    @property
    def names(self):
        """The constrained parameters, in the order a, alpha, Fd."""
        return tuple(name for name in _NAMES if getattr(self, name) is not None)

    def residuals(self, params):
        """Standardised residuals ``(value - mean) / stderr`` of ``params`` [-]."""
        return np.array(
            [(getattr(params, n) - getattr(self, n)[0]) / getattr(self, n)[1] for n in self.names]
        )

    @classmethod
    def from_material(cls, mu_a, mu_d, alpha, normal_load):
        """The prior at a normal load from Amontons material constants with standard errors.

        Parameters
        ----------
        mu_a, mu_d : tuple of float
            (value, standard error) of a / F_N and Fd / F_N [-].
        alpha : tuple of float
            (value, standard error) of alpha [1/m].
        normal_load : float
            Normal load F_N [N].
        """
        load = check.positive(normal_load, "normal_load", "N")
        return cls(
            a=(mu_a[0] * load, mu_a[1] * load),
            alpha=tuple(alpha),
            Fd=(mu_d[0] * load, mu_d[1] * load),
        )

    @classmethod
    def from_amontons(cls, result, normal_load):
        """The prior at a normal load from an :class:`~granflow.AmontonsResult`."""
        joint = result.joint

        def pair(name):
            stderr = joint.stderr[name]
            if not math.isfinite(stderr) or stderr <= 0:
                raise InvalidParameterError(f"the Amontons fit has no standard error of {name}")
            return (joint.params[name], stderr)

        return cls.from_material(pair("mu_a"), pair("mu_d"), pair("alpha"), normal_load)

    def to_dict(self):
        """JSON-safe mapping: name -> [value, stderr] (SI)."""
        return {name: list(getattr(self, name)) for name in self.names}

    @classmethod
    def from_dict(cls, d):
        """Inverse of :meth:`to_dict`."""
        return cls(**{name: tuple(d[name]) for name in _NAMES if d.get(name) is not None})
