"""Annular contact of a rotating tube on a granular layer: torque, angle and speed to SI."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidParameterError
from granflow.model.units import si_unit

if TYPE_CHECKING:
    from granflow._typing import ArrayLike

__all__ = ["SPEED_UNITS", "Annulus"]

#: Factors from a rotational speed in each unit to rev/s (its SI unit in the unit table); the
#: spellings a caller may pass as ``unit``, not a table of quantities.
SPEED_UNITS = {
    "rev/s": 1.0,
    "1/s": 1.0,
    "1/min": 1.0 / 60.0,
    "rpm": 1.0 / 60.0,
    "rad/s": 0.5 / math.pi,
}
_TORQUE_RADII = ("uniform", "mean")


def _speed_factor(unit):
    try:
        return SPEED_UNITS[unit]
    except KeyError:
        known = ", ".join(SPEED_UNITS)
        raise InvalidParameterError(f"unit must be one of {known}, got {unit!r}") from None


_SPEC_KEYS = (
    "outer_diameter",
    "wall_thickness",
    "outer_radius",
    "inner_radius",
    "effective_radius",
    "mean_radius",
    "torque_radius",
)


def _spec_fields(spec):
    """A geometry spec (mapping or "key=value,..." string) as a dict with known keys."""
    if isinstance(spec, str):
        fields = {}
        for item in filter(None, (part.strip() for part in spec.split(","))):
            key, sep, value = item.partition("=")
            if not sep:
                raise InvalidParameterError(
                    f"geometry: expected 'paper' or key=value pairs, got {item!r} in {spec!r}"
                )
            fields[key.strip()] = value.strip()
    elif hasattr(spec, "items"):
        fields = {str(key): value for key, value in spec.items()}
    else:
        raise InvalidParameterError(
            f"geometry must be 'paper', a mapping or a 'key=value,...' string, "
            f"got {type(spec).__name__}"
        )
    unknown = sorted(set(fields) - set(_SPEC_KEYS))
    if unknown:
        raise InvalidParameterError(
            f"geometry: unknown key {unknown[0]!r}; known: {', '.join(_SPEC_KEYS)}"
        )
    return fields


def _length(value, key):
    """A positive length [m] from a number (metres) or a string with a unit."""
    from granflow.model.units import parse_quantity

    length = parse_quantity(value, "m", f"geometry {key}")
    if not length > 0:
        raise InvalidParameterError(f"geometry {key} must be positive, got {value!r}")
    return length


def _from_radii(effective, mean, cls):
    """The annulus whose uniform-stress radius is ``effective`` and mean radius ``mean``.

    With s = R_o + R_i = 2 r_m and p = R_o R_i, r_eff = (2/3)(s^2 - p)/s gives
    p = s^2 - (3/2) r_eff s; R_o and R_i are the roots of z^2 - s z + p.
    """
    if not mean <= effective < 4.0 / 3.0 * mean:
        raise InvalidParameterError(
            f"geometry: effective_radius {effective:g} m must lie in [mean_radius, 4/3 "
            f"mean_radius) = [{mean:g}, {4 * mean / 3:g}) m for an annulus"
        )
    total = 2.0 * mean
    product = total * total - 1.5 * effective * total
    half_gap = math.sqrt(max(total * total / 4.0 - product, 0.0))
    outer, inner = total / 2.0 + half_gap, total / 2.0 - half_gap
    if half_gap == 0.0:
        raise InvalidParameterError(
            f"geometry: effective_radius equal to mean_radius ({mean:g} m) is a line, not "
            "an annulus"
        )
    return cls(2 * outer, outer - inner)


def _scale(value, factor, name, unit=None):
    """value * factor, keeping scalars as floats and arrays as new arrays; ``unit`` (for
    messages) defaults to the SI unit of the quantity ``name``."""
    unit = si_unit(name) if unit is None else unit
    if np.ndim(value) == 0:
        return check.real_scalar(value, name, unit) * factor
    return check.real_array(value, name, unit) * factor


@dataclass(frozen=True, slots=True)
class Annulus:
    """The annular contact between the end of a tube and the granular layer.

    Parameters
    ----------
    outer_diameter : float
        Outer diameter of the tube [m]; positive.
    wall_thickness : float
        Wall thickness [m]; positive and less than the outer radius.
    torque_radius : {"uniform", "mean"}
        Radius that turns torque into friction force: ``"uniform"`` (default) assumes a
        uniform shear stress on the annulus, r_eff = (2/3)(Ro^3 - Ri^3)/(Ro^2 - Ri^2);
        ``"mean"`` uses the mean radius (Ro + Ri)/2.

    Examples
    --------
    >>> from granflow import Annulus
    >>> tube = Annulus.paper()
    >>> round(tube.velocity_from_speed(1e-5) * 1e6, 3)  # 1e-5 rev/s in um/s
    0.861
    >>> round(tube.effective_radius * 1e3, 2)  # mm
    13.73
    """

    outer_diameter: float
    wall_thickness: float
    torque_radius: str = "uniform"

    def __post_init__(self):
        diameter = check.positive(self.outer_diameter, "outer_diameter", si_unit("outer_diameter"))
        wall = check.positive(self.wall_thickness, "wall_thickness", si_unit("wall_thickness"))
        if wall >= diameter / 2:
            raise InvalidParameterError(
                f"wall_thickness must be less than the outer radius {diameter / 2:g} m, "
                f"got {wall:g} m"
            )
        if self.torque_radius not in _TORQUE_RADII:
            raise InvalidParameterError(
                f"torque_radius must be 'uniform' or 'mean', got {self.torque_radius!r}"
            )
        object.__setattr__(self, "outer_diameter", diameter)
        object.__setattr__(self, "wall_thickness", wall)

    @classmethod
    def paper(cls, torque_radius: str = "uniform") -> Annulus:
        """The aluminium tube of Farain & Bonn: outer diameter 29.7 mm, wall 2.3 mm."""
        return cls(outer_diameter=29.7e-3, wall_thickness=2.3e-3, torque_radius=torque_radius)

    @classmethod
    def from_spec(cls, spec: Any) -> Annulus:
        """The annulus a user describes in a manifest, on the command line or in Python.

        Parameters
        ----------
        spec : str, mapping or Annulus
            ``"paper"`` (:meth:`paper`); an :class:`Annulus` (returned as it is); a mapping, or
            a string ``"key=value,key=value"``, holding one of these pairs of lengths, each a
            number in metres or a string with its unit ("14.85 mm"):

            - ``outer_diameter`` and ``wall_thickness``;
            - ``outer_radius`` and ``inner_radius``;
            - ``effective_radius`` (r_eff, torque to force) and ``mean_radius`` (r_m, angle
              to slip), with r_m <= r_eff < (4/3) r_m, from which the radii of the annulus
              with uniform shear stress follow.

            ``torque_radius`` ("uniform" or "mean") may be added to the first two.

        Raises
        ------
        granflow.InvalidParameterError
            An unknown key, a missing or extra length, a length that is not a positive
            length, or radii that make no annulus; the message names the key.

        Examples
        --------
        >>> tube = Annulus.from_spec("outer_radius=14.85mm, inner_radius=12.55mm")
        >>> round(tube.effective_radius * 1e3, 2)  # mm
        13.73
        """
        if isinstance(spec, cls):
            return spec
        if isinstance(spec, str) and spec.strip().lower() == "paper":
            return cls.paper()
        fields = _spec_fields(spec)
        torque_radius = fields.pop("torque_radius", None)
        lengths = {key: _length(value, key) for key, value in fields.items()}
        keys = frozenset(lengths)
        if keys == {"outer_diameter", "wall_thickness"}:
            return cls(torque_radius=torque_radius or "uniform", **lengths)
        if keys == {"outer_radius", "inner_radius"}:
            outer, inner = lengths["outer_radius"], lengths["inner_radius"]
            if inner >= outer:
                raise InvalidParameterError(
                    f"geometry: inner_radius {inner:g} m must be less than outer_radius {outer:g} m"
                )
            return cls(2 * outer, outer - inner, torque_radius=torque_radius or "uniform")
        if keys == {"effective_radius", "mean_radius"}:
            if torque_radius is not None:
                raise InvalidParameterError(
                    "geometry: torque_radius cannot be given with effective_radius"
                )
            return _from_radii(lengths["effective_radius"], lengths["mean_radius"], cls)
        raise InvalidParameterError(
            "geometry must be 'paper' or give outer_diameter and wall_thickness, outer_radius "
            f"and inner_radius, or effective_radius and mean_radius; got {sorted(keys)}"
        )

    @property
    def outer_radius(self) -> float:
        """R_o [m]."""
        return self.outer_diameter / 2

    @property
    def inner_radius(self) -> float:
        """R_i [m]."""
        return self.outer_radius - self.wall_thickness

    @property
    def mean_radius(self) -> float:
        """Mean radius (R_o + R_i)/2 [m]: the radius at which slip and velocity are measured."""
        return (self.outer_radius + self.inner_radius) / 2

    @property
    def uniform_stress_radius(self) -> float:
        """(2/3)(R_o^3 - R_i^3)/(R_o^2 - R_i^2) [m]: torque/force for uniform shear stress."""
        ro, ri = self.outer_radius, self.inner_radius
        return 2.0 / 3.0 * (ro**3 - ri**3) / (ro**2 - ri**2)

    @property
    def effective_radius(self) -> float:
        """Radius [m] that converts torque to friction force, as chosen by ``torque_radius``."""
        return self.uniform_stress_radius if self.torque_radius == "uniform" else self.mean_radius

    @property
    def area(self) -> float:
        """Contact area pi (R_o^2 - R_i^2) [m^2]."""
        return math.pi * (self.outer_radius**2 - self.inner_radius**2)

    def force_from_torque(self, torque: ArrayLike) -> Any:
        """Friction force [N] from torque [N m]."""
        return _scale(torque, 1.0 / self.effective_radius, "torque")

    def torque_from_force(self, force: ArrayLike) -> Any:
        """Torque [N m] from friction force [N]."""
        return _scale(force, self.effective_radius, "force")

    def slip_from_angle(self, angle: ArrayLike) -> Any:
        """Slip [m] at the mean radius from deflection angle [rad]."""
        return _scale(angle, self.mean_radius, "angle")

    def angle_from_slip(self, slip: ArrayLike) -> Any:
        """Deflection angle [rad] from slip at the mean radius [m]."""
        return _scale(slip, 1.0 / self.mean_radius, "slip")

    def velocity_from_speed(self, speed: ArrayLike, unit: str = "rev/s") -> Any:
        """Sliding velocity [m/s] at the mean radius from rotational speed.

        Parameters
        ----------
        speed : float or array_like
            Rotational speed in ``unit``.
        unit : {"rev/s", "1/s", "1/min", "rpm", "rad/s"}
            Unit of ``speed``; "1/s" and "1/min" are revolutions, as rheometers print them.
        """
        return _scale(speed, _speed_factor(unit) * 2.0 * math.pi * self.mean_radius, "speed", unit)

    def speed_from_velocity(self, velocity: ArrayLike, unit: str = "rev/s") -> Any:
        """Rotational speed in ``unit`` from sliding velocity [m/s] at the mean radius."""
        return _scale(
            velocity,
            1.0 / (_speed_factor(unit) * 2.0 * math.pi * self.mean_radius),
            "velocity",
        )
