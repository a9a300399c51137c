"""A large lookup is built in private node groups of bounded size (glossy_addon.nodes:
each node edit in Blender 5.0 updates its whole tree, so one tree of a thousand nodes
took 8.5 s to attach), and those groups live and die with the lookup: a validation's
truth copy, a re-attach and glossy.clear leave no group behind and never one that a
material still uses. That the split lookup renders what the NumPy twin computes is
tests/blender/test_runtime_nodes.py's knot-lights test (its lookup is split too)."""

import pytest

from tests.blender.conftest import run_script

pytestmark = pytest.mark.blender


def test_a_large_lookup_lives_in_bounded_private_groups(tmp_path, hdri_dir):
    r = run_script("lookup_parts.py", hdri_dir / "forest.exr", tmp_path, tmp_path / "r.json")
    print(f"\nattach {r['attach_s']:.2f} s, re-attach {r['reattach_s']:.2f} s")
    assert r["capture"] == r["bake"] == r["attach"] == ["FINISHED"]
    attached = r["attached"]
    # Seven roughness knots, each map split at Base Color 0 and 1: the whole lookup
    # (983 nodes when written) is there, counted through its groups.
    assert attached["maps"] == 14 and attached["lookup"] > 900
    # No tree holds more than a map's lookup and its colour split past the threshold
    # (at most 117 nodes when written; one tree of 983 before).
    assert len(attached["part_nodes"]) >= 5
    assert max(attached["root"], *attached["part_nodes"]) <= 150
    assert attached["used_parts"] == attached["parts"] and attached["user_nodes"]
    # The truth copy validation renders: the user's nodes alone, and stripping it
    # leaves the original's groups (still used) in place.
    copy = r["copy"]
    assert copy["lookup"] == 0 and copy["parts"] == attached["parts"]
    assert copy["nodes"] == ["ShaderNodeBsdfPrincipled", "ShaderNodeOutputMaterial",
                             "ShaderNodeTexChecker", "ShaderNodeTexImage"]
    # A re-attach replaces the groups (none left over from the first) ...
    assert r["reattach"] == ["FINISHED"]
    again = r["reattached"]
    assert again["used_parts"] == again["parts"]
    assert len(again["parts"]) == len(attached["parts"]) and again["lookup"] == attached["lookup"]
    # ... and Clear removes them with the lookup, the user's nodes kept.
    assert r["clear"] == ["FINISHED"]
    cleared = r["cleared"]
    assert cleared["parts"] == [] and cleared["lookup"] == 0 and cleared["user_nodes"]


def test_a_split_lookup_renders_the_pixels_of_one_tree(tmp_path, hdri_dir):
    """The same lookups attached split into private groups and in one tree render the
    same pixels, to the bit: a 3D map with its colour split through a node chain,
    split after every 12 nodes (EEVEE and Cycles), and a Hybrid with a checker's
    colour split, its runtime part and its probe lights' repeat zones, split where
    Glossy splits it (EEVEE; Cycles' SVM stack cannot hold this lookup, split or
    not). Written when an early version put the Material Output in a group (the
    chain 7% off in EEVEE, 45% in Cycles)."""
    from bake import exr

    r = run_script("split_render.py", hdri_dir / "sunset.exr", tmp_path, tmp_path / "r.json")
    assert r["capture"] == ["FINISHED"] and r["steps"] == [["FINISHED"]] * 6
    assert r["Chain"]["method"] == "3d" and r["Checker"]["method"] == "hybrid"
    for name, parts in (("Chain", 2), ("Checker", 1)):
        split, whole = r[name]["split"], r[name]["whole"]
        assert len(split["parts"]) >= parts and whole["parts"] == []
        assert split["lookup"] == whole["lookup"] > 60
    for engine, name in (("eevee", "Chain"), ("eevee", "Checker"), ("cycles", "Chain")):
        split = exr.read(r[engine][f"{name} split"])[0]
        whole = exr.read(r[engine][f"{name} whole"])[0]
        assert whole[..., :3].max() > 0.1, (engine, name)
        assert (split == whole).all(), (engine, name)
