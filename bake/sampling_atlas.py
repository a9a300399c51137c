"""The probe's pre-blurred levels in one texture, for runtime sampling in shader nodes.

Shader nodes have no level-of-detail input, so the per-sample MIP level of
bake.sampling is realised by blending pre-blurred levels held in an atlas.
The layout is bake.atlas's padded slice stack, one slice per level, so the
existing four-tap node group (``Glossy Atlas Taps``) reads it unchanged:

- the probe becomes a lat-long map of height H (W = 2H) and its
  solid-angle-weighted MIP pyramid (bake.envmap.mip, ``gauss4`` by default);
- level l (H / 2^l rows) is sampled back bilinearly at the base texel
  directions, so every level is stored H x W (padded H + 2 x W + 2: pole rows,
  wrapped columns) and a lookup at level l is the same four taps at every
  level: atlas (L (H + 2), W + 3, 3), row 0 at the top;
- a fractional level blends the two stored levels around it (trilinear).

:class:`AtlasProbe` has :class:`bake.sampling.MipProbe`'s interface, so
``bake.sampling.render_regular(..., mip=AtlasProbe(atlas, meta))`` is the
NumPy twin of the node lookup. Its level-0 texel has the lat-long solid angle
(pi / H)(2 pi / W) sin(theta), floored at the pole row's (the lat-long
distortion factor, as (2/n)^2 |d|_inf^3 is the cube's).
"""

import numpy as np

from .atlas import _lookup, _pad
from .envmap import convert, get_layout
from .envmap.mip import pyramid
from .errors import BakeError

__all__ = ["pack_levels", "AtlasProbe", "MODE", "is_stack_height", "stack_rows_below",
           "level_count"]

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
    ``height`` rows, so the levels kept are those of the whole stack; the first
    kept is stored as it is (height / 2^first rows, ``meta["slice_height"]``) and
    the coarser ones sampled back at its texels, so a lookup at level l of the
    whole stack is one at l - first of this one (the lat-long texel's solid angle
    grows by 4^first with the rows). ``meta["first_level"]`` records it and
    ``meta["stack_rows"]`` the whole stack's rows.
    """
    layout_obj = get_layout(layout)
    probe = layout_obj.check_image(probe)[..., :3].astype(np.float32)
    if height is None:
        height = 2 * probe.shape[0] if layout_obj.name == "cube" else probe.shape[0]
    if int(height) != height or not is_stack_height(int(height)):
        raise BakeError(f"the atlas height must be a power of two >= 4 or three times one "
                        f"(6, 12, ..., 384, 768), not {height!r}")
    height = int(height)
    latlong = get_layout("latlong")
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
    kept = chain[first][..., :3]
    slices = [kept] + [latlong.upsampled(level[..., :3], rows) for level in chain[first + 1:]]
    atlas = np.concatenate([_pad(level) for level in slices], axis=0)
    atlas = np.concatenate([atlas, np.zeros((atlas.shape[0], 1, 3), np.float32)], axis=1)
    meta = {"mode": MODE, "slices": len(slices), "slice_height": rows,
            "slice_width": 2 * rows, "filter": filter, "mu": [0.0] * len(slices),
            "offsets": [0.0] * len(slices), "first_level": first, "stack_rows": height}
    return atlas.astype(np.float32), meta


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
        return (_lookup(self.atlas, self.meta, low, directions) * (1.0 - frac)
                + _lookup(self.atlas, self.meta, high, directions) * frac)
