"""Packing a 3D map into one texture for shader nodes, and the lookup nodes perform.

Shader nodes have no 3D or layered textures, and EEVEE's Linear filtering is
not exact for computed lookups (MEASURED.md), so a node group reads four
Closest taps and blends them with bilinear weights it computes itself. This
module fixes the layout those nodes read and is their NumPy twin:

- each lat-long slice (H, W) is padded to (H + 2, W + 2): row 0 is the north
  pole (the mean of the first row), row H + 1 the south pole, column 0 repeats
  the last column and column W + 1 the first (the u seam);
- the K padded slices are stacked top to bottom, and one more column holds
  each slice's offset (radians, R channel, on the slice's first row):
  atlas (K (H + 2), W + 3, 3), row 0 at the top as in every EXR;
- the per-slice mu nodes and offsets also travel in the metadata.

:func:`shade` evaluates exactly the arithmetic the node group does (tent
weights over mu, lobe centre turned by the slice offset, padded bilinear
lookups) and equals ``BakedMap.shade`` of the map it was packed from.
"""

import numpy as np

from .errors import BakeError

__all__ = ["pack", "shade", "texel_uv", "storage_precision", "HALF_MAX", "block_lookup"]

#: Largest finite value of a 16-bit float.
HALF_MAX = 65504.0


def storage_precision(image) -> str:
    """``half`` when every value of an atlas fits a 16-bit float (half the file, and the
    GPU texture Blender makes anyway), else ``float32``: a probe brighter than a half
    float holds (a sun of 1e5) keeps its map 32-bit rather than turning it to inf."""
    values = np.asarray(image)
    # The largest magnitude from max and min (no |values| copy of a 57 MB atlas); NaN
    # compares false, so it keeps float32 as before.
    return "half" if values.size and max(float(values.max()), -float(values.min())) \
        <= HALF_MAX else "float32"


def _pad(image):
    """(H + 2, W + 2, 3): pole rows (ring means) above and below, wrapped columns."""
    rows = np.concatenate([image[:1].mean(axis=1, keepdims=True).repeat(image.shape[1], 1),
                           image,
                           image[-1:].mean(axis=1, keepdims=True).repeat(image.shape[1], 1)])
    return np.concatenate([rows[:, -1:], rows, rows[:, :1]], axis=1)


def pack(baked):
    """(atlas, meta) from a 3D BakedMap with L lobe sequences, (L K (H + 2), W + 3, 3)
    float32 (slice j K + k is lobe j's slice k),
    or from a 2D BakedMap: the padded map (H + 2, W + 4, 3) whose column W + 2
    holds slice k's offset (R) and column W + 3 its weight k(theta_o) (RGB) on row k."""
    if baked.mode == "2d":
        return _pack_2d(baked)
    if baked.mode != "3d":
        raise BakeError("only 3D maps and 2D maps pack into an atlas")
    count = baked.meta["slices"]
    lobes = baked.meta.get("lobes", 1)
    names = [f"slice.{k}" if lobes == 1 else f"lobe{j}.slice.{k}"
             for j in range(lobes) for k in range(count)]
    height, width = baked.layers[names[0]].shape[:2]
    atlas = np.zeros((len(names) * (height + 2), width + 3, 3), np.float32)
    for index, name in enumerate(names):
        top = index * (height + 2)
        atlas[top:top + height + 2, :width + 2] = _pad(
            np.asarray(baked.layers[name], dtype=np.float32)[..., :3])
    # Slice j K + k is lobe j's slice k; its offset sits on its first row.
    offsets = np.float32([baked.meta["offsets"][k][j] for j in range(lobes)
                          for k in range(count)])
    atlas[np.arange(len(names)) * (height + 2), width + 2, 0] = offsets
    meta = {"mode": "atlas3d", "slices": count, "lobes": lobes, "slice_height": height,
            "slice_width": width, "mu": [float(m) for m in baked.meta["mu"]],
            "offsets": [float(o) for o in offsets], "spec": baked.meta.get("spec")}
    return atlas, meta


def _pack_2d(baked):
    image = np.asarray(baked.layers[""], dtype=np.float32)[..., :3]
    height, width = image.shape[:2]
    count = baked.meta["slices"]
    if count > height + 2:
        raise BakeError(f"a 2D atlas holds at most {height + 2} slices for a {height}-row map")
    offsets = np.float32([o[0] for o in baked.meta["offsets"]])
    weights = np.float32(baked.meta["k"])
    columns = np.zeros((height + 2, 2, 3), np.float32)
    columns[:count, 0, 0] = offsets
    columns[:count, 1] = weights
    meta = {"mode": "atlas2d", "slices": count, "slice_height": height, "slice_width": width,
            "mu": [float(m) for m in baked.meta["mu"]], "offsets": [float(o) for o in offsets],
            "k": weights.tolist(), "spec": baked.meta.get("spec")}
    return np.concatenate([_pad(image), columns], axis=1), meta


