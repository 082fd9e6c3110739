"""Material parameters of the aging-rejuvenation model, in SI units, validated when made."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from granflow import _validate as check
from granflow.errors import InvalidParameterError

if TYPE_CHECKING:
    from granflow._typing import PathLike

#: What a parameter mapping may hold: the slip-domain set (a, alpha, Fd, x0) or the
#: time-domain set (a, k, t0, Fd, velocity); units from :data:`granflow.model.units.QUANTITIES`.
_SLIP_KEYS = ("a", "alpha", "Fd", "x0")
_TIME_KEYS = ("a", "k", "t0", "Fd", "velocity")

__all__ = ["MaterialConstants", "Params"]


@dataclass(frozen=True, slots=True)
class Params:
    """Parameters of Eq. 2 in the slip domain, ``dF/dx = a/x - alpha (F - Fd)``.

    Parameters
    ----------
    a : float
        Aging amplitude [N]: at rest F grows as ``a ln(t / tau)``; ``a >= 0``.
    alpha : float
        Shear-rejuvenation constant [1/m]; ``1/alpha`` is a slip length; ``alpha > 0``.
    Fd : float
        Steady-state (dynamic) friction [N]; ``Fd >= 0``.
    x0 : float
        Initial state as a slip [m] (``x0 = v t0``); the model starts there; ``x0 > 0``.

    Examples
    --------
    >>> from granflow import Params
    >>> p = Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    >>> round(p.alpha), round(p.x0 * 1e6, 4)
    (41860, 0.1978)
    >>> round(p.k(0.86e-6), 6), round(p.t0(0.86e-6), 6)
    (0.036, 0.23)
    """

    a: float
    alpha: float
    Fd: float
    x0: float

    def __post_init__(self):
        object.__setattr__(self, "a", check.non_negative(self.a, "a", "N"))
        object.__setattr__(self, "alpha", check.positive(self.alpha, "alpha", "1/m"))
        object.__setattr__(self, "Fd", check.non_negative(self.Fd, "Fd", "N"))
        object.__setattr__(self, "x0", check.positive(self.x0, "x0", "m"))

    @classmethod
    def from_time_domain(cls, a: float, k: float, t0: float, Fd: float, velocity: float) -> Params:
        """Build from the paper's time-domain values at one sliding velocity.

        Parameters
        ----------
        a : float
            Aging amplitude [N].
        k : float
            Rejuvenation rate ``alpha * velocity`` [1/s]; positive.
        t0 : float
            Initial-state time [s]; positive.
        Fd : float
            Steady-state friction [N].
        velocity : float
            Imposed sliding velocity [m/s]; positive.
        """
        velocity = check.positive(velocity, "velocity", "m/s")
        k = check.positive(k, "k", "1/s")
        t0 = check.positive(t0, "t0", "s")
        return cls(a=a, alpha=k / velocity, Fd=Fd, x0=t0 * velocity)

    @classmethod
    def from_material(cls, constants: MaterialConstants, normal_load: float, x0: float) -> Params:
        """Parameters at one normal load from Amontons material constants.

        Parameters
        ----------
        constants : MaterialConstants
            ``mu_a``, ``mu_d`` [-] and ``alpha`` [1/m].
        normal_load : float
            Normal load F_N [N]; positive.
        x0 : float
            Initial state [m].
        """
        return constants.params_at(normal_load, x0)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], source: str = "params") -> Params:
        """Build from a mapping of SI numbers or strings with units (as a parameter file holds).

        Parameters
        ----------
        values : mapping
            Either ``a, alpha, Fd, x0`` (slip domain) or ``a, k, t0, Fd, velocity`` (time
            domain); each a number in SI units or a string with a unit ("3.31 mN",
            "0.86 um/s"). A mapping whose ``params`` entry is a mapping is read from there.
        source : str
            Where the mapping comes from (a file name), for error messages.

        Raises
        ------
        granflow.InvalidParameterError
            Not a mapping, an unknown or missing parameter, or a value that is not a
            quantity of the right dimension; the message names the source and the key.

        Examples
        --------
        >>> from granflow import Params
        >>> p = Params.from_mapping({"a": "3.31 mN", "alpha": 4.186e4, "Fd": "10 mN",
        ...                          "x0": "0.198 um"})
        >>> round(p.a * 1e3, 2), round(p.x0 * 1e6, 3)
        (3.31, 0.198)
        """
        from granflow.model.units import parse_quantity, si_unit

        if isinstance(values, dict) and isinstance(values.get("params"), dict):
            values = values["params"]
        if not isinstance(values, dict):
            raise InvalidParameterError(
                f"{source}: expected a mapping of parameters (a, alpha, Fd, x0)"
            )
        unknown = sorted(set(values) - {*_SLIP_KEYS, *_TIME_KEYS})
        if unknown:
            raise InvalidParameterError(f"{source}: unknown parameter(s) {', '.join(unknown)}")
        parsed = {
            key: parse_quantity(value, si_unit(key), f"{source}: {key}")
            for key, value in values.items()
        }
        time_domain = {"k", "t0"} <= set(parsed)
        required = _TIME_KEYS if time_domain else _SLIP_KEYS
        missing = [key for key in required if key not in parsed]
        if missing:
            raise InvalidParameterError(
                f"{source}: missing parameter {missing[0]} (give a, alpha, Fd, x0 or a, k, t0, "
                "Fd, velocity)"
            )
        if time_domain:
            return cls.from_time_domain(**{key: parsed[key] for key in _TIME_KEYS})
        return cls(**{key: parsed[key] for key in _SLIP_KEYS})

    @classmethod
    def load(cls, path: PathLike) -> Params:
        """Read parameters from a YAML file; see :meth:`from_mapping` for what it holds.

        Parameters
        ----------
        path : str or pathlib.Path
            A YAML mapping, e.g. ``a: 3.31 mN``, ``k: 0.036 /s``, ``t0: 0.23 s``,
            ``Fd: 10 mN``, ``velocity: 0.86 um/s``.

        Raises
        ------
        granflow.InvalidParameterError
            The file cannot be read, is not YAML, or does not hold valid parameters.
        """
        import yaml

        try:
            data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
        except OSError as exc:
            raise InvalidParameterError(f"{path}: cannot read the parameters ({exc})") from None
        except yaml.YAMLError as exc:
            raise InvalidParameterError(f"{path}: not valid YAML ({exc})") from None
        return cls.from_mapping(data, source=str(path))

    def k(self, velocity: float) -> float:
        """Rejuvenation rate ``alpha * velocity`` [1/s] at a sliding velocity [m/s]."""
        return self.alpha * check.positive(velocity, "velocity", "m/s")

    def t0(self, velocity: float) -> float:
        """Initial-state time ``x0 / velocity`` [s] at a sliding velocity [m/s]."""
        return self.x0 / check.positive(velocity, "velocity", "m/s")

    @property
    def slip_length(self) -> float:
        """Rejuvenation slip length ``1 / alpha`` [m]."""
        return 1.0 / self.alpha

    def to_material(self, normal_load: float) -> MaterialConstants:
        """Amontons material constants (mu_a = a/F_N, mu_d = Fd/F_N, alpha) at a load [N]."""
        load = check.positive(normal_load, "normal_load", "N")
        return MaterialConstants(mu_a=self.a / load, mu_d=self.Fd / load, alpha=self.alpha)

    def replace(self, **changes: Any) -> Params:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, float]:
        """JSON-safe mapping of the four parameters in SI units."""
        return {"a": self.a, "alpha": self.alpha, "Fd": self.Fd, "x0": self.x0}

    def __repr__(self):
        return (
            f"Params(a={self.a:.6g} N, alpha={self.alpha:.6g} 1/m, "
            f"Fd={self.Fd:.6g} N, x0={self.x0:.6g} m)"
        )


@dataclass(frozen=True, slots=True)
class MaterialConstants:
    """Load-independent constants of a granular layer under Amontons' law.

    Parameters
    ----------
    mu_a : float
        Aging friction coefficient ``a / F_N`` [-]; non-negative.
    mu_d : float
        Dynamic friction coefficient ``Fd / F_N`` [-]; non-negative.
    alpha : float
        Shear-rejuvenation constant [1/m]; positive; independent of the load.

    Examples
    --------
    >>> from granflow import MaterialConstants
    >>> p = MaterialConstants(mu_a=0.06, mu_d=0.2, alpha=4e4).params_at(0.05, x0=2e-7)
    >>> round(p.a, 6), round(p.Fd, 6)
    (0.003, 0.01)
    """

    mu_a: float
    mu_d: float
    alpha: float

    def __post_init__(self):
        object.__setattr__(self, "mu_a", check.non_negative(self.mu_a, "mu_a", ""))
        object.__setattr__(self, "mu_d", check.non_negative(self.mu_d, "mu_d", ""))
        object.__setattr__(self, "alpha", check.positive(self.alpha, "alpha", "1/m"))

    def params_at(self, normal_load: float, x0: float) -> Params:
        """Model parameters at a normal load [N] and initial state x0 [m]."""
        load = check.positive(normal_load, "normal_load", "N")
        return Params(a=self.mu_a * load, alpha=self.alpha, Fd=self.mu_d * load, x0=x0)

    def to_dict(self) -> dict[str, float]:
        """JSON-safe mapping of the three constants (alpha in 1/m)."""
        return {"mu_a": self.mu_a, "mu_d": self.mu_d, "alpha": self.alpha}
