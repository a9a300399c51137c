"""The probe's pre-blurred levels in one texture, for runtime sampling in shader nodes.

Shader nodes have no level-of-detail input, so the per-sample MIP level of
bake.sampling is realised by blending pre-blurred levels held in an atlas:

- the probe becomes a lat-long map of height H (W = 2H) and its
  solid-angle-weighted MIP pyramid (bake.envmap.mip, ``gauss4`` by default);
- each level l is stored at its own size, H_l = H / 2^l rows and W_l = 2 H_l
  columns, padded as bake.atlas pads a slice (pole rows above and below,
  wrapped columns: H_l + 2 by W_l + 2), the levels one below the other from
  row 0 at the top, left-aligned, in an atlas W + 3 texels wide: level l's
  block starts at row r_l = 2 H (1 - 2^-l) + 2 l (``meta["level_layout"]``
  "mip", ``meta["atlas_rows"]`` the levels' rows). A lookup at level l is the
  four bilinear taps of bake.atlas's lookup in that block (:func:`level_lookup`;
  the nodes feed the shared ``Glossy Atlas Taps`` group with the level's
  sizes), so the whole stack holds about 4/3 of the base's texels;
- a fractional level blends the two stored levels around it (trilinear).

Until stop 75 every level was sampled back bilinearly at the base's texels
and stored H x W (L slices of H + 2 rows): 9-11 times the base's texels, and a
lookup read a bilinear resampling of the level, a little blurrier than the
level itself. Against the brute-force integral (runtime sampling, GGX 0.1-1,
tiny spots and four bundled HDRIs from 64 px probes, 128-row stacks) the two
layouts differ by 0-3% of the error, mostly in the old one's favour at GGX
0.6, whose MIP bias (bake.sampling_runtime.mip_bias_for) was measured on it;
in EEVEE against Cycles they measured the same (README, "Stop 75"). Atlases
of that layout (no ``level_layout``) are still read as they were.

:class:`AtlasProbe` has :class:`bake.sampling.MipProbe`'s interface, so
``bake.sampling.render_regular(..., mip=AtlasProbe(atlas, meta))`` is the
NumPy twin of the node lookup. Its level-0 texel has the lat-long solid angle
(pi / H)(2 pi / W) sin(theta), floored at the pole row's (the lat-long
distortion factor, as (2/n)^2 |d|_inf^3 is the cube's).
"""

import numpy as np

from .atlas import _lookup, _pad, block_lookup
from .envmap import convert, get_layout
from .envmap.mip import pyramid
from .errors import BakeError

__all__ = ["pack_levels", "AtlasProbe", "MODE", "is_stack_height", "stack_rows_below",
           "level_count", "level_row", "level_lookup"]

MODE = "atlas_levels"


def is_stack_height(rows: int) -> bool:
    """Whether a level stack may have ``rows`` lat-long rows: a power of two of at
    least 4, or three times a power of two of at least 6. Either halves exactly
    level by level (each level's box reduction takes two rows into one) down to 2
    or 3 rows: 384 = 3 x 2^7 keeps a map's default Max Map Size whole, where
    rounding it down to a power of two (256) lost a third of the rows, and with
    them a near-mirror lobe's detail."""
    rows = int(rows)
    if rows < 4:
        return False
    odd = rows >> ((rows & -rows).bit_length() - 1)  # rows without its factors of two
    return odd == 1 or (odd == 3 and rows >= 6)


def stack_rows_below(wanted: int) -> int:
    """The most rows :func:`is_stack_height` allows that are at most ``wanted``
    (at least 4): 656 -> 512, 400 -> 384, 200 -> 192, 100 -> 96."""
    wanted = max(4, int(wanted))
    power = 1 << (wanted.bit_length() - 1)  # the largest power of two <= wanted
    three = 3 * (power >> 1)  # 1.5 x it: at most wanted when wanted >= 1.5 power
    return three if 6 <= three <= wanted else power


def level_count(rows: int) -> int:
    """Levels of a stack of ``rows`` (:func:`is_stack_height`): the base and each
    exact halving down to 2 rows (a power of two) or 3 (three times one)."""
    rows, count = int(rows), 1
    while rows > 3:
        rows //= 2
        count += 1
    return count


