"""Params and MaterialConstants: construction, validation, conversions."""

import dataclasses
import math

import numpy as np
import pytest

import granflow as gf


def test_time_domain_round_trip():
    p = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    assert p.alpha == pytest.approx(0.036 / 0.86e-6, rel=1e-15)
    assert p.x0 == pytest.approx(0.23 * 0.86e-6, rel=1e-15)
    assert p.k(0.86e-6) == pytest.approx(0.036, rel=1e-15)
    assert p.t0(0.86e-6) == pytest.approx(0.23, rel=1e-15)
    assert p.slip_length == pytest.approx(0.86e-6 / 0.036)
    # SPEC §4 table: alpha 4.19e4 1/m and x0 0.198 µm for the blue set
    assert round(p.alpha, -2) == 41900
    assert round(p.x0 * 1e6, 3) == 0.198


def test_params_are_frozen_and_json_safe():
    p = gf.Params(a=1e-3, alpha=1e4, Fd=2e-3, x0=1e-7)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.a = 2.0
    assert p.to_dict() == {"a": 1e-3, "alpha": 1e4, "Fd": 2e-3, "x0": 1e-7}
    assert "1/m" in repr(p)
    assert p.replace(a=2e-3).a == 2e-3
    assert isinstance(gf.Params(a=np.float32(1), alpha=np.int64(3), Fd=0, x0=1).alpha, float)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"a": -1e-3}, r"a must be non-negative, got -0.001 N"),
        ({"a": math.nan}, r"a must be finite, got nan N"),
        ({"alpha": 0.0}, r"alpha must be positive, got 0 1/m"),
        ({"alpha": -5.0}, r"alpha must be positive"),
        ({"Fd": -1e-3}, r"Fd must be non-negative"),
        ({"x0": 0.0}, r"x0 must be positive, got 0 m"),
        ({"x0": math.inf}, r"x0 must be finite"),
        ({"a": "3 m"}, r"a must be a quantity in N, got '3 m' \(in m, which does not"),
        ({"a": "3"}, r"a must be a real number in N or a string with a unit, got '3' \(no"),
        ({"a": True}, r"a must be a real number"),
        ({"a": np.array([1.0, 2.0])}, r"a must be a real number"),
    ],
)
def test_invalid_params_name_the_argument(kwargs, match):
    values = {"a": 1e-3, "alpha": 1e4, "Fd": 2e-3, "x0": 1e-7} | kwargs
    with pytest.raises(gf.InvalidParameterError, match=match):
        gf.Params(**values)


def test_replace_validates_again():
    with pytest.raises(gf.InvalidParameterError, match="alpha"):
        gf.Params(a=1e-3, alpha=1e4, Fd=2e-3, x0=1e-7).replace(alpha=-1.0)


@pytest.mark.parametrize("bad", [{"velocity": 0.0}, {"k": -0.1}, {"t0": math.nan}])
def test_time_domain_validation(bad):
    values = {"a": 1e-3, "k": 0.03, "t0": 0.2, "Fd": 1e-2, "velocity": 1e-6} | bad
    with pytest.raises(gf.InvalidParameterError, match=next(iter(bad))):
        gf.Params.from_time_domain(**values)


def test_material_constants():
    material = gf.MaterialConstants(mu_a=0.06, mu_d=0.2, alpha=4e4)
    p = gf.Params.from_material(material, normal_load=0.05, x0=2e-7)
    assert (p.a, p.Fd, p.alpha, p.x0) == pytest.approx((3e-3, 1e-2, 4e4, 2e-7))
    assert material.to_dict() == {"mu_a": 0.06, "mu_d": 0.2, "alpha": 4e4}
    with pytest.raises(gf.InvalidParameterError, match="normal_load must be positive"):
        material.params_at(0.0, 1e-7)
    with pytest.raises(gf.InvalidParameterError, match="mu_d must be non-negative"):
        gf.MaterialConstants(mu_a=0.06, mu_d=-0.2, alpha=4e4)


def test_from_mapping_reads_numbers_and_quantities_with_units():
    # 3.31 mN = 3.31e-3 N, 0.198 um = 1.98e-7 m (by hand)
    p = gf.Params.from_mapping({"a": "3.31 mN", "alpha": 41860, "Fd": "10mN", "x0": "0.198 um"})
    assert (p.a, p.alpha, p.Fd, p.x0) == pytest.approx((3.31e-3, 41860, 1e-2, 1.98e-7), rel=1e-15)
    time = gf.Params.from_mapping(
        {
            "params": {
                "a": 3.31e-3,
                "k": "0.036/s",
                "t0": "0.23 s",
                "Fd": 0.01,
                "velocity": "0.86um/s",
            }
        }
    )
    assert time.alpha == pytest.approx(0.036 / 0.86e-6, rel=1e-15)
    assert time.x0 == pytest.approx(0.23 * 0.86e-6, rel=1e-15)


@pytest.mark.parametrize(
    ("values", "match"),
    [
        ([1, 2], "f.yaml: expected a mapping"),
        ({"a": 1, "alpha": 1, "Fd": 1, "x0": 1, "beta": 2}, "unknown parameter.*beta"),
        ({"a": "3mN", "alpha": 4e4}, "missing parameter Fd"),
        ({"a": "3mN", "k": 0.03, "t0": 0.2, "Fd": 0.01}, "missing parameter velocity"),
        ({"a": "3 kg", "alpha": 1, "Fd": 1, "x0": 1}, "f.yaml: a: cannot read"),
        ({"a": 1, "alpha": -1, "Fd": 1, "x0": 1}, "alpha must be positive"),
    ],
)
def test_from_mapping_names_the_source_and_the_culprit(values, match):
    with pytest.raises(gf.InvalidParameterError, match=match):
        gf.Params.from_mapping(values, source="f.yaml")


def test_load_reads_a_yaml_file(tmp_path):
    path = tmp_path / "blue.yaml"
    path.write_text("a: 3.31 mN\nk: 0.036 /s\nt0: 0.23 s\nFd: 10 mN\nvelocity: 0.86 um/s\n")
    p = gf.Params.load(path)
    assert p.k(0.86e-6) == pytest.approx(0.036, rel=1e-14) and p.Fd == pytest.approx(0.01)
    with pytest.raises(gf.InvalidParameterError, match="cannot read the parameters"):
        gf.Params.load(tmp_path / "missing.yaml")
    path.write_text("a: [1\n")
    with pytest.raises(gf.InvalidParameterError, match="not valid YAML"):
        gf.Params.load(path)
