"""How fine a world-image probe must be for a lobe: measured on the world itself.

bake.resolution.choose_probe_face sizes a probe from the lobe alone (the
probe's own error under about 2% on studio.exr's softboxes). Lamps only a
few of the world image's texels wide break that rule: each probe texel
spreads a lamp over its whole area and the bilinear lookup over two texels,
so a lobe a few texels wide sees the lamp moved and smeared, differently at
every face size (aliasing). Measured against Cycles in EEVEE
(benchmarks/runtime_validate.py, docs/HISTORY.md "Stop 33"): interior.exr and
night.exr at GGX 0.3 are 8.4% / 6.7% off from the 72 px face the lobe rule
gives and 3.6% / 4.4% from a 160 px one.

:func:`probe_error` measures that error for one world image, face size and
lobe: the world filtered by the lobe from a cube probe of that face (as the
capture makes it, then read back as the bake reads it) against the world
filtered by the same lobe at its own detail, both as lat-long maps of R rows
(R = the rows the lobe is filtered at, at most the world's rows and
MAX_REFERENCE_ROWS): the relative RMS of luminance, each texel weighted by
its solid angle. The lobe is GGX's reflection lobe at normal incidence with
the given width (bake.resolution.lobe_half_width), its heavy tail included.

:func:`choose_world_face` walks a ladder of faces, from the lobe rule's face
up by FACE_STEP, and keeps the first whose error is at most TOLERANCE, capped
by the world's own detail and the user's maximum.

Measured on the bundled HDRIs (`benchmarks/probe_face.py --world`; the
probe's error at the lobe rule's face, then the face chosen):

    GGX 0.3 (72 px):  city 1.9%, courtyard 0.5%, forest 0.8%, sunset 0.7% -> 72;
                      studio 2.1%, sunrise 3.1% -> 96; night 5.7% -> 152;
                      interior 6.9% -> 192
    GGX 0.45 (48 px): interior 2.6% -> 104, night 2.2% -> 64, the others 0.3-1.9% -> 48
    GGX 0.6 (32 px):  interior 2.4%, sunrise 2.6% -> 40, the others 0.2-1.0% -> 32
    GGX 0.1 (200 px): courtyard 1.2%, studio 1.9% -> 200; forest 3.7% -> 320;
                      city, interior, night, sunrise, sunset 7.9-16% -> 328 (the
                      worlds' own detail; 3-8% remain there)

The ladder is not monotone where lamps alias (interior at GGX 0.3: 6.9 /
2.0 / 4.2 / 2.7 / 0.5% at 72 / 96 / 120 / 152 / 192 px); the first face
under the tolerance is kept. In EEVEE against Cycles (Hybrid, 19 samples,
benchmarks/runtime_validate.py --probe auto) this took interior and night at
GGX 0.3 from 8.4% / 6.7% to 2.7% / 4.4%, night at GGX 0.2 from 8.6% to 4.8%,
and GGX 0.3 with anisotropy 0.8 in interior from 14.4% to 6.7%.
"""

import collections
import hashlib
import math
import threading

import numpy as np

from .envmap import convert
from .envmap.mip import reduce_latlong
from .errors import BakeError
from .probe_maps import ProbeMaps

__all__ = ["TOLERANCE", "FACE_STEP", "MAX_REFERENCE_ROWS", "ggx_kernel_profile",
           "WorldDetail", "probe_error", "measurable_face", "face_ladder", "world_face_steps",
           "choose_world_face", "measured_probe"]

