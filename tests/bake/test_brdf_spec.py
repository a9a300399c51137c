"""Spec strings: parsing, canonical form, stable hashes, clear errors; Cycles' parameter maps."""

import subprocess
import sys

import numpy as np
import pytest

from bake import brdf
from bake.brdf.cycles import cycles_alphas
from tests.bake.test_brdf_models import SPECS
from tests.conftest import ROOT


@pytest.mark.parametrize("spec", SPECS)
def test_canonical_spec_round_trips(spec):
    model = brdf.parse(spec)
    again = brdf.parse(model.spec)
    assert again == model and again.spec == model.spec
    assert again.spec_hash() == model.spec_hash()
    wi, wo = np.array([0.3, 0.2, 0.93]), np.array([-0.4, 0.1, 0.91])
    np.testing.assert_array_equal(again.f(wi, wo), model.f(wi, wo))
    assert model.spec in repr(model)


def test_hash_is_stable_across_processes_and_sensitive_to_values():
    spec = "ggx:roughness=0.3,anisotropy=0.5"
    here = brdf.parse(spec).spec_hash()
    code = f"from bake import brdf; print(brdf.parse({spec!r}).spec_hash())"
    there = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                           text=True, check=True).stdout.strip()
    assert here == there
    assert brdf.parse("ggx:roughness=0.3,anisotropy=0.5000001").spec_hash() != here
    assert brdf.parse("ggx:anisotropy=0.5,roughness=0.3").spec_hash() == here


@pytest.mark.parametrize(("spec", "message"), [
    ("plastic:roughness=0.3", "unknown BRDF 'plastic'"),
    ("ggx:roughnes=0.3", "unknown key 'roughnes'"),
    ("ggx:roughness=1.5", "roughness=1.5 is out of range [0.01, 1]"),
    ("ggx:roughness=abc", "roughness='abc' is not a number"),
    ("ggx:roughness=nan", "out of range"),
    ("ggx:roughness=0.3,alpha=0.2", "give roughness, alpha or ax/ay"),
    ("ggx:ax=0.2", "ax and ay go together"),
    ("ggx:alpha=0.2,anisotropy=0.5", "anisotropy goes with roughness"),
    ("ward:alpha=0.1,ax=0.2,ay=0.1", "alpha or ax/ay"),
    ("phong:n=-3", "n=-3 is out of range"),
    ("lambert:color=0.1/0.2", "one number or three"),
    ("ggx:roughness", "expected key=value"),
    ("ggx:roughness=0.3,roughness=0.4", "given twice"),
    ("layer(ior=0.5; lambert; lambert)", "ior=0.5 is out of range"),
    ("sum(lambert; ggx:roughness=2)", "out of range"),
    ("sum(lambert; (ggx)", "unbalanced"),
    ("", "non-empty"),
    ("merl:file=/no/such/file.binary", "no such file"),
])
def test_bad_specs_name_the_problem(spec, message):
    with pytest.raises(brdf.SpecError, match=message.replace("[", r"\[").replace("(", r"\(")):
        brdf.parse(spec)


def test_cycles_anisotropy_mapping():
    """CYCLES.md: alpha = r^2; A > 0: ax = a(1 - A), ay = a / (1 - A); A < 0 mirrored; clamps."""
    assert cycles_alphas(0.5, 0.0) == (0.25, 0.25)
    assert cycles_alphas(0.5, 0.5) == pytest.approx((0.125, 0.5))
    assert cycles_alphas(0.5, -0.5) == pytest.approx((0.5, 0.125))
    assert cycles_alphas(0.5, 0.8) == pytest.approx((0.05, 1.0))  # ay clamped to 1
    assert cycles_alphas(0.5, 1.0) == pytest.approx((0.0025, 1.0))  # A clamped to 0.99
    assert cycles_alphas(0.5, 5e-5) == (0.25, 0.25)  # |A| <= 1e-4 is isotropic


def test_ggx_matches_the_isotropic_closed_form():
    """D = alpha^2 / (pi ((1 - ch^2) + alpha^2 ch^2)^2), G2 from Lambda, f = D G2 / (4 cv cl)."""
    model = brdf.parse("ggx:roughness=0.4")
    alpha = 0.16
    wi = np.array([[0.3, -0.2, 0.932737905], [0.8, 0.1, 0.591607978]])
    wo = np.array([[-0.5, 0.1, 0.860232527], [0.0, -0.6, 0.8]])
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    ch = h[:, 2]
    d = alpha**2 / (np.pi * ((1 - ch**2) + alpha**2 * ch**2) ** 2)

    def lam(w):
        tan2 = (1 - w[:, 2] ** 2) / w[:, 2] ** 2
        return (np.sqrt(1 + alpha**2 * tan2) - 1) / 2

    expected = d / (1 + lam(wi) + lam(wo)) / (4 * wi[:, 2] * wo[:, 2])
    np.testing.assert_allclose(model.f(wi, wo)[:, 0], expected, rtol=1e-9)  # float64 reordering


def test_rotation_turns_the_anisotropy_axes_counter_clockwise():
    base = brdf.parse("ggx:roughness=0.5,anisotropy=0.7")
    turned = brdf.parse("ggx:roughness=0.5,anisotropy=0.7,rotation=0.25")
    wi, wo = np.array([0.6, 0.1, 0.7937]), np.array([-0.3, 0.4, 0.8660])
    quarter = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])  # +90 degrees about z
    np.testing.assert_allclose(turned.f(quarter @ wi, quarter @ wo), base.f(wi, wo), rtol=1e-9)


def test_models_lists_every_name():
    names = brdf.models()
    for name in ("lambert", "phong", "blinn_phong", "ward", "cook_torrance", "ggx", "beckmann",
                 "ashikhmin_shirley", "principled_metallic", "ggx_multiscatter", "kurt",
                 "lafortune", "sum", "layer", "table", "merl"):
        assert name in names
