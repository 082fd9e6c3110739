"""The option objects (checked when made, errors naming the argument and its unit) and the
METHODS registry of steppers that simulate() picks from."""

import dataclasses
import math

import pytest

import granflow as gf
from granflow.simulation.driver import DEFAULT_DAMPING, DEFAULT_MASS, METHODS
from granflow.simulation.dynamic import DynamicStepper
from granflow.simulation.options import Aging, DirectEffect, Drive, Numerics
from granflow.simulation.quasistatic import QuasiStaticStepper
from granflow.simulation.stepper import Stepper

V = 0.86e-6


# -- the option objects ---------------------------------------------------------------------


def test_option_objects_are_frozen_and_keep_their_checked_values():
    aging = Aging("time", t0=1, F_init=0)
    assert (aging.clock, aging.t0, aging.F_init) == ("time", 1.0, 0.0)
    assert isinstance(aging.t0, float)
    drive = Drive(1e-3, 1e-15, mass=1, damping=0, stiffness=200)
    assert (drive.mass, drive.damping, drive.stiffness) == (1.0, 0.0, 200.0)
    assert drive.inertial and not Drive(1e-3, 1e-15).inertial
    numerics = Numerics(points=50, max_evaluations=1e3)
    assert numerics.max_evaluations == 1000 and isinstance(numerics.max_evaluations, int)
    assert numerics.implicit and not Numerics(solver="RK45").implicit
    effect = DirectEffect(1e-4)
    for value, name in ((aging, "t0"), (drive, "mass"), (numerics, "points"), (effect, "velocity")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(value, name, 2.0)


@pytest.mark.parametrize(
    ("make", "words"),
    [
        (lambda: Aging("wall", 1.0, 0.0), "clock must be one of 'slip', 'time', got 'wall'"),
        (lambda: Aging("slip", -1.0, 0.0), "t0 must be positive, got -1 s"),
        (lambda: Aging("slip", math.nan, 0.0), "t0 must be finite, got nan s"),
        (lambda: Aging("slip", 1.0, -2e-3), "F_init must be non-negative, got -0.002 N"),
        (lambda: Drive(-1.0, 1e-15), "v_fail must be positive, got -1 m/s"),
        (lambda: Drive(1e-3, 0.0), "v_stop must be positive, got 0 m/s"),
        (lambda: Drive(1e-3, 1e-15, mass=-1.0, damping=0.5), "mass must be positive, got -1 kg"),
        (
            lambda: Drive(1e-3, 1e-15, mass=1.0, damping=-0.5),
            "damping must be non-negative, got -0.5 N s/m",
        ),
        (
            lambda: Drive(1e-3, 1e-15, mass=1.0, damping=0.5, stiffness=0.0),
            "stiffness must be positive, got 0 N/m",
        ),
        (lambda: Drive(1e-3, 1e-15, mass=1.0), "damping is missing"),
        (lambda: Drive(1e-3, 1e-15, stiffness=10.0), "stiffness applies to an inertial drive"),
        (lambda: Drive(1e-3, 1e-15, damping=1.0), "damping applies to an inertial drive"),
        (lambda: DirectEffect(0.0), "amplitude must be positive, got 0 N"),
        (lambda: DirectEffect(1e-4, velocity=-1.0), "velocity must be positive, got -1 m/s"),
        (lambda: Numerics(points=1), "points must be an integer of at least 2, got 1"),
        (lambda: Numerics(points=2.5), "points must be an integer"),
        (lambda: Numerics(points=True), "points must be an integer"),
        (lambda: Numerics(rtol=0.0), "rtol must be positive"),
        (lambda: Numerics(max_evaluations=-1), "max_evaluations must be positive"),
        (lambda: Numerics(max_transitions=0), "max_transitions must be positive"),
        (lambda: Numerics(max_wall=math.inf), "max_wall must be finite, got inf s"),
    ],
)
def test_bad_options_name_the_argument_and_its_unit(make, words):
    with pytest.raises(gf.InvalidParameterError, match=words.replace("(", r"\(")):
        make()


def test_simulate_builds_the_options_it_reports(blue):
    protocol = gf.Protocol([gf.Velocity(V, 10.0), gf.SwitchToForce(5.0, factor=1.01)])
    result = gf.simulate(blue, protocol, method="dynamic", points=20)
    options = result.options
    assert options["mass"] == DEFAULT_MASS and options["damping"] == DEFAULT_DAMPING
    assert options["stiffness"] is None and options["solver"] == "LSODA"
    assert options["t0"] == pytest.approx(blue.x0 / V, rel=1e-15)
    assert options["v_stop"] == pytest.approx(1e-9 * V, rel=1e-15)
    assert list(options) == [
        "clock",
        "method",
        "t0",
        "mass",
        "damping",
        "stiffness",
        "v_fail",
        "v_stop",
        "direct_effect",
        "rtol",
        "solver",
        "max_evaluations",
        "max_transitions",
        "max_wall",
    ]
    quasistatic = gf.simulate(blue, protocol, points=20).options
    assert quasistatic["mass"] is None and quasistatic["damping"] is None


@pytest.mark.parametrize(
    ("keyword", "value", "words"),
    [
        ("t0", 0.0, "t0 must be positive, got 0 s"),
        ("F_init", -1.0, "F_init must be non-negative, got -1 N"),
        ("points", 1, "points must be an integer of at least 2"),
        ("rtol", -1e-9, "rtol must be positive"),
        ("max_wall", 0.0, "max_wall must be positive, got 0 s"),
        ("direct_effect", -1e-4, "amplitude must be positive"),
        ("stiffness", 10.0, "stiffness applies to method='dynamic' only"),
    ],
)
def test_simulate_keywords_are_checked_by_the_option_objects(blue, keyword, value, words):
    with pytest.raises(gf.InvalidParameterError, match=words):
        gf.simulate(blue, [gf.Velocity(V, 1.0)], **{keyword: value})


# -- the METHODS registry ---------------------------------------------------------------------


def test_methods_registry_holds_the_two_steppers():
    assert {"quasistatic": QuasiStaticStepper, "dynamic": DynamicStepper} == METHODS
    assert gf.simulation.METHODS is METHODS
    for stepper in METHODS.values():
        assert issubclass(stepper, Stepper)
        assert stepper.rate is not Stepper.rate and stepper.force is not Stepper.force
    assert DynamicStepper.inertial and not QuasiStaticStepper.inertial


def test_an_unknown_method_names_the_known_ones(blue):
    with pytest.raises(gf.InvalidParameterError) as info:
        gf.simulate(blue, [gf.Velocity(V, 1.0)], method="implicit")
    message = str(info.value)
    assert "method must be one of" in message and "'implicit'" in message
    for name in METHODS:
        assert repr(name) in message


def test_simulate_runs_the_stepper_that_method_names(blue, monkeypatch):
    """A stepper registered under a new name is what simulate(method=name) runs."""
    seen = []

    class Recording(QuasiStaticStepper):
        def force(self, piece):
            seen.append(piece)
            super().force(piece)

    monkeypatch.setitem(METHODS, "recording", Recording)
    protocol = gf.Protocol([gf.Velocity(V, 10.0), gf.SwitchToForce(5.0, factor=1.01)])
    result = gf.simulate(blue, protocol, method="recording")
    reference = gf.simulate(blue, protocol)
    assert len(seen) == 1 and seen[0].duration == 5.0
    assert result.options["method"] == "recording"
    assert result.to_dict()["slip"] == reference.to_dict()["slip"]