#: The largest relative RMS error (luminance) a probe may add to the lobe-filtered world.
TOLERANCE = 0.02
#: Ratio between successive faces tried (rounded up to multiples of 8).
FACE_STEP = 1.25
#: Rows of the lat-long maps compared, at most (texels of 0.35 deg, about those of a
#: 256 px face's centre: bounds the measure's cost for 4k and larger worlds).
MAX_REFERENCE_ROWS = 512
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def ggx_kernel_profile(half_width, gamma):
    """GGX's reflection lobe at normal incidence whose width (bake.resolution.lobe_half_width)
    is ``half_width`` rad, tabulated at angles ``gamma`` (G,) rad from its axis: (G,) 1/sr,
    unit integral over the sphere. It is the density of the reflected direction
    when the half vector follows D(h) (h.n): D(gamma / 2) / 4 (the reflection's
    Jacobian 1 / (4 h.n) cancels h.n), cut at the horizon (gamma = pi / 2), with
    alpha = sqrt(3) tan(half_width / 2) (resolution.ggx_half_width inverted)."""
    if not 0 < half_width < math.pi / 2:
        raise BakeError(f"a lobe width must be in (0, pi/2) rad, not {half_width!r}")
    alpha = math.sqrt(3.0) * math.tan(0.5 * half_width)

    def density(angles):
        theta = 0.5 * np.asarray(angles, dtype=np.float64)
        d = alpha**2 / (math.pi * np.cos(theta) ** 4 * (alpha**2 + np.tan(theta) ** 2) ** 2)
        return np.where(angles <= 0.5 * math.pi, 0.25 * d, 0.0)

    # Normalize on a fine grid (2 pi int p sin g dg = 1): the tabulated nodes may be coarse.
    fine = np.linspace(0.0, 0.5 * math.pi, 20001)
    values = density(fine) * np.sin(fine)
    total = 2.0 * math.pi * float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(fine)))
    return density(np.asarray(gamma, dtype=np.float64)) / total


def _filtered(maps, kernel, rows, half):
    from .prefilter import _filter

    return _filter(maps, kernel, rows, half)


def _reference_rows(world_rows):
    """Rows R of the compared maps: the world's rows, halved (while even) to at most
    MAX_REFERENCE_ROWS. The lobe itself is filtered at its own working rows within R
    (prefilter.filter_rows: 6 texels per width), from lat-long maps of the world or
    the probe read with enough sub-samples not to alias their lamps (_ExactMaps)."""
    rows = int(world_rows)
    while rows > MAX_REFERENCE_ROWS and rows % 2 == 0:
        rows //= 2
    return rows


#: Sub-samples per texel side of the lat-long working maps compared. The bake's
#: ProbeMaps use 2 x 2 where the source is at most 4x finer, which moves and
#: scales lamps a texel wide in the lobe-filtered map (night.exr, GGX 0.3: the
#: world and its 328 px probe came out 8% apart, the brightest texel 13%); four
#: sub-samples per source texel side (at most SAMPLES) bring that to 1%.
SAMPLES = 8


class _ExactMaps(ProbeMaps):
    """ProbeMaps whose conversions take 4 sub-samples per source texel side (at most
    SAMPLES per target texel side; one, the bilinear reconstruction, where the
    source has at most a quarter of the target's texels), and whose coarser
    tiers are exact reductions of the finer maps (:meth:`convert`)."""

    @staticmethod
    def samples_for(ratio):
        # Reading a much coarser source, one bilinear tap per texel is its reconstruction.
        return 1 if ratio <= 0.25 else min(SAMPLES, math.ceil(4.0 * math.sqrt(ratio)))

    def convert(self, layout, size):
        """The lat-long map at ``size`` rows: when the map at twice the rows is made
        (the filter's coarser tiers follow its finest), its exact 2 x 2 solid-angle
        box reduction (bake.envmap.mip.reduce_latlong), the area mean over each
        coarse texel of the probe as the finer map reads it; else converted from
        the probe's pyramid. Measured against conversions of the full-resolution
        probe with 8 x 8 sub-samples (256-row tiers of 320 px probes of night,
        interior and forest.exr): 0.05-0.25% off (relative RMS of luminance),
        where a conversion from the pyramid's 160 px level is 10-30% off (its box
        steps and bilinear reading blur lamps a texel wide); and 2-8x cheaper
        than that conversion."""
        finer = self._maps.get(2 * int(size)) if layout == "latlong" else None
        if finer is not None:
            return reduce_latlong(finer)[0]
        return super().convert(layout, size)


