"""Validation and EEVEE captures turn EEVEE's shadows off where no light casts one
(glossy_addon.scenes.casts_shadows): exact, and most of a small render's time in
software GL."""

from .conftest import run_script


def test_shadows_off_change_no_pixel_where_no_light_casts_one(tmp_path, hdri_dir):
    result = run_script("eevee_shadows.py", hdri_dir / "sunset.exr", tmp_path,
                        tmp_path / "r.json")
    assert result["world_sun"] and result["lamp"]
    assert not (result["world_sun_unshadowed"] or result["careful"] or result["lamp_hidden"])
    # No light: the two renders are the same to the bit.
    assert result["no_light_max_difference"] == 0.0 and result["no_light_mean"] > 0.0
    # A sun lamp over the sphere and the plane: its shadow is there, and shows.
    assert result["lamp_max_difference"] > 0.05 * result["lamp_mean"]
    # The objects hidden from shadow rays (EEVEE honours it), or only the world
    # renders (the lamp and the world's sun on): nothing casts a shadow.
    assert not result["no_caster"]
    assert result["no_caster_max_difference"] == 0.0 and result["no_caster_mean"] > 0.0
    assert not result["nothing_to_shadow"]
    assert result["nothing_to_shadow_max_difference"] == 0.0
    assert result["nothing_to_shadow_mean"] > 0.0
