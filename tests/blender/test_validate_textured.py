"""glossy.validate on materials with textures the lookup applies per pixel: the NumPy
reference follows a Base Color texture (a Cycles emission pass of it, and integrals
at colours 0 and 1 combined as bake.colour_response has it), a bump map (a pass of
the shading normal), a roughness image (a pass of it, integrals at roughness knots
1.1x apart interpolated per pixel) and each face's own material. Before stop 53 it
shaded every pixel at the Base Color socket's unlinked value, with the mesh's
normal and the object's first material: 152% (metal), 104% (dielectric alone) and
86% (bumped metal) from Cycles on these spheres; the dielectric with a metal upper
half 41% with the first material everywhere; the checker metal with a roughness
image 29% with the roughness at its mean (the colour followed)."""

import pytest

from tests.blender.conftest import run_script
from tools.bpy_wheel import studio_lights

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def test_the_reference_follows_a_base_color_texture_per_pixel(tmp_path):
    result = run_script("validate_textured.py", studio_lights() / "forest.exr", tmp_path,
                        tmp_path / "r.json", timeout=900)
    assert all(v == ["FINISHED"] for v in result["steps"].values()), result["steps"]
    notes = result["notes"]
    assert any(note.startswith("Bumpy: the NumPy reference takes each pixel's normal from "
                               "the material's normal or bump map") for note in notes)
    assert not any(note.startswith("Bumpy: the lookup applies") for note in notes)
    assert any(note.startswith("Bumpy: Principled BSDF: Roughness: driven by 'Math'")
               and "unlinked value 0.3 is used" in note for note in notes), notes
    assert "Plastic: 2 Glossy materials; the NumPy reference shades each face with its own" \
        in notes
    assert any(note.startswith("Rough: the NumPy reference follows the roughness texture "
                               "per pixel") for note in notes)
    for name in ("Metal", "Plastic", "Bumpy", "Rough"):
        if name != "Bumpy":
            assert any(note.startswith(f"{name}: the NumPy reference follows Principled "
                                       f"BSDF: Base Color per pixel") for note in notes)
        figures = result["figures"][name]
        noise, reference = figures["cycles_noise"], figures["methods"]["reference"]
        # The bound of tests/blender/test_validate.py: the two-seed Cycles mean's
        # noise plus at most 1%. Measured (128 px): metal 2.05% (noise 1.63%),
        # dielectric with a metal upper half 1.63% (noise 1.83%), bumped metal
        # 2.16% (noise 2.27%), metal with a roughness image 1.66% (noise 1.63%).
        assert reference["relative_rms"] < noise + 0.01, (name, noise, reference)
        assert abs(reference["bias"] - 1.0) < 0.02
    # The checker metal keeps the Hybrid (a colour texture: its map part split at
    # colours 0 and 1, its runtime part scaled per pixel by the split's value over
    # its value at the mean colour): EEVEE Glossy 2.50% from Cycles, where the 3D
    # map (Auto's choice before stop 54) measured 4.38% and the Hybrid with the
    # colour as a plain factor 2.62%; bound: the 3D map's figure less a point.
    # A roughness texture keeps the 3D map (the runtime part has one roughness:
    # the Hybrid measured 24.3% on the Rough sphere).
    assert result["methods"]["Metal"] == "hybrid" and result["methods"]["Rough"] == "3d"
    assert result["figures"]["Metal"]["methods"]["eevee_glossy"]["relative_rms"] < 0.034


def test_metallic_bsdf_materials_are_read_baked_and_validated(tmp_path):
    """Cycles' Metallic BSDF, F82 Tint with a Base Color texture and Physical Conductor
    (gold), both spheres through one call of each operator. Before stop 55 the node
    reader refused the node ("Glossy cannot read the Metallic BSDF")."""
    result = run_script("validate_metallic.py", studio_lights() / "forest.exr", tmp_path,
                        tmp_path / "r.json", timeout=900)
    assert all(v == [["FINISHED"], ""] for v in result["steps"].values()), result["steps"]
    assert "specular_tint=0.7/0.85/1" in result["specs"]["F82"]
    assert "conductor_ior=0.143/0.374/1.442" in result["specs"]["Gold"]
    assert any(note.startswith("F82: the NumPy reference follows Metallic BSDF: Base Color "
                               "per pixel") for note in result["notes"]), result["notes"]
    for name in ("F82", "Gold"):
        assert result["methods"][name] == "hybrid"
        figures = result["figures"][name]
        noise, methods = figures["cycles_noise"], figures["methods"]
        # The reference: tests/blender/test_validate.py's bound (the two-seed
        # mean's noise plus at most 1%). Measured (128 px): F82 1.52% (noise
        # 1.89%), Gold 2.45% (noise 2.31%).
        assert methods["reference"]["relative_rms"] < noise + 0.01, (name, noise, methods)
        # EEVEE with Glossy: measured 2.37% and 2.55%, against the careful native
        # EEVEE's 13.9% and 12.9%: at most half of it (issue 11's bar), and within
        # the noise plus 2 points (the Hybrid's own error at GGX 0.3 in forest:
        # 1.6-2.6%, README "Where the methods stand").
        glossy = methods["eevee_glossy"]["relative_rms"]
        assert glossy < 0.5 * methods["eevee_native_careful"]["relative_rms"], (name, methods)
        assert glossy < noise + 0.02, (name, noise, glossy)