class WorldDetail:
    """The lobe-filtered world at its own detail, to compare probes of it with.

    world: (H, 2H, 3) float32 lat-long image (row 0 at the zenith); half_width:
    the narrowest lobe's width (rad)."""

    def __init__(self, world, half_width, digest=None):
        from . import lobes
        from .prefilter import _profile_kernel

        world = np.asarray(world, dtype=np.float32)
        if world.ndim != 3 or world.shape[1] != 2 * world.shape[0] or world.shape[2] < 3:
            raise BakeError(f"a world image must be (H, 2H, 3) lat-long, not {world.shape}")
        self.world = world[..., :3]
        self.half_width = float(half_width)
        self.kernel = _profile_kernel(ggx_kernel_profile(self.half_width, lobes.GAMMA))
        self.rows = _reference_rows(world.shape[0])
        truth = _filtered(_ExactMaps(self.world, "latlong"), self.kernel, self.rows,
                          self.half_width)
        self.truth = truth @ LUMINANCE
        latitude = (np.arange(self.rows) + 0.5) / self.rows * math.pi
        self.weights = np.sin(latitude)[:, None] * np.ones((1, 2 * self.rows))
        #: :func:`_world_key` of the world, when the caller has it: the probes
        #: :meth:`error` makes are then kept for :func:`measured_probe`.
        self.digest = digest

    def error(self, face, cube=None):
        """Relative RMS (luminance, solid-angle weighted) of the lobe-filtered world from a
        cube probe of ``face`` px (``cube``: that probe, (face, 6 face, 3); else made from
        the world as World Only capture makes it)."""
        if cube is None:
            cube = convert(self.world, "latlong", "cube", int(face))
            if self.digest is not None:
                _keep_probe(self.digest, int(face), cube)
        seen = _filtered(_ExactMaps(cube, "cube"), self.kernel, self.rows, self.half_width)
        diff = seen @ LUMINANCE - self.truth
        return float(np.sqrt(np.sum(self.weights * diff**2)
                             / max(np.sum(self.weights * self.truth**2), 1e-30)))


def probe_error(world, face, half_width):
    """:meth:`WorldDetail.error` for one world (H, 2H, 3), face (px) and lobe width (rad)."""
    return WorldDetail(world, half_width).error(face)


def measurable_face(world_rows) -> int:
    """The finest cube face (px) :class:`WorldDetail` tells apart for a world of
    ``world_rows`` rows: the face whose centre texels match its compared maps'
    rows (:func:`_reference_rows`, at most MAX_REFERENCE_ROWS: 328 px)."""
    from .resolution import world_detail_face

    return world_detail_face(_reference_rows(world_rows))


def face_ladder(start, cap):
    """Faces tried from ``start`` up: each FACE_STEP times the last, multiples of 8,
    ending at ``cap`` (included)."""
    start, cap = int(start), int(cap)
    faces = []
    face = start
    while face < cap:
        faces.append(face)
        face = max(face + 8, int(math.ceil(face * FACE_STEP / 8.0)) * 8)
    faces.append(cap)
    return faces


#: Results of :func:`world_face_steps` in this session, by world content, width,
#: lobe face and cap (most recent last): capturing the same world again for the
#: same lobes measures nothing.
_MEASURED = collections.OrderedDict()
_MEASURED_LOCK = threading.Lock()
MEASURED_KEPT = 32


#: World Only probes the ladder made (bake.envmap.convert of the world to a cube, the
#: capture's own conversion), by world content and face, most recent last, up to
#: PROBES_KEPT_BYTES: the capture that follows a measure takes the chosen face's
#: probe from here instead of converting the world again (a 4096 x 2048 world to
#: 320 px faces: 11 s on this machine's 2 cores).
_PROBES: "collections.OrderedDict[tuple, np.ndarray]" = collections.OrderedDict()
PROBES_KEPT_BYTES = 256 << 20


def _world_key(world):
    """(shape, digest) of a world image's first three channels as float32."""
    data = np.ascontiguousarray(np.asarray(world)[..., :3], dtype=np.float32)
    return data.shape, hashlib.blake2b(data.tobytes(), digest_size=16).hexdigest()


def _keep_probe(world_key, face, cube):
    cube.flags.writeable = False
    with _MEASURED_LOCK:
        _PROBES[(world_key, face)] = cube
        _PROBES.move_to_end((world_key, face))
        while sum(kept.nbytes for kept in _PROBES.values()) > PROBES_KEPT_BYTES \
                and len(_PROBES) > 1:
            _PROBES.popitem(last=False)


