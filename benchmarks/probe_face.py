"""How large a probe's cube faces must be before the probe stops limiting a lobe
(bake.resolution.choose_probe_face's rule, PROBE_FACE_PER_ROOT_WIDTH).

For every bundled HDRI and GGX roughness, the brute-force integral of the true
BRDF (bake.reference.render) over a cube probe of each face size, on an isolated
sphere's pixels (bake.reference.sphere_buffers), against the same integral over
a 256 px probe of the HDRI (close to the 1024 x 512 images' own detail):
relative RMS of luminance. Also printed: the face Auto chooses for the lobe.
Lamps a texel or two wide (night, interior) alias differently at every size, so
their curves do not fall steadily; bake.probe_lights carries those.

    .venv/bin/python benchmarks/probe_face.py [--roughness 0.2,0.3,0.45,0.6]
        [--faces 8,16,24,32,40,48,64,96,128] [--size 48] [--hdri studio ...]

``--world``: instead, what glossy.capture_probes' Auto does for a Hybrid GGX
material in each world: the lobe rule's face, then bake.probe_detail's ladder
of faces with the probe's error on the world image at each, up to the world's
own detail, and the face chosen, with the measure's time and the time the
capture then takes for its probe (converted again, as before stop 67, or
kept from the measure, as now). ``--baseline`` also measures each world as
before stop 67 (coarse tiers converted from the probe's pyramid, lat-long
maps resampled per sub-sample, the ladder up to the cap) in the same run, and prints the ratio;
``--upsample 2048`` measures each world resampled to 4096 x 2048 first.
"""

import argparse
import contextlib
import importlib
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import brdf, envmap, exr, lobes, probe_detail, reference, resolution  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def auto_face(spec):
    fit = lobes.fit(spec, slices=16)
    narrowest = min(resolution.lobe_half_width(lobes.GAMMA, lobe.profile)
                    for s in fit.slices for lobe in s.lobes)
    return resolution.choose_probe_face([narrowest], maximum=4096).value, narrowest


@contextlib.contextmanager
def _before_stop_67():
    """bake.probe_detail's measure as it was before stop 67, for the baseline: every
    lat-long tier converted from the probe's pyramid (not reduced from the finer
    tier), lat-long maps resampled per sub-sample (not separably) and the ladder
    walked up to the cap (not to the finest face the measure resolves); nothing
    remembered from the measure just made."""
    from bake.probe_maps import ProbeMaps

    convert_module = importlib.import_module("bake.envmap.convert")
    saved = (probe_detail._ExactMaps.convert, convert_module.SEPARABLE_LATLONG,
             probe_detail.measurable_face)
    probe_detail._ExactMaps.convert = ProbeMaps.convert
    convert_module.SEPARABLE_LATLONG = False
    probe_detail.measurable_face = lambda rows: 1 << 30  # the ladder up to the cap
    probe_detail._MEASURED.clear()
    try:
        yield
    finally:
        (probe_detail._ExactMaps.convert, convert_module.SEPARABLE_LATLONG,
         probe_detail.measurable_face) = saved
        probe_detail._MEASURED.clear()


