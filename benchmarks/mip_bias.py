"""The runtime lookups' MIP bias against accuracy, around the default
(bake.sampling_runtime.mip_bias_for), on every bundled HDRI.

The default bias per lobe width was measured on the level stack of stops
45-74 (every level resampled at the base's texels). Since stop 75 each level
is stored at its own size ("mip" layout, bake.sampling_atlas), a little
sharper than the resampled levels, so the best bias could have moved. For
each isotropic GGX roughness, from a cube probe of ``--face`` px of each
bundled HDRI without its small bright lights (bake.probe_lights.extract_kept,
as the bake takes them; their exact term is in the shade), a sphere
(``--sphere``^2 pixels) is shaded by runtime sampling (19 samples,
bake.sampling_runtime.shade: the nodes' NumPy twin, a 128-row stack) at the
default bias plus each offset, against the brute-force integral over the
probe's texels (bake.reference.render). Printed: the root mean square over the
HDRIs of each HDRI's relative RMS of luminance, per bias.

    .venv/bin/python benchmarks/mip_bias.py [--roughness 0.2,0.3,0.45,0.6,0.8,1]
        [--face 64] [--sphere 48] [--offsets=-0.75,-0.5,-0.25,0,0.25,0.5]

No figure is asserted here; tests/bake/test_sampling_runtime.py
(test_the_default_mip_bias_follows_the_lobe_width) asserts the default's gain
over bias 0 at GGX 0.6 in night and sunset.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bake import (  # noqa: E402
    brdf,
    envmap,
    exr,
    probe_lights,
    probe_maps,
    reference,
    sampling_runtime,
)
from tools.bpy_wheel import studio_lights  # noqa: E402

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def errors_by_bias(probe, spec, biases, normals, views):
    """{bias: relative RMS of luminance} of runtime sampling of ``spec`` over ``probe``
    (a cube, (6N, N, 3)) against the brute-force integral, per bias."""
    truth = reference.render(brdf.parse(spec), probe, "cube", normals, views) @ LUMINANCE
    lobe = sampling_runtime.check(spec)[0]
    probe_maps.clear_cache()
    residual, lights = probe_lights.extract_kept(probe, "cube", lobe.mx, lobe.my)
    out = {}
    for bias in biases:
        image, meta = sampling_runtime.pack(residual, spec, height=128, lights=lights,
                                            bias=bias)
        shaded = sampling_runtime.shade(image, meta, normals, views) @ LUMINANCE
        out[bias] = float(np.sum((shaded - truth) ** 2) / np.sum(truth**2))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--roughness", default="0.2,0.3,0.45,0.6,0.8,1")
    parser.add_argument("--face", type=int, default=64, help="probe face px")
    parser.add_argument("--sphere", type=int, default=48, help="sphere image px")
    parser.add_argument("--offsets", default="-0.75,-0.5,-0.25,0,0.25,0.5",
                        help="biases tried, relative to the default")
    args = parser.parse_args()
    offsets = [float(x) for x in args.offsets.split(",")]
    normals, views, mask = reference.sphere_buffers(args.sphere)
    normals, views = normals[mask], views[mask]
    names = sorted(p.stem for p in studio_lights().glob("*.exr"))
    probes = [envmap.convert(exr.read(studio_lights() / f"{name}.exr")[0][..., :3],
                             "latlong", "cube", args.face) for name in names]
    print(f"runtime sampling (19 samples, 128-row stack, probe lights) against brute force, "
          f"{args.face} px probes of {len(names)} HDRIs, {len(normals)} sphere pixels: root "
          f"mean square of the relative RMS of luminance per MIP bias (* the default)")
    for roughness in (float(r) for r in args.roughness.split(",")):
        spec = f"ggx:roughness={roughness}"
        lobe = sampling_runtime.check(spec)[0]
        default = sampling_runtime.mip_bias_for(lobe.mx, lobe.my)
        biases = [default + o for o in offsets]
        squares = np.zeros(len(biases))
        for probe in probes:
            squares += list(errors_by_bias(probe, spec, biases, normals, views).values())
        rms = np.sqrt(squares / len(probes))
        best = biases[int(np.argmin(rms))]
        cells = "  ".join(f"{b:+.2f}{'*' if o == 0 else ' '} {e:.4f}"
                          for b, o, e in zip(biases, offsets, rms, strict=True))
        print(f"GGX {roughness:<4g} {cells}   best {best:+.2f}", flush=True)


if __name__ == "__main__":
    main()
