"""Annulus.from_spec: the geometry a user types, checked against hand-computed radii."""

import math

import pytest

from granflow import InvalidParameterError
from granflow.model.geometry import Annulus


def test_paper_spelled_three_ways_is_the_same_tube():
    paper = Annulus.paper()
    by_radii = Annulus.from_spec("outer_radius=14.85 mm, inner_radius=12.55 mm")
    by_wall = Annulus.from_spec({"outer_diameter": "29.7 mm", "wall_thickness": 2.3e-3})
    assert Annulus.from_spec("paper") == paper
    for tube in (by_radii, by_wall):
        assert tube.outer_radius == pytest.approx(14.85e-3, rel=1e-14)
        assert tube.inner_radius == pytest.approx(12.55e-3, rel=1e-12)


def test_effective_and_mean_radius_give_back_the_annulus():
    # hand derivation: Ro = 20 mm, Ri = 10 mm -> r_m = 15 mm,
    # r_eff = (2/3)(8000 - 1000)/(400 - 100) mm = 140/9 mm
    tube = Annulus.from_spec({"effective_radius": f"{140 / 9} mm", "mean_radius": "15 mm"})
    assert tube.outer_radius == pytest.approx(20e-3, rel=1e-12)
    assert tube.inner_radius == pytest.approx(10e-3, rel=1e-9)
    assert math.isclose(tube.effective_radius, 140 / 9 * 1e-3, rel_tol=1e-12)


@pytest.mark.parametrize(
    ("spec", "words"),
    [
        ("radius=3mm", "unknown key 'radius'"),
        ({"outer_radius": "3 mm"}, "outer_radius and inner_radius"),
        ("outer_radius=3mm, inner_radius=4mm", "inner_radius"),
        ("outer_radius=3 s, inner_radius=1mm", "outer_radius"),
        ({"effective_radius": "1 mm", "mean_radius": "2 mm"}, "effective_radius"),
        ("outer_radius", "key=value"),
        (42, "mapping"),
    ],
)
def test_bad_geometry_names_the_key(spec, words):
    with pytest.raises(InvalidParameterError, match=words):
        Annulus.from_spec(spec)