def world_faces(roughnesses, hdris, baseline=False, upsample=None):
    """Print bake.probe_detail's choice per roughness and HDRI (the capture's Auto);
    with ``baseline`` also the measure before stop 67, timed in the same run."""
    for roughness in roughnesses:
        fit = lobes.fit(f"ggx:roughness={roughness}", slices=16)
        widths = [resolution.lobe_half_width(lobes.GAMMA, lobe.profile)
                  for s in fit.slices for lobe in s.lobes]
        widths.append(resolution.ggx_half_width(roughness**2))  # the sampled lobe
        width = min(widths)
        lobe_face = resolution.choose_probe_face(widths, maximum=4096).value
        print(f"GGX {roughness}: narrowest width {width:.4f} rad, lobe rule {lobe_face} px; "
              f"probe error on the world image per face (tolerance "
              f"{probe_detail.TOLERANCE:.0%}) -> face chosen", flush=True)
        for name in hdris:
            world = exr.read(studio_lights() / f"{name}.exr")[0][..., :3]
            if upsample:  # e.g. 2048: the bundled world as a 4096 x 2048 image would be
                world = envmap.convert(world, "latlong", "latlong", upsample)
            cap = resolution.world_detail_face(world.shape[0])
            start = time.perf_counter()
            face, _, tried = probe_detail.choose_world_face(world, width, lobe_face,
                                                            max(cap, lobe_face))
            measured = time.perf_counter() - start
            # The capture's probe at the chosen face: converted again (before stop 67)
            # and taken from the measure (glossy_addon.world.world_cube now).
            start = time.perf_counter()
            envmap.convert(world, "latlong", "cube", face)
            again = time.perf_counter() - start
            start = time.perf_counter()
            found = probe_detail.measured_probe(world, face) is not None
            kept = time.perf_counter() - start
            kept = f"{kept:.2f} s kept" if found else "not measured: converted"
            before = ""
            if baseline:
                with _before_stop_67():
                    start = time.perf_counter()
                    old = probe_detail.choose_world_face(world, width, lobe_face,
                                                         max(cap, lobe_face))
                    seconds = time.perf_counter() - start
                before = (f"; before stop 67 {seconds:.1f} s ({seconds / measured:.1f}x), "
                          + " ".join(f"{f}:{e:.3f}" for f, e in old[2]) + f" -> {old[0]}")
            print(f"  {name:10s} " + " ".join(f"{f}:{e:.3f}" for f, e in tried)
                  + f"  -> {face}   (measure {measured:.1f} s; capture's probe "
                  f"{again:.2f} s converted again, {kept}{before})", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--roughness", default="0.2,0.3,0.45,0.6")
    parser.add_argument("--faces", default="8,16,24,32,40,48,64,96,128")
    parser.add_argument("--size", type=int, default=48, help="sphere image size (px)")
    parser.add_argument("--hdri", action="append", help="HDRI stem (repeatable; default all)")
    parser.add_argument("--world", action="store_true",
                        help="print the world-detail choice (bake.probe_detail) instead")
    parser.add_argument("--baseline", action="store_true",
                        help="with --world: also time the measure as it was before stop 67")
    parser.add_argument("--upsample", type=int,
                        help="with --world: each world resampled to this many rows first")
    args = parser.parse_args()
    faces = [int(f) for f in args.faces.split(",")]
    hdris = args.hdri or sorted(p.stem for p in studio_lights().glob("*.exr"))
    if args.world:
        return world_faces([float(r) for r in args.roughness.split(",")], hdris, args.baseline,
                           args.upsample)
    normals, views, mask = reference.sphere_buffers(args.size)
    normals, views = normals[mask], views[mask]
    for roughness in (float(r) for r in args.roughness.split(",")):
        spec = f"ggx:roughness={roughness}"
        face, width = auto_face(spec)
        print(f"GGX {roughness}: narrowest half width {width:.4f} rad, Auto face {face}; "
              f"relative RMS against a 256 px probe at faces {faces}", flush=True)
        model = brdf.parse(spec)
        for name in hdris:
            start = time.perf_counter()
            image = exr.read(studio_lights() / f"{name}.exr")[0][..., :3]

            def render(size, image=image, model=model):
                probe = envmap.convert(image, "latlong", "cube", size)
                return reference.render(model, probe, "cube", normals, views) @ LUMINANCE

            truth = render(256)
            errors = [np.sqrt(np.mean((render(f) - truth) ** 2) / np.mean(truth ** 2))
                      for f in faces]
            print(f"  {name:10s} " + " ".join(f"{f}:{e:.3f}" for f, e in
                                             zip(faces, errors, strict=True))
                  + f"   ({time.perf_counter() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
