"""Checks of a material's Glossy settings that refuse a bake before any work.

Each failure is one BakeError naming the material and the field, raised
before a file is written or a property changed (bake_materials._prepare).
"""

import bpy

from ..bake import brdf, sampling_runtime, separable
from ..bake.errors import BakeError
from ..bake.resolution import MIN_ROWS
from .method_choice import SHADER_LOOPS

#: Rows of the tallest texture a GPU takes (GL_MAX_TEXTURE_SIZE of current
#: desktop GPUs and of Mesa's llvmpipe); an atlas taller than this renders
#: wrong in EEVEE (MEASURED: 5.4% error instead of 0.04%).
TEXTURE_LIMIT = 16384
MAP_SIZE_RANGE = (4, 1024)
SLICES_RANGE = (2, 256)


def atlas_rows(method: str, slices: int, lobes: int, rows: int) -> int:
    """Height (texels) of the atlas a bake of ``rows`` lat-long rows packs (bake.atlas)."""
    if method in ("3d", "hybrid"):
        return slices * lobes * (rows + 2)
    if method == "2d":
        return rows + 2
    return 0  # split-sum: a cube MIP strip; runtime: at most 11 x 1026 rows (checks above)


def check_settings(material) -> None:
    """Raise BakeError if ``material.glossy`` cannot be baked as it stands."""
    settings = material.glossy
    low, high = MAP_SIZE_RANGE
    kind = "the map size's upper bound" if settings.size_mode == "AUTO" else "map size"
    if not low <= settings.map_size <= high:
        raise BakeError(f"{material.name}: {kind} must be in [{low}, {high}], "
                        f"not {settings.map_size}")
    low, high = SLICES_RANGE
    if not low <= settings.slices <= high:
        raise BakeError(f"{material.name}: slices must be in [{low}, {high}], "
                        f"not {settings.slices}")
    if 0.0 < settings.fresnel_ior <= 1.0:
        raise BakeError(f"{material.name}: Fresnel IOR {settings.fresnel_ior:g} has no "
                        f"meaning here: use an index above 1 (glass 1.5), or 0 for a plain "
                        f"sum of glossy and diffuse")
    method = settings.method_used()
    lobes = settings.lobes if method in ("3d", "hybrid") else 1
    if settings.size_mode == "FIXED":
        rows = atlas_rows(method, settings.slices, lobes, settings.map_size)
        if rows > TEXTURE_LIMIT:
            fits = TEXTURE_LIMIT // (settings.slices * lobes) - 2
            raise BakeError(
                f"{material.name}: {settings.slices} slices x {lobes} lobe(s) of "
                f"{settings.map_size} rows make a {rows}-row texture, past the GPU's "
                f"{TEXTURE_LIMIT}-row limit (EEVEE would render it wrong): use a map size "
                f"of at most {fits}, fewer slices, or Auto")
    elif method in ("3d", "hybrid") and \
            atlas_rows("3d", settings.slices, lobes, MIN_ROWS) > \
            TEXTURE_LIMIT:
        raise BakeError(f"{material.name}: {settings.slices} slices x {lobes} lobes do not "
                        f"fit the GPU's {TEXTURE_LIMIT}-row texture limit at any map size")
    model = brdf.parse(settings.brdf_spec())  # a bad spec: refused here, with its message
    if method in ("runtime", "hybrid"):
        if bpy.app.version < SHADER_LOOPS:
            raise BakeError(f"{material.name}: the {method} method's shader loop needs "
                            f"Blender {'.'.join(map(str, SHADER_LOOPS))} or newer (choose the "
                            f"3D Map)")
        try:
            sampling_runtime.check(model.spec, settings.samples)
        except BakeError as error:
            raise BakeError(f"{material.name}: {method} method: {error} (choose the "
                            f"3D Map)") from None
    if settings.lamps:
        try:
            separable.check_arguments(settings.lamp_size, settings.lamp_terms,
                                      settings.lamp_parameterization, "xy",
                                      settings.lamp_method, 2.0, settings.lamp_size_h)
        except BakeError as error:
            raise BakeError(f"{material.name}: lamp factors: {error}") from None