def pack_levels(probe, layout="cube", height=None, filter="gauss4", levels=None, base=None,
                first=0):
    """(atlas, meta) of a probe's pre-blurred levels (see the module doc).

    probe: (H, W, 3) in ``layout``; height: the lat-long rows (default: twice a
    cube face, or the lat-long's own); levels: how many (default: down to 2 rows).
    base: the probe already converted to ``height`` lat-long rows
    (bake.envmap.convert with its own sub-samples: bake.probe_maps.ProbeMaps.plain),
    or None to convert it here.
    first: how many of the finest levels to leave out (a lobe whose lookups never
    read them: bake.sampling_runtime.finest_level). The chain is still made from
    ``height`` rows, so the levels kept are those of the whole stack, the first
    kept of height / 2^first rows (``meta["slice_height"]``), and a lookup at
    level l of the whole stack is one at l - first of this one (the lat-long
    texel's solid angle grows by 4^first with the rows). ``meta["first_level"]``
    records it and ``meta["stack_rows"]`` the whole stack's rows.
    """
    layout_obj = get_layout(layout)
    probe = layout_obj.check_image(probe)[..., :3].astype(np.float32)
    if height is None:
        height = 2 * probe.shape[0] if layout_obj.name == "cube" else probe.shape[0]
    if int(height) != height or not is_stack_height(int(height)):
        raise BakeError(f"the atlas height must be a power of two >= 4 or three times one "
                        f"(6, 12, ..., 384, 768), not {height!r}")
    height = int(height)
    if base is not None:
        base = np.asarray(base, dtype=np.float32)[..., :3]
        if base.shape != (height, 2 * height, 3):
            raise BakeError(f"the converted probe is {base.shape}, not ({height}, {2 * height}, 3)")
    elif layout_obj.name == "latlong" and probe.shape[0] == height:
        base = probe
    else:
        base = convert(probe, layout_obj.name, "latlong", height).astype(np.float32)
    most = level_count(height)  # down to 2 rows, or 3
    count = most if levels is None else int(levels)
    if not 1 <= count <= most:
        raise BakeError(f"levels must lie in 1..{most} for height {height}, not {levels!r}")
    first = int(first)
    if not 0 <= first < count:
        raise BakeError(f"first must lie in 0..{count - 1} for {count} levels, not {first!r}")
    chain = pyramid(base, "latlong", filter, levels=count)
    rows = height >> first
    blocks = []
    for level in chain[first:]:
        padded = _pad(level[..., :3].astype(np.float32))
        block = np.zeros((padded.shape[0], 2 * rows + 3, 3), np.float32)
        block[:, :padded.shape[1]] = padded
        blocks.append(block)
    atlas = np.concatenate(blocks, axis=0)
    kept = len(blocks)
    meta = {"mode": MODE, "slices": kept, "slice_height": rows,
            "slice_width": 2 * rows, "filter": filter, "mu": [0.0] * kept,
            "offsets": [0.0] * kept, "first_level": first, "stack_rows": height,
            "level_layout": "mip", "atlas_rows": int(atlas.shape[0])}
    assert meta["atlas_rows"] == level_row(rows, kept - 1) + (rows >> (kept - 1)) + 2
    return atlas, meta


def level_row(height, level):
    """The first row of level ``level``'s padded block in a stack of ``height`` rows
    (the "mip" layout of the module doc): 2 height (1 - 2^-level) + 2 level, exact
    for every level of the stack (each halves ``height`` exactly). Works on arrays."""
    level = np.asarray(level)
    return 2 * height - 2 * (height >> level) + 2 * level


def level_lookup(atlas, meta, level, directions):
    """(..., 3) bilinear lookups of whole levels ``level`` (int array, ...) of a level
    atlas at unit directions (..., 3): bake.atlas's lookup within each level's block
    (an atlas of the old layout, every level H x W: bake.atlas._lookup itself)."""
    if meta.get("level_layout") != "mip":
        return _lookup(atlas, meta, level, directions)
    top = int(meta["slice_height"])
    level = np.asarray(level)
    height = top >> level
    return block_lookup(atlas, height, 2 * height, level_row(top, level), directions)


class AtlasProbe:
    """A packed level atlas read as bake.sampling reads a MIP pyramid."""

    def __init__(self, atlas, meta):
        if meta.get("mode") not in (MODE, "atlas_runtime"):
            raise BakeError(f"not a level atlas (mode {meta.get('mode')!r})")
        self.atlas = np.asarray(atlas, dtype=np.float32)
        self.meta = meta
        self.height, self.width = int(meta["slice_height"]), int(meta["slice_width"])
        self.count = int(meta.get("levels", meta["slices"]))  # runtime atlases hold more

    def texel_solid_angle(self, directions):
        """Solid angle (...) of a level-0 texel at unit directions (...)."""
        sin_theta = np.sqrt(np.clip(1.0 - directions[..., 2] ** 2, 0.0, 1.0))
        pole = np.sin(np.pi / (2.0 * self.height))  # the first row's centre
        return (np.pi / self.height) * (2.0 * np.pi / self.width) * np.maximum(sin_theta, pole)

    def lookup(self, directions, level):
        """(..., 3) at unit directions (..., 3) and fractional levels (...)."""
        level = np.clip(level, 0.0, self.count - 1)
        low = np.floor(level).astype(int)
        high = np.minimum(low + 1, self.count - 1)
        frac = (level - low)[..., None]
        return (level_lookup(self.atlas, self.meta, low, directions) * (1.0 - frac)
                + level_lookup(self.atlas, self.meta, high, directions) * frac)
