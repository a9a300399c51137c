"""Validation reports: figures of each method against Cycles, sheets, report.json/.md.

Pure NumPy (no bpy): the Blender operator ``glossy.validate`` renders the
images and calls this; scripts can call it on their own renders.

Per object, from images (H, W, 3) of the whole frame and the object's mask
(H, W):

- ``cycles``: the mean of two Cycles renders with different seeds (the
  scene truth: the true BSDF, all light paths); its noise is
  :func:`bake.metrics.noise_of_mean`. When it is missing (a BRDF Cycles
  cannot render) the NumPy reference takes its place and the report says so.
- each method (``eevee_native``, ``eevee_native_careful``, ``eevee_glossy``,
  ``reference``) gets :func:`bake.metrics.compare` against the truth.
- ``glossy_vs_reference``: Glossy against the NumPy reference, the method's
  own error under distant lighting (no probe, parallax or occlusion error).
- with two Cycles seeds, each method's ``relative_rms_per_seed``: its relative
  RMS against each seed's render alone, so :func:`ordering` can tell whether
  one figure being below another holds whichever seed is the truth.
- with the pixels' n.v (``cos_view``), each method's ``by_view``
  (:func:`bake.metrics.by_view`): its error per band of view elevation and each
  band's share of it, so the report shows whether the error sits at grazing
  views (the silhouette) or facing the camera; report.md tabulates it per object.

The truth is flagged too noisy when its noise is not below a quarter of the
smallest error reported against it.

:func:`diagnosis` says where EEVEE Glossy's error against Cycles comes from,
from three figures the report already holds: the bake's own error (Glossy
against the NumPy reference over the same probe), what one probe cannot hold
(the reference against Cycles, less Cycles' noise in quadrature: the object's
reflections of itself, occlusion, nearby objects' parallax) and Cycles' noise.
A part is named the cause when its relative RMS is at least twice each other
part's (then it holds at least 4/5 of their squared sum).
"""

import datetime
import json
from pathlib import Path

import numpy as np

from . import metrics, outputs, preview
from .bitmap_font import GLYPHS, HEIGHT, WIDTH

__all__ = ["evaluate_object", "ordering", "deciding_pixels", "diagnosis", "object_sheet",
           "write_report", "markdown", "METHOD_TITLES"]

METHOD_TITLES = {
    "cycles": "Cycles",
    "eevee_native": "EEVEE native",
    "eevee_native_careful": "EEVEE native, no sun/clamp",
    "eevee_glossy": "EEVEE Glossy",
    "reference": "NumPy reference",
}
#: Noise of the truth must be below this fraction of every error reported against it.
NOISE_FRACTION = 0.25
#: A part of the error is its cause when at least this many times each other part
#: (relative RMS; 2 gives it at least 4/5 of their squared sum).
DOMINANT = 2.0


def evaluate_object(renders: dict, mask, cycles_seeds=None, cos_view=None) -> dict:
    """Figures of one object (JSON-ready).

    renders: {method: (H, W, 3) image or None}; cycles_seeds: (a, b) Cycles
    renders with different seeds, or None when Cycles cannot render the BRDF;
    cos_view: (H, W) n.v of each pixel (the shading normal and the direction to
    the camera), or None for no ``by_view`` figures.
    """
    mask = np.asarray(mask, bool)
    out = {"pixels": int(mask.sum()), "methods": {}}
    if cycles_seeds is not None:
        a, b = cycles_seeds
        truth = 0.5 * (np.asarray(a, np.float64) + np.asarray(b, np.float64))
        out["truth"] = "cycles"
        out["cycles_noise"] = metrics.noise_of_mean(a, b, mask)
    else:
        truth = renders.get("reference")
        out["truth"] = "reference"
        out["cycles_noise"] = None
    for method, image in renders.items():
        if image is None or (method == "reference" and out["truth"] == "reference"):
            continue
        out["methods"][method] = metrics.compare(image, truth, mask)
        if cos_view is not None:
            out["methods"][method]["by_view"] = metrics.by_view(image, truth, mask, cos_view)
        if cycles_seeds is not None:
            out["methods"][method]["relative_rms_per_seed"] = [
                metrics.relative_rms(image, seed, mask) for seed in cycles_seeds]
    if renders.get("eevee_glossy") is not None and renders.get("reference") is not None \
            and out["truth"] == "cycles":
        out["glossy_vs_reference"] = metrics.compare(renders["eevee_glossy"],
                                                     renders["reference"], mask)
        if cos_view is not None:
            out["glossy_vs_reference"]["by_view"] = metrics.by_view(
                renders["eevee_glossy"], renders["reference"], mask, cos_view)
    errors = [m["relative_rms"] for m in out["methods"].values()]
    out["truth_too_noisy"] = bool(out["cycles_noise"] is not None and errors
                                  and out["cycles_noise"] > NOISE_FRACTION * min(errors))
    found = diagnosis(out)
    if found is not None:
        out["diagnosis"] = found
    return out


