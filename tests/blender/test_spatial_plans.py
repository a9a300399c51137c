"""The node reader's per-pixel plans (glossy_addon.node_reader / spatial) for single
BSDFs and Mix / Add trees: which user inputs the attached lookup applies per
pixel, which it takes at one value, and the maps a bake writes."""

import pytest

from tests.blender.conftest import run_script

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("plans")
    return run_script("spatial_plans.py", workdir / "r.json")


def test_a_mix_of_diffuse_and_glossy_keeps_the_colour_texture_and_the_shared_normal(plans):
    mix = plans["Mix Diffuse Glossy"]
    # The diffuse BSDF alone makes the diffuse part: its texture is an exact factor.
    assert mix["spatial"]["colour"]["part"] == "diffuse"
    assert mix["spatial"]["colour"]["exact"] is True
    # Both BSDFs take the same Normal Map: it is the lookup's normal.
    assert "normal" in mix["spatial"]
    assert not any("Normal" in line for line in mix["ignored"])


def test_a_part_made_by_two_bsdfs_keeps_the_texture_s_mean(plans):
    # Two diffuse BSDFs (one textured) and a glossy one: a factor on the diffuse
    # part would scale the untextured BSDF too, so the mean is used and said.
    two = plans["Two Diffuse"]
    assert two["spatial"] == {}
    assert any("taken at its mean" in line for line in two["approximated"])
    # The normal map on one BSDF only cannot be the lookup's normal: listed.
    assert any("Normal" in line for line in two["ignored"])
    # A Glossy BSDF's colour where a Principled makes glossy light too: the mean.
    over = plans["Glossy Over Plastic"]
    assert "colour" not in over["spatial"]
    assert any("taken at its mean" in line for line in over["approximated"])


def test_an_add_tree_blends_the_glossy_bsdf_s_roughness_texture(plans):
    add = plans["Add Rough Glossy"]
    assert add["spatial"]["roughness"]["low"] == pytest.approx(0.2, abs=1e-3)
    assert add["spatial"]["roughness"]["high"] == pytest.approx(0.6, abs=1e-3)
    knots = [r for r, _ in add["maps"]]
    assert knots[0] == pytest.approx(0.2, abs=1e-3) and knots[-1] == pytest.approx(0.6, abs=1e-3)
    assert all(b / a <= 1.25 + 1e-6 for a, b in zip(knots[:-1], knots[1:], strict=True))
    assert add["spatial"]["colour"]["part"] == "glossy"


def test_colour_splits_where_bake_colour_response_applies(plans):
    # A coated metal: maps of the metal at colours 0 and 1 and of the coat alone.
    coated = plans["Coated Metal"]
    assert coated["spatial"]["colour"]["split"] is True
    assert coated["maps"] == [[None, "c0"], [None, "c1"], [None, "coat"]]
    # A plastic's Specular Tint from a chain: maps at tints 0 and 1.
    assert plans["Tinted Plastic"]["maps"] == [[None, "c0"], [None, "c1"]]
    assert "tint" in plans["Tinted Plastic"]["spatial"]
    # A metal with both: the base colour is split, the tint taken at its value.
    both = plans["Metal Colour And Tint"]
    assert both["spatial"]["colour"]["split"] is True and "tint" not in both["spatial"]
    assert any("Specular Tint: driven by 'Gamma'" in line for line in both["approximated"])
    # A Multiscatter GGX Glossy BSDF's colour texture: a white map times the colour
    # and the energy term (bake.colour_response), no map at colour 0.
    multiscatter = plans["Multiscatter Glossy"]
    assert multiscatter["maps"] == [[None, "c1"]]
    assert any("white map times the colour" in line for line in multiscatter["approximated"])
    # A coat tint texture: the glossy part and the coat alone; what lies below the
    # coat is scaled per pixel (bake.colour_response.coat_tint_factor).
    coat_tint = plans["Coat Tint Texture"]
    assert coat_tint["maps"] == [[None, "glossy"], [None, "coat"]]
    assert coat_tint["spatial"]["coat_tint"]["coat"] == 1.0
    assert coat_tint["spatial"]["coat_tint"]["mean"] == pytest.approx([0.4] * 3, abs=1e-6)


def test_a_gltf_packed_image_drives_roughness_and_metallic_through_its_channels(plans):
    # Blender's glTF importer routes one image's G and B channels (roughness,
    # metallic) through a Separate Color node. Until stop 56 the reader followed
    # an image linked straight into Roughness only: the packed roughness was taken
    # at the socket's unlinked 0.5 (a glTF-style sphere in courtyard.exr: 45.2%
    # from Cycles, now 14.2%, native 17.6%; README, "Materials as users have them").
    packed = plans["glTF Packed"]
    # The image holds 8-bit values: within 1/255 of those written.
    roughness = packed["spatial"]["roughness"]
    assert roughness["low"] == pytest.approx(0.3, abs=1 / 255)  # the G channel's range
    assert roughness["high"] == pytest.approx(0.5, abs=1 / 255)
    assert packed["spatial"]["metallic"]["mean"] == pytest.approx(0.75, abs=1e-6)  # B's mean
    baked = float(packed["spec"].split("roughness=")[1].split(",")[0])
    assert baked == pytest.approx(0.4, abs=1 / 255)  # the baked spec at G's mean
    knots = sorted({r for r, _ in packed["maps"] if r is not None})
    assert knots[0] == pytest.approx(0.3, abs=1 / 255)
    assert knots[-1] == pytest.approx(0.5, abs=1 / 255)
    assert any("Roughness" in line and "blended per pixel" in line
               for line in packed["approximated"])
