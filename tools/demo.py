"""The demo (``make demo``): Blender's bundled forest.exr through Glossy's map core.

Writes to out/demo/:
- forest_cube256.exr, forest_paraboloid256.exr, forest_sphere256.exr
  (DESIGN.md layouts, parameters in the EXR header);
- forest_cube256.mip<k>.exr, the solid-angle-weighted gauss4 MIP pyramid;
- contact_sheet.png, tonemapped for viewing only: top row lat-long source,
  sphere map and dual paraboloid; then the cube strip (+X -X +Z -Z -Y +Y);
  then MIP levels 2 to 6 of the cube, enlarged to the same size;
- forest_ward3d.exr and forest_ggx3d.exr: Kautz-McCool 3D maps (16 slices of
  256 x 128) for Ward alpha 0.04 (the paper's teapot) and GGX roughness 0.6,
  each with its .json sidecar;
- slices.png: slices of both 3D maps at four view elevations (the paper's
  Figure 8), rows Ward then GGX, left to right cos(theta_o) = 0.02 .. 1;
- fit_error.png: the fits' mean relative RMS error against the number of
  lobes (the paper's Figure 7);
- bump_brdf.png: BRDFs computed from bump height fields (bake.bumpbrdf, Cabral,
  Max & Springmeyer's Figure 3): white noise (128^2, RMS slope 0.3) and
  cylindrical grooves (128^2, period 64, depth 8, along y: each groove has 64
  distinct facet slopes, finer than the 3.75-degree cells), f cos(theta_o) in
  the plane of incidence for light at 0, 30 and 60 degrees; for the grooves
  in the plane across them and along them (the highlight spreads across).
"""

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from bake import exr, preview  # noqa: E402
from bake.envmap import convert, radiant_power  # noqa: E402
from bake.envmap.mip import pyramid  # noqa: E402
from bake.progress import LinePrinter  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

SIZE = 256


def kautz_mccool(image, cube, out, exposure):
    """3D maps, the slice sheet (Figure 8) and the error-vs-lobes plot (Figure 7)."""
    from bake import lobes, prefilter

    written, rows = [], []
    probe = convert(cube, "cube", "cube", 128)
    for name, spec in (("ward3d", "ward:alpha=0.04"), ("ggx3d", "ggx:roughness=0.6")):
        baked = prefilter.prefilter(probe, spec, "3d", 128, slices=16, progress=LinePrinter())
        baked.meta["source"] = "forest.exr"
        path = baked.write(out / f"forest_{name}.exr")
        written += [path, path.with_suffix(".json")]
        picks = [0, 5, 10, 15]
        rows.append([preview.tonemap(convert(baked.layers[f"slice.{k}"], "latlong", "latlong",
                                             96), exposure) for k in picks])
    sheet = out / "slices.png"
    preview.write_png(sheet, preview.contact_sheet(rows))
    written.append(sheet)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing: fit_error.png skipped")
        return written
    figure, axis = plt.subplots(figsize=(6, 4))
    for spec in ("ward:alpha=0.1", "ggx:roughness=0.4", "sum(lambert:color=0.3; ggx:roughness=0.3)",
                 "phong:n=40,ks=0.5,kd=0.4"):
        errors = [np.mean([s.relative_rms_error for s in lobes.fit(spec, 8, count).slices[1:]])
                  for count in (1, 2, 3, 4)]
        axis.plot([1, 2, 3, 4], errors, marker="o", label=spec)
    axis.set_xlabel("lobes per slice")
    axis.set_ylabel("mean relative RMS error (cosine-weighted)")
    axis.set_xticks([1, 2, 3, 4])
    axis.legend(fontsize=7)
    axis.grid(alpha=0.3)
    figure.tight_layout()
    plot = out / "fit_error.png"
    figure.savefig(plot, dpi=100)
    plt.close(figure)
    written.append(plot)
    return written


def _slice(model, theta_i_deg, azimuth_deg, n=721):
    """(signed theta_o, f cos theta_o luminance) in the vertical plane at ``azimuth``
    through the light at theta_i (negative theta_o: the light's side)."""
    a, t = np.radians(azimuth_deg), np.radians(theta_i_deg)
    axis = np.array([np.cos(a), np.sin(a), 0.0])
    wi = -np.sin(t) * axis + np.array([0.0, 0.0, np.cos(t)])  # light on the negative side
    theta = np.radians(np.linspace(-89.5, 89.5, n))
    wo = np.sin(theta)[:, None] * axis + np.cos(theta)[:, None] * np.array([0.0, 0.0, 1.0])
    value = model.f(np.broadcast_to(wi, wo.shape), wo) @ np.array([0.2126, 0.7152, 0.0722])
    return theta, value * np.cos(theta)


def bump_figures(out):
    """bump_brdf.png: Figure 3-style in-plane plots of BRDFs computed from bumps."""
    from bake import bumpbrdf

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing: bump_brdf.png skipped")
        return []
    surfaces = {
        "white noise": bumpbrdf.BumpSurface(bumpbrdf.white_noise(128, 0.3, 0), mirror=True),
        "grooves": bumpbrdf.BumpSurface(bumpbrdf.grooves(128, 64.0, 8.0), mirror=True),
    }
    noise = bumpbrdf.IsotropicTable(bumpbrdf.bump_table(
        surfaces["white noise"], thetas=24, azimuths=12, progress=LinePrinter())[0])
    grooves = bumpbrdf.AnisotropicTable(bumpbrdf.bump_table(
        surfaces["grooves"], thetas=24, phis=32, isotropic=False, progress=LinePrinter())[0])
    panels = [("white noise (isotropic)", noise, 0.0), ("grooves: across them", grooves, 0.0),
              ("grooves: along them", grooves, 90.0)]
    figure = plt.figure(figsize=(13, 4.2))
    for index, (title, model, azimuth) in enumerate(panels):
        axis = figure.add_subplot(1, 3, index + 1, projection="polar")
        for theta_i in (0.0, 30.0, 60.0):
            theta, value = _slice(model, theta_i, azimuth)
            line, = axis.plot(theta, value, label=f"light at {theta_i:g} deg")
            axis.plot([-np.radians(theta_i)] * 2, [0, value.max() * 1.05 + 1e-9], ":",
                      color=line.get_color())
        axis.set_theta_zero_location("N")
        axis.set_theta_direction(-1)
        axis.set_thetamin(-90)
        axis.set_thetamax(90)
        axis.set_title(title, fontsize=10)
        axis.legend(loc="lower left", fontsize=7)
    figure.suptitle("BRDF x cos from bump height fields (F = 1), in the plane of incidence",
                    fontsize=10)
    path = out / "bump_brdf.png"
    figure.savefig(path, dpi=90)
    plt.close(figure)
    return [path]


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

    written += kautz_mccool(image, maps["cube"], out, exposure)
    written += bump_figures(out)
    power = radiant_power(image, "latlong")
    print(f"radiant power (sum L dw, RGB): source {power.round(4)}, "
          f"cube {radiant_power(maps['cube'], 'cube').round(4)}")
    for path in written:
        print(f"wrote {path.relative_to(ROOT)}")
    print(f"done in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