def diagnosis(figures: dict):
    """Where EEVEE Glossy's error against Cycles comes from (module docstring), or None
    without a Cycles truth, Glossy's render or the NumPy reference.

    Returns {"cause": "bake" | "probe" | "noise" | "mixed", "bake": relative RMS of
    Glossy against the reference, "probe": the reference's against Cycles less
    Cycles' noise in quadrature, "noise": Cycles' noise, "text": one sentence}.
    """
    methods = figures.get("methods", {})
    if figures.get("truth") != "cycles" or "eevee_glossy" not in methods \
            or "reference" not in methods or "glossy_vs_reference" not in figures:
        return None
    noise = float(figures.get("cycles_noise") or 0.0)
    bake = float(figures["glossy_vs_reference"]["relative_rms"])
    reference = float(methods["reference"]["relative_rms"])
    probe = float(np.sqrt(max(reference**2 - noise**2, 0.0)))
    parts = {"bake": bake, "probe": probe, "noise": noise}
    cause = "mixed"
    for name, value in parts.items():
        if all(value >= DOMINANT * other for key, other in parts.items() if key != name):
            cause = name
    glossy = _percent(methods["eevee_glossy"]["relative_rms"])
    text = {
        "bake": f"most of Glossy's {glossy} is the bake's own error: it is {_percent(bake)} "
                f"from the NumPy reference over the same probe, which is "
                f"{_percent(reference)} from Cycles (a larger map, more slices, the Hybrid "
                "or Probe Lights reduce it)",
        "probe": f"most of Glossy's {glossy} is what one probe cannot hold: the NumPy "
                 f"reference over the same probe is {_percent(reference)} from Cycles and "
                 f"Glossy {_percent(bake)} from it (the object's reflections of itself, "
                 "occlusion, nearby objects' parallax; a finer bake will not reduce it)",
        "noise": f"most of Glossy's {glossy} is Cycles' own noise ({_percent(noise)}): "
                 "raise the validation samples",
        "mixed": f"Glossy's {glossy} has no single cause: the bake's own error "
                 f"{_percent(bake)} (against the NumPy reference), what the probe cannot "
                 f"hold {_percent(probe)}, Cycles' noise {_percent(noise)}",
    }[cause]
    return {"cause": cause, **parts, "text": text}


def ordering(first: dict, second: dict, method="eevee_glossy") -> dict:
    """Whether ``method``'s error in ``first`` is below its error in ``second``: two
    :func:`evaluate_object` figures of the same object and camera (two materials or
    methods rendered one after the other, each validated with the same Cycles seeds).

    Returns {"mean": bool (against the mean of the seeds: the reported figures),
    "per_seed": [bool, bool] or None (against each seed alone), "reference": bool
    or None (against the NumPy reference over the same probe, which has no noise:
    ``glossy_vs_reference``), "decided_by_noise": bool (the two seeds disagree, so
    Cycles' noise decides the order at this sample count)}.
    """
    a, b = first["methods"][method], second["methods"][method]
    seeds = None
    if "relative_rms_per_seed" in a and "relative_rms_per_seed" in b:
        seeds = [bool(x < y) for x, y in zip(a["relative_rms_per_seed"],
                                             b["relative_rms_per_seed"], strict=True)]
    reference = None
    if "glossy_vs_reference" in first and "glossy_vs_reference" in second \
            and method == "eevee_glossy":
        reference = bool(first["glossy_vs_reference"]["relative_rms"]
                         < second["glossy_vs_reference"]["relative_rms"])
    return {"mean": bool(a["relative_rms"] < b["relative_rms"]), "per_seed": seeds,
            "reference": reference,
            "decided_by_noise": bool(seeds is not None and seeds[0] != seeds[1])}


def deciding_pixels(first, second, truth, mask):
    """How few pixels decide which of two renders of the same object is closer to
    ``truth`` in relative RMS of luminance: the least k such that, leaving out the k
    pixels that favour the closer render most, the order reverses (or ties).

    first, second, truth: (H, W, 3) linear RGB; mask: (H, W) the object's pixels.
    Returns (k, pixels in the mask), or (0, pixels) when the two are level. A k
    of a handful of a sphere's thousands says the order is a few pixels' (a
    highlight's edge), not the method's over the surface: an isolated sphere
    in interior.exr at GGX 0.1 had the Hybrid 0.03 point above Runtime
    Sampling, and 5 pixels at one lamp's highlight held the whole gap."""
    mask = np.asarray(mask, bool)
    lum = [metrics.luminance(np.asarray(x, np.float64))[mask] for x in (first, second, truth)]
    # Per-pixel squared-error difference, positive where ``first`` is the further.
    gap = (lum[0] - lum[2]) ** 2 - (lum[1] - lum[2]) ** 2
    total = float(gap.sum())
    if total == 0.0:
        return 0, int(mask.sum())
    favour = np.sort(gap if total > 0 else -gap)[::-1]  # the closer render's best first
    # The running sum rises while the pixels favour the closer render; its top holds
    # at least the whole gap, so the first k at which it reaches it exists.
    reached = np.cumsum(favour) >= abs(total) * (1.0 - 1e-12)
    return int(np.argmax(reached)) + 1, int(mask.sum())


