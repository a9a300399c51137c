"""Materials as users have them: shared by objects with their own probes, and
textured (base colour, normal map, roughness texture), in EEVEE against Cycles."""

import pytest

from tests.blender.conftest import run_script

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("shared")
    return run_script("shared_probes.py", workdir, workdir / "r.json")


def test_each_object_sharing_a_material_reflects_its_own_probe(shared):
    for step in shared["a"] + shared["b"] + shared["b_again"]:
        assert step[0] == ["FINISHED"], step
    # A baked first and kept the material; B, whose probe differs, got a copy.
    assert shared["materials"] == {"A": "Chrome", "B": "Chrome (B)"}
    # Constant worlds: the reflection is the world's colour times the GGX 0.3
    # albedo (~0.98), so each sphere's dominant channel names its own probe.
    red, blue = shared["first"]["A"], shared["first"]["B"]
    assert red[0] > 10 * max(red[1], red[2]) and blue[2] > 10 * max(blue[0], blue[1])


def test_recapturing_one_object_leaves_the_other_unchanged(shared):
    green = shared["second"]["B"]
    assert green[1] > 10 * max(green[0], green[2])  # B shows its new probe...
    assert shared["a_pixels"] > 500
    assert shared["a_max_change"] == 0.0  # ...and A's pixels are bit for bit the same


@pytest.fixture(scope="module")
def textured(tmp_path_factory, hdri_dir):
    workdir = tmp_path_factory.mktemp("textured")
    return run_script("textured_material.py", hdri_dir / "forest.exr", workdir,
                      workdir / "r.json")


def test_a_textured_material_keeps_its_textures_and_stays_close_to_cycles(textured):
    plain, mapped = textured["Plain"], textured["Textured"]
    for name in ("Plain", "Textured"):
        assert [s[0] for s in textured[name]["steps"]] == [["FINISHED"]] * 4, textured[name]
    notes = "\n".join(mapped["approximated"])
    assert "Base Color: applied per pixel as a factor of the diffuse part" in notes
    assert "Normal: the linked normal (normal or bump map) feeds the lookup's normal" in notes
    assert "Roughness: varies from 0.2 to 0.6" in notes
    # The user's texture nodes stay in the attached material, untouched.
    assert mapped["user_nodes"] == ["ShaderNodeBsdfPrincipled", "ShaderNodeNormalMap",
                                    "ShaderNodeOutputMaterial"] + ["ShaderNodeTexImage"] * 3
    knots = mapped["knots"]
    assert knots[0] == pytest.approx(0.2, abs=0.01) and knots[-1] == pytest.approx(0.6, abs=0.01)
    assert all(b / a <= 1.25 + 1e-6 for a, b in zip(knots[:-1], knots[1:], strict=True))
    print(f"\nrelative RMS against Cycles: textured {mapped['glossy']:.4f} (native "
          f"{mapped['native']:.4f}), without textures {plain['glossy']:.4f} (native "
          f"{plain['native']:.4f}); Cycles noise {mapped['noise']:.4f}")
    # Measured (forest, 80 px): textured 14.1%, untextured 10.8%, native 21.2%.
    assert mapped["glossy"] < 1.5 * plain["glossy"]
    assert mapped["glossy"] < mapped["native"]


def test_the_roughness_blend_s_own_error_is_small(textured):
    for low, high, error in textured["blend_errors"]:
        print(f"roughness blend {low:.3f}-{high:.3f}: relative RMS {error:.4f} at the midpoint")
    # benchmarks/roughness_blend.py: worst 3.1% over the bundled HDRIs at knot
    # ratio 1.25 (roughness 0.1, studio.exr); measured here 1.0-1.7%.
    assert max(error for _, _, error in textured["blend_errors"]) < 0.031


@pytest.fixture(scope="module")
def textured_metal(tmp_path_factory, hdri_dir):
    workdir = tmp_path_factory.mktemp("textured_metal")
    return run_script("textured_material.py", hdri_dir / "sunset.exr", workdir, "metal",
                      workdir / "r.json")


def test_a_textured_metal_s_colour_is_split_exactly_and_stays_close_to_cycles(textured_metal):
    plain, mapped = textured_metal["Plain"], textured_metal["Textured"]
    for name in ("Plain", "Textured"):
        assert [s[0] for s in textured_metal[name]["steps"]] == [["FINISHED"]] * 4, \
            textured_metal[name]
    notes = "\n".join(mapped["approximated"])
    assert "Base Color: applied per pixel to the metal through maps baked at base colours " \
           "0 and 1" in notes
    # Two maps (base colour 0 and 1) at each roughness knot.
    assert mapped["colours"] == ["c0", "c1"] and len(mapped["knots"]) >= 2
    assert mapped["maps"] == 2 * len(mapped["knots"])
    print(f"\nmetal, relative RMS against Cycles: textured {mapped['glossy']:.4f} (native "
          f"{mapped['native']:.4f}), without textures {plain['glossy']:.4f} (native "
          f"{plain['native']:.4f}); Cycles noise {mapped['noise']:.4f}")
    # The bound for a textured material (within 1.5x of the same material
    # without textures, below native EEVEE). Measured (sunset, 80 px): textured
    # 19.9%, untextured 21.7%, native 20.9%: Suzanne's self-reflection dominates
    # both, so this bound does not tell the split from the ratio (19.4% forced);
    # the node-chain test below does.
    assert mapped["glossy"] < 1.5 * plain["glossy"]
    assert mapped["glossy"] < mapped["native"]


