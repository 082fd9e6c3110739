"""The annular contact of the paper's tube."""

import math

import numpy as np
import pytest

import granflow as gf


def test_paper_tube_dimensions():
    tube = gf.Annulus.paper()
    assert tube.outer_radius == pytest.approx(14.85e-3)
    assert tube.inner_radius == pytest.approx(12.55e-3)
    assert tube.mean_radius == pytest.approx(13.70e-3)
    # (2/3)(Ro^3 - Ri^3)/(Ro^2 - Ri^2) by hand: 13.732 mm
    assert tube.effective_radius == pytest.approx(13.732177615e-3, rel=1e-9)
    assert gf.Annulus.paper("mean").effective_radius == pytest.approx(13.70e-3)
    assert tube.area == pytest.approx(math.pi * (14.85e-3**2 - 12.55e-3**2))


def test_paper_speed_to_velocity():
    tube = gf.Annulus.paper()
    velocity = tube.velocity_from_speed(1e-5)  # rev/s
    assert abs(velocity - 0.861e-6) <= 0.001e-6
    assert tube.velocity_from_speed(6e-4, "1/min") == pytest.approx(velocity, rel=1e-14)
    assert tube.velocity_from_speed(2 * math.pi * 1e-5, "rad/s") == pytest.approx(
        velocity, rel=1e-14
    )
    assert tube.speed_from_velocity(velocity, "1/min") == pytest.approx(6e-4, rel=1e-14)


def test_conversions_round_trip_and_keep_input():
    tube = gf.Annulus.paper()
    torque = np.array([1e-4, 2e-4, 3e-4])
    before = torque.copy()
    force = tube.force_from_torque(torque)
    np.testing.assert_allclose(force, torque / tube.effective_radius)
    np.testing.assert_allclose(tube.torque_from_force(force), torque, rtol=1e-15)
    assert np.array_equal(torque, before)
    assert tube.slip_from_angle(1e-3) == pytest.approx(1e-3 * 13.70e-3)
    assert tube.angle_from_slip(tube.slip_from_angle(0.5)) == pytest.approx(0.5)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: gf.Annulus(-1.0, 1e-3), "outer_diameter must be positive"),
        (lambda: gf.Annulus(10e-3, 6e-3), "wall_thickness must be less than"),
        (lambda: gf.Annulus(10e-3, 1e-3, torque_radius="max"), "torque_radius"),
        (lambda: gf.Annulus.paper().velocity_from_speed(1.0, "Hz"), "unit must be one of"),
        (lambda: gf.Annulus.paper().force_from_torque([1.0, np.nan]), "torque must be finite"),
    ],
)
def test_bad_geometry_input(call, match):
    with pytest.raises(gf.InvalidParameterError, match=match):
        call()


def test_geometry_errors_carry_the_units_of_the_unit_table():
    with pytest.raises(gf.InvalidParameterError, match=r"outer_diameter.* m"):
        gf.Annulus(outer_diameter=-1.0, wall_thickness=1e-3)
    with pytest.raises(gf.InvalidParameterError, match=r"torque.*N m"):
        gf.Annulus.paper().force_from_torque(float("nan"))
