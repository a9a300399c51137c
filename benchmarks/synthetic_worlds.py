"""The Hybrid on worlds unlike Blender's bundled HDRIs, whose measurements made its table.

Writes three synthetic lat-long worlds (1024 x 512, linear RGB) to out/worlds/:

- ``hotsun``: a 0.6-degree sun of radiance 40,000 low over a blue sky gradient
  and a dark ground (sunset.exr's sun is about 2,700 times dimmer per texel);
- ``checker``: 5-degree cells of 0.05 and 4 (fine, high-contrast detail
  everywhere) crossed by a ring of strip lights of 300 at 30 degrees elevation;
- ``window``: a dark room (0.02) with one window of 150, 10 x 20 degrees at
  the horizon (a large bright source seen at grazing angles).

Then, for isotropic GGX roughness 0.1 / 0.2 / 0.3 / 0.45 / 0.6 and each world,
as benchmarks/hybrid.py measures the bundled HDRIs (``--face world``: the
face Auto captures for the material in that world; Probe Lights on, as the
bake's default): a 64^2 isolated sphere by the brute-force integral over the
probe (the truth), the 3D map, Runtime Sampling's NumPy twin (19 samples)
and the Hybrid with the committed table's weights; prints each one's
relative RMS of luminance against the truth and whether the Hybrid is below
both. EEVEE against Cycles on the same worlds:

    .venv/bin/python benchmarks/runtime_validate.py --probe auto \\
        --case hybrid:0.3:0:19 --hdri out/worlds/hotsun.exr ...

    .venv/bin/python benchmarks/synthetic_worlds.py [--only-write]
"""

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import exr, hybrid  # noqa: E402
from benchmarks import hybrid as measured  # noqa: E402  (the bundled HDRIs' benchmark)

OUT = ROOT / "out" / "worlds"


def _directions(height):
    """(H, 2H, 3) unit directions of a lat-long map (Blender's Environment Texture
    convention: row 0 at the zenith, +Z up)."""
    theta = np.pi * (np.arange(height) + 0.5) / height
    phi = 2.0 * np.pi * (np.arange(2 * height) + 0.5) / (2 * height)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1), t, p


def worlds(height=512):
    """{name: (H, 2H, 3) float32 lat-long image} of the three worlds (module doc)."""
    d, theta, phi = _directions(height)
    up = d[..., 2:3]
    sky = np.where(up > 0, np.array([0.25, 0.45, 0.9]) * (0.3 + 0.7 * up),
                   np.array([0.08, 0.06, 0.05]))
    sun_axis = np.array([0.6, -0.3, 0.35]) / np.linalg.norm([0.6, -0.3, 0.35])
    hotsun = sky.copy()
    hotsun[d @ sun_axis > np.cos(np.radians(0.6))] = [40000.0, 36000.0, 30000.0]
    cells = (np.floor(theta / np.radians(5)) + np.floor(phi / np.radians(5))) % 2
    checker = (0.05 + 3.95 * cells)[..., None] * np.array([1.0, 0.9, 0.8])
    checker[(np.abs(theta - np.radians(60)) < np.radians(0.8)) & (np.cos(3 * phi) > 0.7)] = 300.0
    window = np.full(d.shape, 0.02)
    window[(np.abs(theta - np.radians(85)) < np.radians(10))
           & (np.abs(phi - np.radians(200)) < np.radians(5))] = [150.0, 140.0, 120.0]
    return {name: image.astype(np.float32) for name, image in
            (("hotsun", hotsun), ("checker", checker), ("window", window))}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only-write", action="store_true", help="write the worlds, no table")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    for name, image in worlds().items():
        exr.write(OUT / f"{name}.exr", image, {"synthetic": name})
    print(f"wrote {', '.join(sorted(worlds()))} to {OUT}", flush=True)
    if args.only_write:
        return
    print("isolated 64^2 sphere, relative RMS of luminance against the brute-force integral "
          "(Probe Lights on, 19 samples, the committed table's weights)")
    print(f"{'world':8s} {'GGX':>5s} {'face':>5s} {'3D map':>7s} {'Runtime':>8s} "
          f"{'Hybrid':>7s}  Hybrid is", flush=True)
    below = total = 0
    for name in sorted(worlds()):
        for roughness, (mu, truth, baked, regular) in measured.renders(
                name, OUT, face="world", with_lights=True).items():
            weight = hybrid.blend_weight(mu, roughness, samples=19)
            blended = (1.0 - weight) * baked + weight * regular[19]
            errors = [measured.relative_rms(e, truth) for e in (baked, regular[19], blended)]
            verdict = "below both" if errors[2] < min(errors[:2]) else (
                "above both" if errors[2] > max(errors[:2]) else "between")
            below += errors[2] < min(errors[:2])
            total += 1
            print(f"{name:8s} {roughness:5.2f} {measured.FACES_USED[(name, roughness)]:5d} "
                  f"{errors[0]:7.4f} {errors[1]:8.4f} {errors[2]:7.4f}  {verdict}", flush=True)
    print(f"the Hybrid is below both in {below} of {total}")


if __name__ == "__main__":
    main()
