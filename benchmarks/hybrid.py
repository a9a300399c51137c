"""The hybrid of the 3D map and regular sampling (bake.hybrid): measured errors and
the hybrid's own, on every bundled HDRI.

For each of Blender's bundled HDRIs and isotropic GGX roughness 0.1, 0.2, 0.3,
0.45, 0.6, 0.8 and 1 (the last two since stop 72; ``--roughness 0.05`` measures
a near-mirror lobe, not in the tables: :data:`ROUGHNESS`), from a cube probe of
the face Auto captures for that roughness (bake.resolution.choose_probe_face: 200 / 104 /
72 / 48 / 32 / 24 / 24 px; ``--face
world``: raised per HDRI for its small lights as the capture's Auto does,
bake.probe_detail; ``--face N`` for one size for all), a sphere (64^2 pixels) is rendered by the
brute-force integral (bake.reference, the truth: by default the sum over the
probe's texel centres, which the committed tables were measured against;
``--truth bilinear``: the integral over the probe's bilinear reconstruction,
0.5-8% away from that sum at GGX 0.1; ``--truth world``: the integral over the
HDRI's own bilinear reconstruction, what Cycles renders, so the probe's loss
counts as each method's error), by the 3D map at Auto size
(bake.prefilter) and by regular sampling with 19, 61 and 127 samples as the
Runtime Sampling nodes compute it (bake.sampling_runtime.shade, their NumPy
twin, over the level stack glossy.bake_materials makes). Per sample budget
and bin of mu = n.v it prints each method's relative RMS of luminance,
pooled over the HDRIs (the root of the mean square), and the weight of the
regular estimate at the bin's centre: the knots of the piecewise-linear w(mu)
the nodes evaluate, fitted by least squares as that curve (``--fit curve``,
bake.hybrid's docstring; ``--fit bins``: each bin's own constant, the tables
before stop 70); ``--write`` stores the table as
bake/hybrid_errors.json, the one bake.hybrid weighs with.

Then the hybrid against both methods alone, per budget, HDRI and roughness,
with the weights derived *without* that HDRI (leave one out), so no figure
judges the table on the scene it was measured on.

    .venv/bin/python benchmarks/hybrid.py [--write] [--no-lights] [--face auto|world|64]
        [--brdf ggx|beckmann] [--truth texels|bilinear|world] [--supersample 2]
        [--roughness 0.1,0.2] [--hdri night,city] [--save out/m.pkl | --load out/m.pkl]
        [--lights cube|world|auto] [--fit curve|bins]

``--lights world`` (with ``--truth world``) measures the probe's lights on the
world's own texels (bake.world_lights) instead of the cube's; ``auto`` only
where the lobe's tiles are at least the world's texel (GGX 0.2 and rougher on
the bundled 1024 x 512 HDRIs).

``--save`` keeps the per-pixel measurements (a pickle; put it under out/), and
``--load`` reads them back instead of measuring (same --brdf, --face, --truth
and --supersample), so the table and the leave-one-out comparison are redone
in seconds rather than the 15-35 minutes the measurement takes here (stop 72:
15 minutes for GGX's seven roughness values alone, 25 beside Beckmann's).

The committed GGX table: ``--face world --supersample 2 --write`` (each pixel
the mean of 2 x 2 sub-pixels, as anti-aliasing filters them; pixel centres
alias highlights narrower than a pixel, :func:`sphere_pixels`).

``--brdf beckmann`` measures Cycles' Beckmann lobe (sampled through GGX's
visible normals, bake.sampling_runtime) and writes its own table,
bake/hybrid_errors_beckmann.json, which a Beckmann Hybrid blends with.

By default both methods see the probe without its small bright lights, which
are shaded exactly (bake.probe_lights, Probe Lights on: the bake's default);
``--no-lights`` measures them on the whole probe (the table before Probe
Lights).
"""