@pytest.fixture(scope="module")
def colour_split(tmp_path_factory, hdri_dir):
    workdir = tmp_path_factory.mktemp("colour_split")
    return run_script("colour_split.py", hdri_dir / "sunset.exr", workdir, workdir / "r.json")


def test_a_metal_colour_from_a_node_chain_renders_as_the_colour_typed_in(colour_split):
    direct, chain = colour_split["Direct"], colour_split["Chain"]
    for name in ("Direct", "Chain", "Mix Direct", "Mix Chain",
                 "Coat Direct", "Coat Chain", "Metallic Chain", "Half Direct", "Half Chain",
                 "Glossy Direct", "Glossy Chain", "Coat Tint Direct", "Coat Tint Chain"):
        assert [s[0] for s in colour_split[name]["steps"]] == [["FINISHED"]] * 4, \
            colour_split[name]
    assert chain["colours"] == ["c0", "c1"] and direct["colours"] == []
    print(f"\nmetal 0.3, dark green: typed in {direct['glossy']:.4f}, through a chain baked "
          f"grey and split per pixel {chain['glossy']:.4f} (native {direct['native']:.4f}; "
          f"Cycles noise {direct['noise']:.4f})")
    # The split is exact (tests/bake/test_colour_response.py), so the chain's error
    # is the typed-in material's: measured 3.52% and 3.53% (sunset, 64 px). The
    # ratio (the grey map scaled by colour / grey) measured 7.8% here
    # (colour_split.py ratio): the bound sits between, at twice Cycles' noise
    # above the typed-in error.
    assert abs(chain["glossy"] - direct["glossy"]) < 2 * direct["noise"]
    assert chain["glossy"] < direct["native"]
    # A Mix Shader of a Diffuse BSDF (colour through the chain, grey unlinked) and a
    # Glossy BSDF: the diffuse part's factor (measured 3.46% both ways; the grey
    # alone would be 3-16x too bright in every channel).
    mixed, mixed_typed = colour_split["Mix Chain"], colour_split["Mix Direct"]
    assert mixed["spatial"] == ["colour"]
    assert abs(mixed["glossy"] - mixed_typed["glossy"]) < 2 * mixed_typed["noise"]
    # Under a coat (Coat Weight 1, coat roughness 0.03): maps of the metal alone at
    # colours 0 and 1 and of the coat alone, C + W(mu) (R_0 + c (R_1 - R_0)) m.
    # Each map holds one lobe shape, so the chain measured 10.1% where the
    # colour typed in (one map of narrow coat plus metal, fitted as one lobe)
    # measured 15.8% (the c / grey factor 22.9%); native EEVEE 4.6% (the coat's
    # near-mirror lobe is wider in a 256-row map than in Cycles).
    coated, coated_typed = colour_split["Coat Chain"], colour_split["Coat Direct"]
    assert coated["maps"] == ["c0", "c1", "coat"]
    assert coated["glossy"] < coated_typed["glossy"] + 2 * coated_typed["noise"]


def test_a_metallic_texture_mixes_maps_at_metallic_0_and_1(colour_split):
    # Metallic 1 and the dark green both through chains whose unlinked values are 0
    # and grey: the bake's spec is a grey dielectric, the lookup mixes the maps at
    # Metallic 0 and 1 per pixel (the metal's colour split) and scales the diffuse
    # part by (1 - metallic) / (1 - 0). Measured 3.52%, as "Direct" (3.53%); the
    # dielectric at the unlinked values measured 74%.
    metal, direct = colour_split["Metallic Chain"], colour_split["Direct"]
    assert metal["maps"] == ["dielectric", "c0", "c1"]
    assert metal["spatial"] == ["colour", "metallic"]
    assert abs(metal["glossy"] - direct["glossy"]) < 2 * direct["noise"]
    # A half metal (Metallic 0.5) through a chain whose unlinked value is 0, against
    # the same typed in: both measured 2.33% (native 5.35%; unlinked value: 36.6%).
    half, typed = colour_split["Half Chain"], colour_split["Half Direct"]
    assert half["maps"] == ["dielectric", "metal"]
    assert abs(half["glossy"] - typed["glossy"]) < 2 * typed["noise"]
    assert half["glossy"] < half["native"]
    # A Multiscatter GGX Glossy BSDF (roughness 0.5) whose Color comes through a
    # chain: a white single-scatter map times c and the energy term, measured
    # 7.72% as the colour typed in (7.72%). The c / grey factor measured 5.79%:
    # the typed-in map is itself 5% dark against Cycles here (bias 0.946), and
    # the factor's error happens to offset it; the split equals the typed-in
    # material, which is what it claims.
    ms, ms_typed = colour_split["Glossy Chain"], colour_split["Glossy Direct"]
    assert ms["maps"] == ["c1"]
    assert abs(ms["glossy"] - ms_typed["glossy"]) < 2 * ms_typed["noise"]
    # A coat tint through a chain (unlinked white) over a light grey plastic: the
    # glossy part's map and the coat's alone, below the coat scaled per pixel by
    # T(tint, n.v) / T(white, n.v), the diffuse part too. Measured 1.50% against
    # 1.41% typed in (native 10.4%).
    coat_tint, coat_typed = colour_split["Coat Tint Chain"], colour_split["Coat Tint Direct"]
    assert coat_tint["maps"] == ["glossy", "coat"] and coat_tint["spatial"] == ["coat_tint"]
    assert abs(coat_tint["glossy"] - coat_typed["glossy"]) < 2 * coat_typed["noise"]
