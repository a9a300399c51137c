"""The demo (``make demo``): Blender's bundled forest.exr through Glossy's map core.

Writes to out/demo/:
- forest_cube256.exr, forest_paraboloid256.exr, forest_sphere256.exr
  (DESIGN.md layouts, parameters in the EXR header);
- forest_cube256.mip<k>.exr, the solid-angle-weighted gauss4 MIP pyramid;
- contact_sheet.png, tonemapped for viewing only: top row lat-long source,
  sphere map and dual paraboloid; then the cube strip (+X -X +Z -Z -Y +Y);
  then MIP levels 2 to 6 of the cube, enlarged to the same size.
"""

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import exr, preview  # noqa: E402
from bake.envmap import convert, radiant_power  # noqa: E402
from bake.envmap.mip import pyramid  # noqa: E402
from bake.progress import LinePrinter  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

SIZE = 256


def main() -> int:
    out = ROOT / "out" / "demo"
    out.mkdir(parents=True, exist_ok=True)
    source_path = studio_lights() / "forest.exr"
    start = time.perf_counter()
    image, _ = exr.read(source_path)
    print(f"read {source_path} ({image.shape[1]}x{image.shape[0]} lat-long)")
    written = []
    maps = {}
    for layout in ("cube", "paraboloid", "sphere"):
        maps[layout] = convert(image, "latlong", layout, SIZE, progress=LinePrinter())
        path = out / f"forest_{layout}{SIZE}.exr"
        exr.write(path, maps[layout], {"generator": "glossy-demo", "layout": layout,
                                       "size": SIZE, "source": source_path.name})
        written.append(path)
    levels = pyramid(maps["cube"], "cube", "gauss4")
    for index, level in enumerate(levels[1:], start=1):
        path = out / f"forest_cube{SIZE}.mip{index}.exr"
        exr.write(path, level, {"generator": "glossy-demo", "layout": "cube", "mip_level": index,
                                "mip_filter": "gauss4", "source": source_path.name})
        written.append(path)

    exposure = 0.18 / max(float(image.mean()), 1e-6)
    def view(img):
        return preview.tonemap(img, exposure)
    small = {name: convert(image, "latlong", name, 128) for name in ("latlong", "sphere",
                                                                      "paraboloid")}
    rows = [[view(small["latlong"]), view(small["sphere"]), view(small["paraboloid"])],
            [view(convert(maps["cube"], "cube", "cube", 128))]]
    for level in levels[2:7]:  # faces of 64 down to 4 texels, shown 64 wide
        rows.append([preview.upscale(view(level), 64 // level.shape[0])])
    sheet = out / "contact_sheet.png"
    preview.write_png(sheet, preview.contact_sheet(rows))
    written.append(sheet)

    power = radiant_power(image, "latlong")
    print(f"radiant power (sum L dw, RGB): source {power.round(4)}, "
          f"cube {radiant_power(maps['cube'], 'cube').round(4)}")
    for path in written:
        print(f"wrote {path.relative_to(ROOT)}")
    print(f"done in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