import argparse
import json
import pickle
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import (  # noqa: E402
    brdf,
    exr,
    hybrid,
    lobes,
    prefilter,
    probe_detail,
    probe_lights,
    reference,
    resolution,
    sampling_runtime,
    world_lights,
)
from bake.envmap import convert, get_layout  # noqa: E402

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
#: Not 0.05 (stop 73): at GGX 0.05 from the 328 px faces Auto captures, the texel sum
#: (the tables' truth) aliases the lobe: both methods measured 22% from it in
#: courtyard, where against the world's own integral they are 2-3%
#: (benchmarks/stack_rows.py), so its weights would be fitted to the truth's error.
#: Below 0.1 the Hybrid takes 0.1's weights.
ROUGHNESS = (0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0)
EDGES = (0.0, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0)
BUDGETS = (19, 61, 127)
#: The default Max Map Size, which bounds the runtime level stack's rows in the bake
#: (operators.bake_materials.runtime_height: bake.sampling_runtime.stack_height, rounded
#: down to a power of two or three times one: 384; a power of two, 256, before stop 73).
STACK_ROWS_MAX = prefilter.DEFAULT_MAX_SIZE
#: (HDRI, roughness) -> the probe face :func:`renders` used.
FACES_USED = {}


def hdri_directory():
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("bpy is not installed: run make test once (it sets up .venv)")
    return Path(next(iter(spec.submodule_search_locations))) / "5.0" / "datafiles" / \
        "studiolights" / "world"


def runtime_twin(cube, spec, budget, normals, views, lights=()):
    """(N, 3) the Runtime Sampling nodes' radiance (bake.sampling_runtime.shade, their
    NumPy twin) with the level stack glossy.bake_materials makes for this probe
    (operators.bake_materials.runtime_height at Auto: twice the face's rows, at
    most the default Max Map Size, bake.sampling_runtime.stack_height): the estimate
    the Hybrid blends; with ``lights`` (``cube`` then the residual), their exact term
    is included."""
    rows = sampling_runtime.stack_height(cube.shape, "cube", cap=STACK_ROWS_MAX)[0]
    atlas, meta = sampling_runtime.pack(cube, spec, layout="cube", budget=budget, height=rows,
                                        lights=lights)
    return sampling_runtime.shade(atlas, meta, normals, views)


#: The lobe kind measured (``--brdf``): "ggx" (the committed bake/hybrid_errors.json)
#: or "beckmann" (bake/hybrid_errors_beckmann.json).
KIND = ["ggx"]
#: What the truth integrates (``--truth``): the probe's texels, its bilinear
#: reconstruction (bake.reference.RECONSTRUCTIONS), or the HDRI's (``world``).
TRUTH = ["texels"]
TRUTHS = (*reference.RECONSTRUCTIONS, "world")


def _spec(roughness):
    return f"{KIND[0]}:roughness={roughness}"


def _widths(roughness):
    fit = lobes.fit(_spec(roughness), slices=16)
    widths = [resolution.lobe_half_width(lobes.GAMMA, lobe.profile)
              for s in fit.slices for lobe in s.lobes]
    widths.append(resolution.ggx_half_width(roughness ** 2))
    return widths


def auto_face(roughness):
    """The probe face glossy.capture_probes' lobe rule gives a Hybrid material of
    isotropic GGX (or KIND) ``roughness`` (operators.capture_probes: the narrowest
    of the 3D fit's lobes and the sampled lobe)."""
    return resolution.choose_probe_face(_widths(roughness), maximum=4096).value


def world_face(image, roughness):
    """The face glossy.capture_probes' Auto gives that material in the world ``image``
    (H, 2H, 3) (operators.capture_probes._face_size): the lobe rule's, at most the
    world's own detail, and raised for the world's small lights (bake.probe_detail)
    up to that detail. Stop 73 added the first bound, as the capture has it: GGX
    0.05's lobe asks for 600 px faces, which a 512-row world caps at 328 (rougher
    lobes ask for at most 328 and are unchanged)."""
    widths = _widths(roughness)
    choice = resolution.choose_probe_face(widths, maximum=4096, world_rows=image.shape[0])
    cap = resolution.world_detail_face(image.shape[0])
    if choice.limited_by != "lobe" or cap <= choice.value:
        return choice.value
    return probe_detail.choose_world_face(image, min(widths), choice.value, cap)[0]