def _draw_text(image, text, x, y, colour=(255, 255, 255)):
    """Print ``text`` into uint8 ``image`` (H, W, 3) with its top-left corner at (x, y)."""
    for index, char in enumerate(text):
        code = ord(char) if 32 <= ord(char) < 127 else ord("?")
        row = GLYPHS[code - 32]
        bits = np.array([[int(row[2 * i:2 * i + 2], 16) >> (WIDTH - 1 - j) & 1
                          for j in range(WIDTH)] for i in range(HEIGHT)], dtype=bool)
        left = x + index * WIDTH
        h = min(HEIGHT, image.shape[0] - y)
        w = min(WIDTH, image.shape[1] - left)
        if h <= 0 or w <= 0:
            break
        region = image[y:y + h, left:left + w]
        region[bits[:h, :w]] = colour


def _crop_box(mask, margin=4):
    rows, cols = np.nonzero(mask)
    top = max(int(rows.min()) - margin, 0)
    left = max(int(cols.min()) - margin, 0)
    return (slice(top, min(int(rows.max()) + margin + 1, mask.shape[0])),
            slice(left, min(int(cols.max()) + margin + 1, mask.shape[1])))


def object_sheet(renders: dict, truth, mask, figures: dict, title: str, scale=None):
    """uint8 (H, W, 3) sheet: each render, the truth, signed and absolute error
    heatmaps of Glossy against the truth, each panel titled, figures printed below."""
    box = _crop_box(mask)
    exposure = metrics.exposure_for(truth, mask)
    panels = [("Cycles" if figures["truth"] == "cycles" else "Reference (truth)",
               preview.tonemap(truth[box], exposure))]
    for method in ("eevee_native", "eevee_native_careful", "eevee_glossy", "reference"):
        image = renders.get(method)
        if image is None or (method == "reference" and figures["truth"] == "reference"):
            continue
        panels.append((METHOD_TITLES[method], preview.tonemap(image[box], exposure)))
    glossy = renders.get("eevee_glossy")
    if glossy is not None:
        panels.append(("Glossy-truth signed", metrics.signed_heatmap(glossy[box], truth[box],
                                                                      mask[box])))
        panels.append(("|Glossy-truth|", metrics.absolute_heatmap(glossy[box], truth[box],
                                                                   mask[box])))
    height, width = panels[0][1].shape[:2]
    factor = scale or max(1, int(np.ceil(160 / max(height, width))))
    height, width = height * factor, width * factor
    label = HEIGHT + 4
    lines = _figure_lines(figures, title)
    sheet = np.full((label + height + 6 + len(lines) * (HEIGHT + 2) + 4,
                     len(panels) * (width + 4) + 4, 3), 24, dtype=np.uint8)
    for index, (name, image) in enumerate(panels):
        x = 4 + index * (width + 4)
        _draw_text(sheet, name[: max(1, width // WIDTH)], x, 2)
        sheet[label:label + height, x:x + width] = preview.upscale(image, factor)
    y = label + height + 6
    for line in lines:
        _draw_text(sheet, line[: max(1, (sheet.shape[1] - 8) // WIDTH)], 4, y)
        y += HEIGHT + 2
    return sheet


def _percent(value):
    return "n/a" if value is None else f"{100 * value:.1f}%"


def _figure_lines(figures, title):
    truth = "Cycles (2 seeds)" if figures["truth"] == "cycles" else "NumPy reference"
    lines = [f"{title}: {figures['pixels']} px, truth = {truth}"
             + (f", its noise {_percent(figures['cycles_noise'])}"
                if figures.get("cycles_noise") is not None else "")
             + (" - TOO NOISY" if figures.get("truth_too_noisy") else "")]
    for method, m in figures["methods"].items():
        flip = "" if m["flip"] is None else f" FLIP {m['flip']:.3f}"
        lines.append(f"{METHOD_TITLES[method]}: rel RMS {_percent(m['relative_rms'])}, bias "
                     f"{m['bias']:.3f}, PSNR {m['psnr_db']:.1f} dB, p90 "
                     f"{_percent(m['relative_error']['p90'])}{flip}")
    if "glossy_vs_reference" in figures:
        lines.append(f"Glossy vs NumPy reference (method error): rel RMS "
                     f"{_percent(figures['glossy_vs_reference']['relative_rms'])}")
    if "diagnosis" in figures:
        found = figures["diagnosis"]
        lines.append(f"Cause: {found['cause']} (bake {_percent(found['bake'])}, probe "
                     f"{_percent(found['probe'])}, noise {_percent(found['noise'])})")
    return lines


def markdown(report: dict) -> str:
    """report.md: the settings and one table row per object and method."""
    lines = [f"# Glossy validation ({report['date']})", "",
             f"- scene: {report.get('scene', '?')}, camera: {report.get('camera', '?')}",
             f"- {report['resolution'][0]} x {report['resolution'][1]} px, Cycles "
             f"{report['cycles_samples']} spp x 2 seeds, EEVEE {report['eevee_samples']} samples",
             f"- FLIP: {'yes' if report.get('flip') else 'not available (flip-evaluator absent)'}",
             ""]
    for note in report.get("notes", []):
        lines.append(f"- note: {note}")
    lines += ["", "| object | material | BRDF | truth | truth noise | method | rel. RMS | bias "
              "| PSNR dB | p90 | FLIP |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for entry in report["objects"]:
        figures = entry["figures"]
        for method, m in figures["methods"].items():
            flip = "-" if m["flip"] is None else f"{m['flip']:.3f}"
            lines.append(
                f"| {entry['object']} | {entry['material']} | `{entry['brdf']}` | "
                f"{figures['truth']} | {_percent(figures['cycles_noise'])} | "
                f"{METHOD_TITLES[method]} | {_percent(m['relative_rms'])} | {m['bias']:.3f} | "
                f"{m['psnr_db']:.1f} | {_percent(m['relative_error']['p90'])} | {flip} |")
        if "glossy_vs_reference" in figures:
            g = figures["glossy_vs_reference"]
            lines.append(f"| {entry['object']} | | | reference | | Glossy vs reference | "
                         f"{_percent(g['relative_rms'])} | {g['bias']:.3f} | {g['psnr_db']:.1f}"
                         f" | {_percent(g['relative_error']['p90'])} | - |")
    causes = [f"- {entry['object']}: {entry['figures']['diagnosis']['text']}"
              for entry in report["objects"] if "diagnosis" in entry["figures"]]
    if causes:
        lines += ["", "Where the error comes from (bake.validation.diagnosis):", "", *causes]
    for entry in report["objects"]:
        lines += _by_view_lines(entry)
    return "\n".join(lines) + "\n"


def _by_view_lines(entry) -> list:
    """report.md's table of one object's error by view elevation (none without
    ``by_view`` figures): per band of n.v that holds pixels, their count and each
    method's relative RMS with the band's share of that method's squared error."""
    figures = entry["figures"]
    methods = [(METHOD_TITLES[name], m["by_view"]) for name, m in figures["methods"].items()
               if "by_view" in m]
    if "by_view" in figures.get("glossy_vs_reference", {}):
        methods.append(("Glossy vs reference", figures["glossy_vs_reference"]["by_view"]))
    if not methods:
        return []
    lines = ["", f"{entry['object']} by view elevation (n.v; 0 at the silhouette): relative "
                 f"RMS in the band (the band's share of the object's squared error)", "",
             "| n.v | pixels | " + " | ".join(title for title, _ in methods) + " |",
             "|---|---|" + "---|" * len(methods)]
    for index, band in enumerate(methods[0][1]):
        if not band["pixels"]:
            continue
        cells = [f"{_percent(bands[index]['relative_rms'])} "
                 f"({100 * bands[index]['error_share']:.0f}%)" for _, bands in methods]
        lines.append(f"| {band['from']:.2f}-{band['to']:.2f} | {band['pixels']} | "
                     + " | ".join(cells) + " |")
    return lines


def _atomic_text(path: Path, text: str):
    outputs.atomic_write(path, lambda target: Path(target).write_text(text))


def write_report(folder, report: dict, sheets: dict) -> list:
    """Write sheets ({file name: uint8 image}), report.json and report.md into
    ``folder`` (each file atomically); returns the paths written."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    report = dict(report)
    report.setdefault("date", datetime.datetime.now().isoformat(timespec="seconds"))
    written = [preview.write_png(folder / name, image) for name, image in sheets.items()]
    _atomic_text(folder / "report.json", json.dumps(report, indent=2))
    _atomic_text(folder / "report.md", markdown(report))
    return written + [folder / "report.json", folder / "report.md"]
