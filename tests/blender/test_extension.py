"""The built extension zip installs into a clean Blender user directory and behaves."""

import zipfile

import pytest

from tests.blender.conftest import run_script

pytestmark = pytest.mark.blender


def test_zip_keeps_dev_files_out_and_bundles_openexr(extension_zip):
    names = zipfile.ZipFile(extension_zip).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert any(n.startswith("bake/envmap/") for n in names)
    assert not any(n.startswith(("tests/", "benchmarks/", "tools/", ".ci/", ".venv/"))
                   for n in names)
    assert "Makefile" not in names and "requirements.txt" not in names
    wheels = [n for n in names if n.startswith("wheels/openexr-")]
    assert any("manylinux" in n and "x86_64" in n for n in wheels)
    assert any("win_amd64" in n for n in wheels)
    assert any("macosx" in n and "arm64" in n for n in wheels)


def test_install_enable_disable_reenable(extension_zip, tmp_path):
    user = tmp_path / "user"
    user.mkdir()
    result = run_script("install_extension.py", extension_zip, tmp_path / "r.json", user_dir=user)
    assert result["user_resources"] == str(user)
    assert result["install"] == ["FINISHED"]
    everything = {"operators": True, "panels": True, "scene_settings": True, "enabled": True}
    nothing = dict.fromkeys(everything, False)
    assert result["after_install"] == everything
    assert result["module_file"].startswith(str(user))
    # The OpenEXR that the installed extension uses is the wheel from its zip.
    assert result["openexr"].startswith(str(user))
    assert result["poll_without_image"] is False
    assert result["after_disable"] == nothing
    assert result["after_reenable"] == everything
    assert result["after_second_cycle"] == everything


def test_export_operator_as_a_script_uses_it(extension_zip, hdri_dir, tmp_path):
    user = tmp_path / "user"
    user.mkdir()
    result = run_script("export_operator.py", extension_zip, hdri_dir / "forest.exr", tmp_path,
                        tmp_path / "r.json", user_dir=user)
    assert result["poll_no_image"] is False and result["poll_with_image"] is True

    unsaved = result["unsaved"]
    assert unsaved["status"] == ["FINISHED"]
    assert unsaved["path"].startswith(str(user))
    assert unsaved["shape"] == [32, 192, 3] and unsaved["meta_layout"] == "cube"
    assert unsaved["files"] == ["forest_cube32.exr"] + [f"forest_cube32.mip{k}.exr"
                                                       for k in range(1, 6)]
    # Blender decodes the DWAB file to the same floats as OpenEXR; what remains
    # is float32 summation order (relative 1e-6 of the peak).
    assert unsaved["max_abs_diff_over_peak"] < 1e-5

    assert result["saved"]["status"] == ["FINISHED"]
    assert result["saved"]["path"] == str(tmp_path / "glossy" / "forest_paraboloid16.exr")

    assert result["foreign"]["status"] is None
    assert "not written by Glossy" in result["foreign"]["error"]
    assert result["foreign"]["unchanged"] is True
    assert "too large" in result["too_large"]["error"]
    assert "MIP pyramids" in result["mip_on_sphere"]["error"]
    assert result["files_unchanged"] is True
    assert result["still_usable"] is True
