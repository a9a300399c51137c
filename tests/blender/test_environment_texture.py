"""bake's lat-long convention is the one Cycles' Environment Texture node uses."""

import pytest

from tests.blender.conftest import run_script
from tests.conftest import ROOT

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def test_texel_written_by_bake_is_looked_up_in_the_same_direction(tmp_path):
    result = run_script("envtexture_direction.py", ROOT, tmp_path, tmp_path / "r.json")
    for name, view in result["views"].items():
        # Every rendered pixel shows a texel bake predicts for its camera ray
        # (within the 0.005 px the pixel filter can move a ray).
        assert view["consistent"] == 1.0, name
        # Only rays that graze a texel boundary may land on the neighbour
        # (near the poles a column is narrow): most are exact.
        assert view["exact"] >= 0.95, name
        assert view["blue"] == 0.0, name