def measured_probe(world, face):
    """A copy of the (face, 6 face, 3) float32 World Only probe of ``world`` (H, 2H, 3+)
    that a measure in this session made (bake.envmap.convert(world[..., :3],
    "latlong", "cube", face), to the bit), or None when none was made for this
    content and face."""
    key = (_world_key(world), int(face))
    with _MEASURED_LOCK:
        cube = _PROBES.get(key)
    return None if cube is None else cube.copy()


def world_face_steps(world, half_width, lobe_face, cap):
    """:func:`choose_world_face` as a generator: yields (fraction, message) after the
    reference and after each face tried (0.5-3.5 s each for a 1024 x 512
    world on 2 cores, 3-15 s in all at GGX 0.1; a 4096 x 2048 one 38 s at GGX 0.1,
    22 s of it the world's 320 and 328 px cubes: benchmarks/probe_face.py --world),
    and returns (face, error, tried). A world measured before in this session for the same
    width, lobe face and cap (the same pixels, by digest) returns the same result
    at once, after one step saying so."""
    lobe_face, cap = int(lobe_face), int(cap)
    if cap <= lobe_face:
        return cap, None, []
    # Faces finer than the compared maps' texels are beyond what the measure
    # resolves: its error there only follows how a lamp aliases on each grid
    # (a 4096 x 2048 night.exr at GGX 0.1: 2.6 / 3.7 / 4.9 / 2.7 / 3.6% at 320 /
    # 400 / 504 / 632 / 792 px, never 2%), while Cycles credits the larger probe
    # (docs/HISTORY.md, stop 40: sun4k at GGX 0.1 measured 2.7% from 1024 px faces,
    # 4.5% from 256). The ladder stops at the finest face the measure resolves,
    # and the cap stands when no face up to it passes.
    top = min(cap, measurable_face(np.shape(world)[0]))
    if top <= lobe_face:
        return cap, None, []
    world_key = _world_key(world)
    key = (*world_key, round(float(half_width), 12), lobe_face, cap, TOLERANCE, FACE_STEP,
           MAX_REFERENCE_ROWS)
    with _MEASURED_LOCK:
        known = _MEASURED.get(key)
        if known is not None:
            _MEASURED.move_to_end(key)
    if known is not None:
        yield 1.0, "the world's detail for this lobe, measured before in this session"
        return known
    ladder = face_ladder(lobe_face, top)
    detail = WorldDetail(world, half_width, digest=world_key)
    yield 1.0 / (len(ladder) + 1), "the lobe-filtered world at its own detail"
    tried = []
    result = None
    for index, face in enumerate(ladder):
        error = detail.error(face)
        tried.append((face, error))
        yield (index + 2) / (len(ladder) + 1), f"probe error {error:.1%} at {face} px"
        if error <= TOLERANCE:
            result = (face, error, tried)
            break
    if result is None:
        result = (cap, tried[-1][1], tried)
    with _MEASURED_LOCK:
        _MEASURED[key] = result
        while len(_MEASURED) > MEASURED_KEPT:
            _MEASURED.popitem(last=False)
    return result


def choose_world_face(world, half_width, lobe_face, cap, progress=None):
    """(face, error, tried) for a world-image probe: the first face of
    :func:`face_ladder` (lobe_face .. the smaller of cap and
    :func:`measurable_face`) whose :meth:`WorldDetail.error` is at most
    TOLERANCE, else ``cap`` (error None when nothing is measured: cap or the
    measurable face at most lobe_face; else the last face tried's error, which
    is below cap when the world is finer than the measure resolves). world:
    (H, 2H, 3) lat-long; half_width: the narrowest lobe's width (rad);
    ``tried``: [(face, error)] in order. progress(fraction,
    message) is called after each part."""
    steps = world_face_steps(world, half_width, lobe_face, cap)
    while True:
        try:
            fraction, message = next(steps)
        except StopIteration as done:
            return done.value
        if progress is not None:
            progress(fraction, message)