@pytest.fixture(scope="module")
def user_materials(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("user_materials")
    return run_script("validate_emission.py", studio_lights() / "forest.exr", workdir,
                      workdir / "r.json", timeout=900)


def test_what_the_user_s_shaders_emit_stays_in_the_lookup(user_materials):
    """A coated gold panel whose Emission Color is a checker texture, and a red
    Emission shader mixed with a plastic by a Fresnel node (glossy_addon.emission):
    both spheres through one call of each operator, forest.exr. Until stop 56 the
    lookup dropped the emission ("Principled BSDF: emission" ignored): measured
    with it dropped (``without``), 17.0% (Panel, careful native 15.7%) and 89.4%
    (Rim) from Cycles; with it, 4.28% and 0.23%."""
    result = user_materials
    assert all(v == [["FINISHED"], ""] for v in result["steps"].values()), result["steps"]
    assert result["lines"]["Panel"] == [
        "Principled BSDF: emission: not baked; the lookup adds it as Cycles emits it, below "
        "the coat (glossy_addon.emission)"]
    for name in ("Panel", "Rim"):
        assert any(note.startswith(f"{name}: the NumPy reference adds what {name} emits")
                   for note in result["notes"]), result["notes"]
        figures = result["figures"][name]
        noise, methods = figures["cycles_noise"], figures["methods"]
        glossy = methods["eevee_glossy"]["relative_rms"]
        # The reference (the reflection's integral plus the emission pass): within the
        # two-seed mean's noise plus 1% (tests/blender/test_validate.py's bound).
        assert methods["reference"]["relative_rms"] < noise + 0.01, (name, noise, methods)
        assert glossy < 0.5 * methods["eevee_native_careful"]["relative_rms"], (name, methods)
    # The panel's reflection is the coated gold's 3D map (measured 2.95% from its
    # reference, a coat and a metal in one lobe shape); the rim is mostly emission
    # times 1 - F, exact per pixel: within three times Cycles' noise (0.22%).
    panel = result["figures"]["Panel"]
    assert panel["glossy_vs_reference"]["relative_rms"] < 0.05
    rim = result["figures"]["Rim"]
    assert rim["methods"]["eevee_glossy"]["relative_rms"] < 3 * rim["cycles_noise"] + 0.002
    # The unlinked Emission Strength is held at attach; an edit asks for Attach again.
    assert result["changed"] == [False, True]
    assert ["Principled BSDF", "Emission Color", "linked"] in result["emission_set"]
    assert ["Principled BSDF", "Emission Strength", 0.6] in result["emission_set"]


def test_a_gltf_packed_material_is_followed_per_pixel_by_lookup_and_reference(
        user_materials):
    """Roughness and Metallic from one image's G and B channels through a Separate
    Color node, as Blender's glTF importer builds them. Until stop 56 the reader took
    the roughness at the socket's unlinked 0.5 and the reference shaded every pixel
    at the mean metallic (in courtyard.exr: Glossy 45.2%, the reference 68.7% from
    Cycles). Measured here (forest.exr): the reference 1.52% (noise 1.47%), Glossy
    5.92% (6.50% before stop 57's probe lights beside the knots), the careful native
    EEVEE 22.0%."""
    result = user_materials
    assert result["spatial"] == ["metallic", "roughness"]
    # Auto keeps the 3D map for the textures, with the probe's small bright lights
    # beside the knots' maps, shaded at the pixel's roughness (bake.knot_lights).
    bake = result["packed_bake"]
    assert bake["method"] == "3d" and bake["lights_path"].endswith("_3d_lights.exr"), bake
    assert "shaded exactly at the pixel's roughness" in bake["reason"], bake
    assert "Glossy Probe Light v4 varying" in bake["groups"], bake
    assert bake["lights_precision"] == "float32", bake  # light directions unrounded
    notes = result["notes"]
    assert any(note.startswith("Packed: the NumPy reference follows Principled BSDF: "
                               "Metallic per pixel") for note in notes), notes
    assert any(note.startswith("Packed: the NumPy reference follows the roughness texture")
               for note in notes), notes
    figures = result["figures"]["Packed"]
    noise, methods = figures["cycles_noise"], figures["methods"]
    # Exact per pixel (integrals at Metallic 0 and 1 and at roughness knots 1.1x
    # apart): tests/blender/test_validate.py's bound.
    assert methods["reference"]["relative_rms"] < noise + 0.01, (noise, methods)
    glossy = methods["eevee_glossy"]["relative_rms"]
    print(f"\nPacked: Glossy {glossy:.4f}, reference {methods['reference']['relative_rms']:.4f}, "
          f"careful native {methods['eevee_native_careful']['relative_rms']:.4f}")
    assert glossy < 0.5 * methods["eevee_native_careful"]["relative_rms"], methods
    # The 3D map at GGX 0.25-0.55 (README, "Where the methods stand": up to 10.7%
    # on the bundled HDRIs) blended between roughness knots (3.1% at worst,
    # benchmarks/roughness_blend.py): under 12% from the reference.
    assert figures["glossy_vs_reference"]["relative_rms"] < 0.12


def test_an_alpha_mask_cuts_the_lookup_as_it_cuts_cycles(user_materials):
    """A metal whose Principled Alpha is a checker mask (a Math node's Greater Than,
    as a glTF alpha mask): the lookup mixes a Transparent BSDF in by it
    (glossy_addon.transparency), so its holes show the sphere's inside as Cycles'
    do. Until stop 56 Alpha was ignored (the lookup opaque): 99.3% from Cycles;
    now 2.02% (careful native 14.2%). The NumPy reference stays opaque (99.3%;
    the report says so), so only Glossy against Cycles is asserted."""
    result = user_materials
    assert result["alpha"] == [
        "Principled BSDF: Alpha: not baked; the lookup mixes a Transparent BSDF in by it, "
        "as Cycles does (glossy_addon.transparency)"]
    assert any(note.startswith("Cutout: the NumPy reference is opaque")
               for note in result["notes"]), result["notes"]
    figures = result["figures"]["Cutout"]
    noise, methods = figures["cycles_noise"], figures["methods"]
    glossy = methods["eevee_glossy"]["relative_rms"]
    assert glossy < 0.5 * methods["eevee_native_careful"]["relative_rms"], methods
    # The metal's Hybrid at GGX 0.3 in forest (README, "Where the methods stand":
    # 1.6-2.6%) within Cycles' noise: as test_metallic_bsdf_... bounds it.
    assert glossy < noise + 0.02, (noise, glossy)
    # The attach records the Alpha it applies; unlinking it asks for Attach again.
    assert result["cutout_set"] == [["Principled BSDF", "Alpha", "linked"]]
    assert result["alpha_changed"] == [False, True]


def test_a_mix_with_a_transparent_bsdf_cuts_the_lookup_once(user_materials):
    """The older cut-out: a Mix Shader of a Transparent BSDF and a glowing metal, its
    Fac a mask. The reader bakes the metal whole and the lookup mixes the
    Transparent BSDF in by the same Fac (glossy_addon.transparency); the emission
    is weighted by that final mix alone (the mask feeds one lookup node). Until
    stop 56 the reader baked the metal scaled by the mask's unlinked 0.5 and the
    lookup was opaque; opaque with the metal whole (``without``) it measures
    81.4% from Cycles, now 1.84% (careful native 9.55%)."""
    result = user_materials
    assert result["masked_lines"] == [
        "Mix Shader: its Transparent BSDF: not baked; the lookup mixes it in by the same "
        "Fac, as Cycles does (glossy_addon.transparency)"]
    assert result["masked_spec"].startswith("principled:")  # the metal whole, unscaled
    assert result["mask_links"] == ["ShaderNodeMixShader"]
    figures = result["figures"]["Masked"]
    noise, methods = figures["cycles_noise"], figures["methods"]
    glossy = methods["eevee_glossy"]["relative_rms"]
    assert glossy < 0.5 * methods["eevee_native_careful"]["relative_rms"], methods
    assert glossy < noise + 0.02, (noise, glossy)