#: Where the probe's lights are measured (``--lights``): on the cube (the bake's for a
#: probe rendered from the scene), on the world's own texels (bake.world_lights), or
#: on the world's where the lobe resolves them (world_lights.resolves: the bake's for
#: a World Only probe of an unchanged world, bake.world_lights.split_for).
LIGHTS = ["cube"]
LIGHT_SOURCES = ("cube", "world", "auto")

#: Sub-pixels per pixel side (``--supersample``): 1 shades pixel centres (the committed
#: tables); S averages S x S sub-pixels, the footprint EEVEE's and Cycles' anti-aliasing
#: integrate.
SUPERSAMPLE = [1]
#: How the weights are fitted (``--fit``): "curve", the knot values of the
#: piecewise-linear w(mu) the nodes evaluate (bake.hybrid.curve_normal_equations,
#: bounded to [0, 1]: the committed tables since stop 70), or "bins", one
#: constant per mu bin (the tables before).
FIT = ["curve"]
FITS = ("curve", "bins")


def sphere_pixels(size, supersample=1):
    """(normals (P, 3), views (P, 3), average) of the sphere's sub-pixels: ``size`` x
    ``size`` pixels of bake.reference.sphere_buffers, each split into supersample^2
    sub-pixels; ``average`` maps values (P,) of the sub-pixels to (N,) per pixel that
    any of its sub-pixels covers (their mean over the covered ones).

    Pixel centres alone alias a highlight narrower than a pixel: night.exr's lamps
    at GGX 0.1 through 328 px faces put the mean over the n.v 0.2-0.35 bin of a
    64^2 px sphere at 1.25 by the texel sum and 1.02 by both methods (the same
    exact light term), 18% apart, while over 4 x 4 sub-pixels the light term
    and the sum over the lights' texels agree within 1.2%."""
    s = int(supersample)
    normals, views, mask = reference.sphere_buffers(size * s)
    rows, cols = np.nonzero(mask)
    pixel = (rows // s) * size + cols // s
    covered, group = np.unique(pixel, return_inverse=True)
    counts = np.bincount(group, minlength=len(covered)).astype(np.float64)

    def average(values):
        return np.bincount(group, np.asarray(values, dtype=np.float64),
                           len(covered)) / counts

    return normals[mask], views[mask], average


def lights_texel_sum(model, delta, normals, views, chunk=2048):
    """(P, 3) the texel sum (bake.reference.reflected_radiance) over the texels a probe
    lost to its lights: ``delta`` (cube strip) = probe - residual, zero elsewhere; the
    truth of the lights' share, which their exact term approximates."""
    layout = get_layout("cube")
    shape = delta.shape[:2]
    flat = np.asarray(delta, dtype=np.float64).reshape(-1, 3)
    keep = np.any(flat != 0.0, axis=1)
    directions = layout.texel_directions(shape).reshape(-1, 3)[keep]
    flux = flat[keep] * layout.solid_angles(shape).reshape(-1)[keep, None]
    frames = reference._frames(normals, None, (0.3, 0.5, 0.8))
    out = np.zeros((len(normals), 3))
    for start in range(0, len(normals), chunk):
        frame = frames[start:start + chunk]
        wi = np.einsum("pij,tj->pti", frame, directions)
        wo = np.broadcast_to(np.einsum("pij,pj->pi", frame, views[start:start + chunk])
                             [:, None, :], wi.shape)
        values = model.f(wi, wo) * np.clip(wi[..., 2:3], 0.0, None)
        out[start:start + chunk] = np.einsum("ptc,tc->pc", values, flux)
    return out


def renders(name, directory, size=64, face="auto", with_lights=False):
    """{roughness: (mu, truth, map, {budget: regular}, lights)} luminance per
    sphere pixel, each roughness from a probe of ``face`` px (or its
    :func:`auto_face`). ``with_lights``: as the bake does with Probe Lights on
    (bake.probe_lights): both methods see the residual probe and each estimate
    includes the lights' exact term (added outside the blend, as the nodes add
    it); the truth is the whole probe's, and ``lights`` is (the exact term, the
    texel sum over the lights' texels: :func:`lights_texel_sum`), both zero without
    lights or with a truth other than the texel sum: the exact term's error is
    the part of each estimate's error that no blend weight changes."""
    image, _ = exr.read(directory / f"{name}.exr")
    normals, views, average = sphere_pixels(size, SUPERSAMPLE[0])
    mu = average(np.clip(np.sum(normals * views, axis=-1), 0.0, 1.0))
    out = {}
    for roughness in ROUGHNESS:
        spec = _spec(roughness)
        model = brdf.parse(spec)
        size_px = auto_face(roughness) if face == "auto" else \
            world_face(image[..., :3], roughness) if face == "world" else int(face)
        FACES_USED[(name, roughness)] = size_px
        cube = convert(image[..., :3], "latlong", "cube", size_px)
        if TRUTH[0] == "world":
            truth = reference.render(model, image[..., :3], "latlong", normals, views,
                                     reconstruction="bilinear") @ LUMINANCE
        else:
            truth = reference.render(model, cube, "cube", normals, views,
                                     reconstruction=TRUTH[0]) @ LUMINANCE
        truth = average(truth)
        probe, taken, light_term = cube, (), 0.0
        lights = (np.zeros_like(truth), np.zeros_like(truth))
        if with_lights:
            probe, taken = probe_lights.extract_for(cube, "cube", roughness ** 2)
            if LIGHTS[0] == "world" or (LIGHTS[0] == "auto" and world_lights.resolves(
                    image.shape, roughness ** 2)):
                world_residual, taken = world_lights.from_world(taken, image[..., :3], size_px)
                probe = convert(world_residual, "latlong", "cube", size_px)
            light_term = runtime_twin(probe, spec, BUDGETS[0], normals, views, taken) \
                - runtime_twin(probe, spec, BUDGETS[0], normals, views)
            if TRUTH[0] == "texels" and taken:
                lights = (average(light_term @ LUMINANCE), average(lights_texel_sum(
                    model, cube - probe, normals, views) @ LUMINANCE))
        baked = average((prefilter.prefilter(probe, spec, "3d", "auto").shade(normals, views)
                         + light_term) @ LUMINANCE)
        regular = {budget: average(runtime_twin(probe, spec, budget, normals, views, taken)
                                   @ LUMINANCE) for budget in BUDGETS}
        out[roughness] = (mu, truth, baked, regular, lights)
    return out


def binned_squares(mu, truth, estimate):
    """Per mu bin: (sum of squared errors, sum of squared truth)."""
    index = np.clip(np.searchsorted(EDGES, mu, side="right") - 1, 0, len(EDGES) - 2)
    errors = np.bincount(index, (estimate - truth) ** 2, len(EDGES) - 1)
    scale = np.bincount(index, truth ** 2, len(EDGES) - 1)
    return errors, scale


def table_from(results, names, face="auto"):
    """The pooled error and least-squares weight table over the HDRIs ``names``."""
    bins = len(EDGES) - 1
    centres = 0.5 * (np.array(EDGES[:-1]) + np.array(EDGES[1:]))
    map_error = np.zeros((len(ROUGHNESS), bins))
    regular_error = np.zeros((len(BUDGETS), len(ROUGHNESS), bins))
    weight = np.zeros_like(regular_error)
    for i, roughness in enumerate(ROUGHNESS):
        relative = []
        for name in names:
            mu, truth, baked, _, _ = results[name][roughness]
            errors, truth_squares = binned_squares(mu, truth, baked)
            relative.append(errors / np.maximum(truth_squares, 1e-300))
        map_error[i] = np.sqrt(np.mean(relative, axis=0))
        for s, budget in enumerate(BUDGETS):
            relative = []
            numerator, denominator = np.zeros(bins), np.zeros(bins)
            gram, rhs = np.zeros((bins, bins)), np.zeros(bins)
            for name in names:
                mu, truth, baked, regular, (term, share) = results[name][roughness]
                regular = regular[budget]
                errors, truth_squares = binned_squares(mu, truth, regular)
                relative.append(errors / np.maximum(truth_squares, 1e-300))
                # The blend weighs what it changes: the residual probe's estimates
                # against the residual's truth (the lights' exact term and its error
                # are the same whatever w is; :func:`renders`).
                truth, baked, regular = truth - share, baked - term, regular - term
                index = np.clip(np.searchsorted(EDGES, mu, side="right") - 1, 0, bins - 1)
                scale = np.maximum(np.bincount(index, truth ** 2, bins) /
                                   np.maximum(np.bincount(index, None, bins), 1), 1e-300)
                numerator += np.bincount(index, (baked - truth) * (baked - regular), bins) / scale
                denominator += np.bincount(index, (baked - regular) ** 2, bins) / scale
                equations = hybrid.curve_normal_equations(mu, baked, regular, truth,
                                                          1.0 / scale[index], centres)
                gram, rhs = gram + equations[0], rhs + equations[1]
            regular_error[s, i] = np.sqrt(np.mean(relative, axis=0))
            if FIT[0] == "curve":
                weight[s, i] = hybrid.bounded_least_squares(gram, rhs)
            else:
                weight[s, i] = np.clip(numerator / np.maximum(denominator, 1e-300), 0.0, 1.0)
    return hybrid.ErrorTable(ROUGHNESS, EDGES, map_error, regular_error, weight,
                             {"hdris": list(names), "sphere": 64,
                              "probe_face": {str(r): auto_face(r) for r in ROUGHNESS}
                              if face == "auto" else
                              {f"{n} {r}": FACES_USED.get((n, r)) for n in names
                               for r in ROUGHNESS} if face == "world" else face,
                              "brdf": f"{KIND[0]} (isotropic)", "truth": TRUTH[0],
                              "supersample": SUPERSAMPLE[0], "fit": FIT[0]},
                             BUDGETS)


def relative_rms(estimate, truth):
    return float(np.sqrt(np.mean((estimate - truth) ** 2) / np.mean(truth ** 2)))


def main():
    global ROUGHNESS
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true",
                        help="store the pooled table as bake/hybrid_errors.json (or the "
                             "--brdf's own)")
    parser.add_argument("--face", default="auto",
                        help="probe face size, or auto: each roughness at the face Auto "
                             "captures for it (the committed table)")
    parser.add_argument("--brdf", default="ggx", choices=hybrid.KINDS,
                        help="the lobe measured (its own table: bake.hybrid.table_path)")
    parser.add_argument("--no-lights", action="store_true",
                        help="the whole probe in both methods (Probe Lights off); the "
                             "default takes the probe's lights out as the bake does")
    parser.add_argument("--supersample", type=int, default=1,
                        help="sub-pixels per pixel side averaged (1: pixel centres, the "
                             "committed tables)")
    parser.add_argument("--roughness", default=None,
                        help="comma-separated subset of the roughness values measured "
                             f"(default: all of {', '.join(map(str, ROUGHNESS))}); with "
                             "a subset the table is printed, not written")
    parser.add_argument("--hdri", default=None,
                        help="comma-separated subset of the bundled HDRIs (by stem); with a "
                             "subset the table is printed, not written")
    parser.add_argument("--truth", default="texels", choices=TRUTHS,
                        help="what the brute-force truth integrates: the probe's texels (the "
                             "committed tables), its bilinear reconstruction, or the HDRI's")
    parser.add_argument("--lights", default="cube", choices=LIGHT_SOURCES,
                        help="measure the probe's lights on the cube (the bake's), on the "
                             "world's own texels (bake.world_lights; needs --truth world), or "
                             "on the world's where the lobe resolves them")
    parser.add_argument("--fit", default="curve", choices=FITS,
                        help="fit the knots of the curve the nodes evaluate (the committed "
                             "tables) or one constant per mu bin (the tables before stop 70)")
    parser.add_argument("--save", default=None,
                        help="also store the per-pixel measurements (a pickle, e.g. under "
                             "out/) for --load")
    parser.add_argument("--load", default=None,
                        help="take the per-pixel measurements from a --save file instead of "
                             "measuring (same --brdf, --face, --truth, --supersample)")
    args = parser.parse_args()
    KIND[0] = args.brdf
    FIT[0] = args.fit
    LIGHTS[0] = args.lights
    if args.lights != "cube" and args.truth != "world":
        parser.error("--lights world|auto needs --truth world (the texel sum is the cube's)")
    if args.lights != "cube" and args.write:
        parser.error("--write stores the bake's table: its lights are the cube's")
    TRUTH[0] = args.truth
    SUPERSAMPLE[0] = args.supersample
    if args.roughness:
        ROUGHNESS = tuple(float(x) for x in args.roughness.split(","))
        if args.write:
            parser.error("--write needs every roughness (leave --roughness out)")
    directory = hdri_directory()
    names = sorted(p.stem for p in directory.glob("*.exr"))
    if args.hdri:
        unknown = sorted(set(args.hdri.split(",")) - set(names))
        if unknown:
            parser.error(f"unknown HDRI(s) {', '.join(unknown)} (bundled: {', '.join(names)})")
        if args.write:
            parser.error("--write needs every HDRI (leave --hdri out)")
        names = sorted(set(args.hdri.split(",")))
    results = {}
    if args.load:
        with open(args.load, "rb") as handle:
            saved = pickle.load(handle)
        results = {name: {r: saved["results"][name][r] for r in ROUGHNESS} for name in names}
        FACES_USED.update(saved["faces"])
    for name in names:
        if name in results:
            continue
        start = time.perf_counter()
        results[name] = renders(name, directory, face=args.face,
                                with_lights=not args.no_lights)
        print(f"measured {name} ({time.perf_counter() - start:.0f} s)", flush=True)
    if args.save:
        with open(args.save, "wb") as handle:
            pickle.dump({"results": results, "faces": FACES_USED, "args": vars(args)}, handle)
    table = table_from(results, names, args.face)
    table.meta["probe_lights"] = not args.no_lights
    # The 3D map's lobes about the centre bake.lobes chooses (stop 72), not the peak.
    table.meta["lobe_centre"] = "best"
    # The runtime level stack's rows: a power of two or three times one (stop 73:
    # 384 at the default Max Map Size), not a power of two.
    table.meta["stack_rows"] = "power of two or three times one"
    print("\npooled relative RMS per mu bin, map / regular, and the weight w of regular:")
    for s, budget in enumerate(BUDGETS):
        print(f"{budget} samples")
        print(f"{'roughness':>9s} " + " ".join(f"{f'{a:.2f}-{b:.2f}':>13s}"
                                              for a, b in zip(EDGES[:-1], EDGES[1:], strict=True)))
        for i, roughness in enumerate(ROUGHNESS):
            print(f"{roughness:9.2f} " + " ".join(
                f"{m:6.3f}/{r:6.3f}" for m, r in zip(table.map[i], table.regular[s, i],
                                                     strict=True))
                  + "   w " + " ".join(f"{w:.2f}" for w in table.weight[s, i]))
    if args.write:
        path = hybrid.table_path(args.brdf)
        path.write_text(json.dumps(table.to_json(), indent=1) + "\n")
        print(f"wrote {path}")
    print("\nwhole sphere, relative RMS (weights measured without the HDRI itself); "
          "'fixed w' is the hybrid weighted as for 19 samples:")
    print(f"{'samples':>7s} {'hdri':10s} {'rough':>5s} {'map':>6s} {'regular':>7s} "
          f"{'hybrid':>6s} {'fixed w':>7s}  best alone")
    for budget in BUDGETS:
        wins = worse = fixed_wins = 0
        for name in names:
            others = table_from(results, [n for n in names if n != name])
            for roughness in ROUGHNESS:
                mu, truth, baked, regular, _ = results[name][roughness]
                regular = regular[budget]
                blends = []
                for samples in (budget, BUDGETS[0]):
                    weight = hybrid.blend_weight(mu, roughness, others, samples)
                    blends.append((1.0 - weight) * baked + weight * regular)
                errors = [relative_rms(x, truth) for x in (baked, regular, *blends)]
                wins += errors[2] < min(errors[:2])
                fixed_wins += errors[3] < min(errors[:2])
                worse += errors[2] > max(errors[:2])
                print(f"{budget:7d} {name:10s} {roughness:5.2f} {errors[0]:6.3f} "
                      f"{errors[1]:7.3f} {errors[2]:6.3f} {errors[3]:7.3f}  "
                      f"{min(errors[:2]):6.3f}", flush=True)
        cases = len(names) * len(ROUGHNESS)
        print(f"{budget} samples: hybrid below both alone in {wins} of {cases} cases "
              f"(weighted as for 19 samples: {fixed_wins}), above both in {worse}")


if __name__ == "__main__":
    main()
