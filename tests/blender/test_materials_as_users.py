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


def test_one_bake_and_attach_for_the_whole_selection(shared):
    together = shared["together"]
    # C alone: no probe, refused with one message; in the selection it is skipped.
    assert together["only_c"] == [["CANCELLED"], "Error: C has no probe yet: capture one "
                                                 "first"]
    assert together["steps"] == [[["FINISHED"], ""], [["FINISHED"], ""]]
    assert together["plain_path"] == ""
    # Each sphere's material baked in that one call, against its own probe.
    for name, baked in together["baked"].items():
        assert baked["object"] == name and baked["status"] == "up to date", baked
        assert baked["roughness"] == pytest.approx(0.5)
        # Auto within Max Map Size 384: a constant world's probe holds no detail
        # finer than one texel per face (bake.probe_content), so the map takes the
        # fewest rows and the panel says why (the texel rule: 72 rows from these
        # 16 px probes).
        assert baked["chosen_size"] == 16, baked
        assert "the probe's content, no more detailed than a 1 px cube" in \
            baked["size_reason"], baked
    red, green = together["means"]["A"], together["means"]["B"]
    assert red[0] > 10 * max(red[1], red[2]) and green[1] > 10 * max(green[0], green[2])
    # A constant world reflects its colour times the GGX albedo at n.v: A's red
    # against the albedo at Roughness 0.5 (the Hybrid's runtime part is exact for a
    # constant world, up to the half-float atlas and its albedo table's
    # interpolation, both under 0.1%). 1% is 10x below the change from 0.3 to
    # 0.5 (0.976 -> 0.882), so a bake at the old roughness or another probe fails.
    assert red[0] == pytest.approx(together["a_red_expected"], rel=0.01)
    assert shared["first"]["A"][0] > 1.05 * red[0]


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


#: (input through a chain, the same typed in, maps the chain's bake writes, its
#: per-pixel inputs), with what each measured (sunset, 64 px spheres validated
#: together through an orthographic camera, Cycles 2 x 256 spp; the fixture now
#: renders 2 x 128 spp, where the pairs differ by 0.1-0.4 points against a
#: Cycles noise of 0.9-1.8%; "before" was
#: measured with each sphere alone and framed from above, by colour_split.py ...
#: ratio: the c / grey factor or the unlinked value):
CHAIN_CASES = [
    # A metal's colour: maps at base colours 0 and 1 and the energy term.
    # 3.61% / 3.55% (native 5.28%; before 7.8%) with the 3D map; since stop 54
    # both take the Hybrid (its runtime part scaled by the split's colour
    # response): 3.00% / 2.97% (native 5.62%).
    ("Chain", "Direct", ["c0", "c1"], ["colour"]),
    # A Mix Shader of a Diffuse BSDF (colour through the chain) and a Glossy BSDF:
    # the diffuse part's factor. 3.29% / 3.31%.
    ("Mix Chain", "Mix Direct", [], ["colour"]),
    # Metallic 1 and the colour through chains whose unlinked values are 0 and
    # grey: maps at Metallic 0 and 1 mixed per pixel, the metal's colour split,
    # the diffuse part scaled by (1 - m) / (1 - 0). 3.51% (before 74%).
    ("Metallic Chain", "Direct", ["dielectric", "c0", "c1"], ["colour", "metallic"]),
    # A half metal through a chain whose unlinked value is 0. 2.47% / 2.54%
    # (native 5.96%; before 36.6%).
    ("Half Chain", "Half Direct", ["dielectric", "metal"], ["metallic"]),
    # A Multiscatter GGX Glossy BSDF's colour: a white single-scatter map times c
    # and the energy term. 7.61% / 7.58%. The c / grey factor measured 5.79%:
    # the typed-in map is itself 3.5-5% dark against Cycles here (bias 0.965; 0.946
    # seen from above) and the factor's error happens to offset it; the split
    # equals the typed-in material, which is what it claims.
    ("Glossy Chain", "Glossy Direct", ["c1"], ["colour"]),
    # A coat tint (unlinked white) over a light grey plastic: the glossy part's map
    # and the coat's alone, below the coat scaled by T(tint, n.v) / T(white, n.v).
    # 1.82% against 1.54% (native 10.9%).
    ("Coat Tint Chain", "Coat Tint Direct", ["glossy", "coat"], ["coat_tint"]),
]


@pytest.mark.parametrize("chain_name, typed_name, maps, spatial", CHAIN_CASES,
                         ids=[case[0] for case in CHAIN_CASES])
def test_an_input_through_a_node_chain_renders_as_the_value_typed_in(
        colour_split, chain_name, typed_name, maps, spatial):
    chain, typed = colour_split[chain_name], colour_split[typed_name]
    for result in (chain, typed):
        assert [s[0] for s in result["steps"]] == [["FINISHED"]] * 4, result
    assert chain["maps"] == maps and chain["spatial"] == spatial
    print(f"\n{chain_name}: {chain['glossy']:.4f}, {typed_name}: {typed['glossy']:.4f} "
          f"(native {typed['native']:.4f}; Cycles noise {typed['noise']:.4f})")
    # The splits and factors are exact (tests/bake/test_colour_response.py), so the
    # chain's error is the typed-in material's, within twice Cycles' noise (the
    # previous paths measured above sit well outside it).
    assert abs(chain["glossy"] - typed["glossy"]) < 2 * typed["noise"]
    assert chain["glossy"] < chain["native"]


def test_validation_without_the_numpy_reference_measures_against_cycles_alone(colour_split):
    # colour_split validates with the panel's NumPy Reference off: no reference step,
    # image or figure, the report says so, and every figure against Cycles is there.
    report = colour_split["report"]
    assert report["reference"] is None and "reference.exr" not in report["files"]
    assert not [name for name in report["timings"] if name.startswith("reference")]
    assert "reference" not in report["figures"] and "glossy_vs_reference" not in report["figures"]
    assert {"eevee_glossy", "eevee_native", "cycles_noise"} <= set(report["figures"])
    assert any("NumPy reference was off" in note for note in report["notes"])


def test_a_coated_metal_s_colour_split_beats_its_one_map_bake(colour_split):
    # Under a coat (Coat Weight 1, coat roughness 0.03): maps of the metal alone at
    # colours 0 and 1 and of the coat alone, C + W(mu) (R_0 + c (R_1 - R_0)) m.
    # Each map holds one lobe shape, so the chain measured 13.6% where the
    # colour typed in (one map of narrow coat plus metal, fitted as one lobe)
    # measured 21.5%; native EEVEE 5.0%: the near-mirror coat reflects sunset's
    # sun from this test's 64 px probe (at Auto's 256 px probe: 2.1% and 4.1%,
    # README). Those are at pixel centres, as validation renders EEVEE since
    # stop 32; with EEVEE's 1.5 px film filter they were 6.9% and 9.6%.
    coated, typed = colour_split["Coat Chain"], colour_split["Coat Direct"]
    for result in (coated, typed):
        assert [s[0] for s in result["steps"]] == [["FINISHED"]] * 4, result
    assert coated["maps"] == ["c0", "c1", "coat"]
    # The probe, not the map, is what limits the coat here, and the capture says so
    # (bake.resolution.fixed_face_reason: Auto's face for the coat's lobe, capped
    # by sunset.exr's own detail).
    for result in (coated, typed):
        reason = result["probe_reason"]
        assert reason.startswith("64 px faces: set by hand; Auto would capture "), reason
        assert int(reason.split("Auto would capture ")[1].split(" px")[0]) >= 256, reason
    assert coated["glossy"] < typed["glossy"] + 2 * typed["noise"]
