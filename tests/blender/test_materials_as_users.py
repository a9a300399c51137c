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