def pack_split_sum(baked, slices=33):
    """A split-sum BakedMap as a 2D atlas for the node lookup (same layout as pack's 2D).

    The material's roughness is fixed, so its two MIP levels are blended once
    into one lat-long map (rows: twice the finer level's face size, at least
    ``slices``), looked up
    at r with zero offsets; the DFG factor F0 A + B at that roughness becomes
    the per-slice weight k(theta_o) over ``slices`` nodes in mu.
    """
    from .envmap import get_layout
    from .lobes import slice_nodes

    if baked.mode != "split-sum":
        raise BakeError("pack_split_sum needs a split-sum map")
    from .prefilter import BakedMap, split_sum_level_weights

    blend = split_sum_level_weights(baked.meta)
    face = baked.layers[blend[0][0]].shape[0]
    shape = get_layout("latlong").shape(max(2 * face, slices))
    directions = get_layout("latlong").texel_directions(shape)
    cube = get_layout("cube")
    image = sum(weight * cube.sampler(baked.layers[name])(directions) for name, weight in blend)
    mus = slice_nodes(slices)
    normal = np.array([0.0, 0.0, 1.0])
    views = np.stack([np.sqrt(1 - mus**2), np.zeros_like(mus), mus], -1)
    # k(theta_o): the DFG factor alone, i.e. shade() of a map that is 1 everywhere.
    ones = {name: np.ones_like(layer) for name, layer in baked.layers.items() if name != "dfg"}
    ones["dfg"] = baked.layers["dfg"]
    weights = BakedMap("split-sum", ones, baked.meta).shade(normal, views)
    stand_in = BakedMap("2d", {"": image.astype(np.float32)},
                        {"slices": slices, "offsets": [[0.0] for _ in mus],
                         "k": weights.tolist(), "mu": mus.tolist(),
                         "spec": baked.meta.get("spec")})
    return _pack_2d(stand_in)


def pack_irradiance(baked):
    """(atlas (H + 2, W + 3, 3), meta) of an irradiance BakedMap, times its colour.

    The same padded layout as one slice of a 3D map; its lookup centre is the
    normal itself (a Lambertian lobe peaks at the normal: an offset of -theta_o).
    """
    if baked.mode != "irradiance":
        raise BakeError("pack_irradiance needs an irradiance map")
    image = np.asarray(baked.layers["irradiance"], dtype=np.float32)[..., :3]
    image = image * np.asarray(baked.meta["color"], dtype=np.float32)
    rows = np.concatenate([image[:1].mean(axis=1, keepdims=True).repeat(image.shape[1], 1),
                           image,
                           image[-1:].mean(axis=1, keepdims=True).repeat(image.shape[1], 1)])
    padded = np.concatenate([rows[:, -1:], rows, rows[:, :1],
                             np.zeros((rows.shape[0], 1, 3), np.float32)], axis=1)
    meta = {"mode": "atlas_irradiance", "slices": 1, "slice_height": image.shape[0],
            "slice_width": image.shape[1], "mu": [1.0], "offsets": [0.0],
            "color": list(baked.meta["color"])}
    return padded, meta


def _tent(mu, nodes):
    nodes = np.asarray(nodes, dtype=np.float64)
    s = np.interp(mu, nodes, np.arange(nodes.size))
    k0 = np.clip(np.floor(s), 0, nodes.size - 1).astype(int)
    k1 = np.minimum(k0 + 1, nodes.size - 1)
    return k0, k1, s - k0


def texel_uv(row, col, atlas_shape):
    """Blender image UV of atlas texel (row from the top, col): its centre."""
    rows, cols = atlas_shape[:2]
    return (col + 0.5) / cols, 1.0 - (row + 0.5) / rows


def _lookup(atlas, meta, k, centre):
    height, width = meta["slice_height"], meta["slice_width"]
    return block_lookup(atlas, height, width, k * (height + 2), centre)


def block_lookup(atlas, height, width, first_row, centre):
    """(..., 3) bilinear lookups at unit directions ``centre`` (..., 3) of the padded
    lat-long blocks of ``height`` rows and ``width`` columns (texels; scalars or
    arrays broadcast with ``centre``'s leading shape) whose pole row is atlas row
    ``first_row``: the four taps the nodes' ``Glossy Atlas Taps`` group reads."""
    u = np.mod(0.5 - np.arctan2(centre[..., 1], centre[..., 0]) / (2 * np.pi), 1.0)
    y = np.arccos(np.clip(centre[..., 2], -1.0, 1.0)) / np.pi * height
    px = u * width + 0.5
    py = np.where(y < 0.5, 2.0 * y,
                  np.where(y > height - 0.5, height + 1.0 - 2.0 * (height - y), y + 0.5))
    px = np.clip(px, 0.0, width + 1.0)
    py = np.clip(py, 0.0, height + 1.0)
    x0 = np.minimum(np.floor(px).astype(int), width)
    y0 = np.minimum(np.floor(py).astype(int), height)
    fx = (px - x0)[..., None]
    fy = (py - y0)[..., None]
    row = first_row + y0
    top = atlas[row, x0] * (1 - fx) + atlas[row, x0 + 1] * fx
    bottom = atlas[row + 1, x0] * (1 - fx) + atlas[row + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def shade(atlas, meta, normal, view):
    """Reflected radiance (..., 3) from world-space normals and views (surface to viewer)."""
    from .prefilter import view_frame

    n, mu, r, toward = view_frame(normal, view)
    if meta.get("mode") == "atlas_irradiance":
        # The nodes turn r towards n by theta_o, which lands on n.
        return _lookup(atlas, meta, 0, n)
    k0, k1, t = _tent(mu, meta["mu"])
    offsets = np.asarray(meta["offsets"], dtype=np.float64)
    two_d = meta.get("mode") == "atlas2d"
    count = meta["slices"]
    out = 0.0
    for first in range(0, len(offsets) if not two_d else 1, count):  # lobe sequences
        for k, weight in ((k0, 1.0 - t), (k1, t)):
            delta = offsets[first + k][..., None]
            centre = np.cos(delta) * r + np.sin(delta) * toward
            centre /= np.linalg.norm(centre, axis=-1, keepdims=True)
            if two_d:  # one map, scaled by the slice's weight k(theta_o)
                value = _lookup(atlas, meta, 0, centre) * np.asarray(meta["k"])[k]
            else:
                value = _lookup(atlas, meta, first + k, centre)
            out = out + weight[..., None] * value
    return out
