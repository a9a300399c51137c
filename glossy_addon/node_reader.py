"""The BRDF of a material's own node tree, as a bake.brdf spec.

From the Material Output's Surface back through reroutes: Principled BSDF,
Metallic BSDF (GGX or Multiscatter GGX; F82 Tint or Physical Conductor: the
Principled BSDF's metal layer), Glossy BSDF (all four distributions), Diffuse
BSDF, Mix Shader (a constant factor, or Blender's Fresnel node) and Add Shader
of these. The spec is exact
where Cycles' formulas allow it (bake.brdf.principled, bake.brdf.cycles);
everything else is listed, never dropped silently:

- ``ignored``: what the spec leaves out (transmission, subsurface, sheen,
  alpha (but a lone Principled BSDF's, which the lookup applies:
  glossy_addon.transparency), thin film, Oren-Nayar diffuse roughness, normal maps and other
  links into Normal / Coat Normal / Tangent, transparent shaders inside a
  mix); emission (a Principled BSDF's, Emission shaders) is not part of the
  BRDF either, but the attached lookup adds it (glossy_addon.emission), so it
  is listed under ``approximated``;
- ``approximated``: inputs driven by links, taken at one value (an Image
  Texture at its mean, an RGB or Value node at its value, anything else at the
  socket's own unlinked value);
- a tree Glossy cannot read at all (no surface, pure emission, volume only, a
  node group, an unknown shader) raises NodeReadError with the reason.

The reader only reads: it never changes the material.
"""

import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from ..bake.errors import BakeError
from .image_colour import linear_rgb

#: Glossy BSDF distributions and the bake.brdf model of each (CYCLES.md).
GLOSSY_MODELS = {"GGX": "ggx", "BECKMANN": "beckmann", "ASHIKHMIN_SHIRLEY": "ashikhmin_shirley",
                 "MULTI_GGX": "ggx_multiscatter"}
#: Rec. 709 luminance: how Blender converts a colour link into a float socket.
LUMINANCE = (0.2126, 0.7152, 0.0722)
#: The BSDF nodes the reader reads (and plans per-pixel inputs of).
BSDF_NODES = ("ShaderNodeBsdfPrincipled", "ShaderNodeBsdfDiffuse", "ShaderNodeBsdfAnisotropic",
              "ShaderNodeBsdfGlossy", "ShaderNodeBsdfMetallic")
#: Below this roughness Cycles renders a perfect mirror (CYCLES.md).
MIN_ROUGHNESS = 0.01
#: A colour applied per pixel is baked at its mean, each channel at least this
#: (the per-pixel factor divides by it).
COLOUR_FLOOR = 1e-3


class NodeReadError(BakeError):
    """The material's node tree holds no BSDF Glossy can read."""


@dataclass
class Derived:
    """What the reader found: ``spec`` (bake.brdf), and the lists of the module docstring.

    ``inputs``: {input label: value} of every BRDF-relevant input (the staleness
    hash); ``images``: identities of the images read (name, file, size);
    ``spatial``: what the attached lookup applies per pixel (see
    :func:`spatial_inputs`): {"colour": {"node", "input", "mean" (3,), "part":
    "glossy" | "diffuse", "exact", "split" (a metal's two-map split,
    bake.colour_response)}, "normal": {"node", "input"}, "roughness":
    {"node", "input", "low", "high"}}, node and input names of the tree read.
    """

    spec: str
    ignored: list = field(default_factory=list)
    approximated: list = field(default_factory=list)
    inputs: dict = field(default_factory=dict)
    images: list = field(default_factory=list)
    spatial: dict = field(default_factory=dict)

    def digest(self) -> str:
        """Hash of the derived spec and the images' identities (16 hex digits)."""
        text = json.dumps({"spec": self.spec, "images": self.images}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def inputs_json(self) -> str:
        return json.dumps(self.inputs, sort_keys=True)


def _fmt(value) -> str:
    values = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if np.allclose(values, values[0]):
        return f"{values[0]:.6g}"
    return "/".join(f"{v:.6g}" for v in values)


class _Reader:
    def __init__(self, material):
        self.material = material
        self.derived = Derived(spec="")
        #: {(node name, input name): plan} of the inputs applied per pixel (plan_spatial)
        self.per_pixel = {}

    # --- sockets ---------------------------------------------------------------------------
    @staticmethod
    def _source(socket):
        """(node, output socket) feeding ``socket`` through reroutes, or (None, None)."""
        while socket.is_linked:
            link = socket.links[0]
            if not link.is_valid or link.is_muted:
                return None, None
            node = link.from_node
            if node.bl_idname == "NodeReroute":
                socket = node.inputs[0]
                continue
            return node, link.from_socket
        return None, None

    def _image_values(self, node, output, colour):
        """Per-pixel values of an Image Texture output: (N, 3) linear RGB, or (N,)
        for a float socket (alpha, or Blender's luminance of the colour)."""
        image = node.image
        pixels = np.empty(len(image.pixels), dtype=np.float32)
        image.pixels.foreach_get(pixels)
        channels = max(int(image.channels), 1)
        pixels = pixels.reshape(-1, channels).astype(np.float64)
        rgb = pixels[:, :3] if channels >= 3 else np.repeat(pixels[:, :1], 3, axis=1)
        rgb = linear_rgb(rgb, image)
        if output.name == "Alpha" and channels == 4:
            rgb = np.repeat(pixels[:, 3:4], 3, axis=1)
        self.derived.images.append([image.name, image.filepath, list(image.size)])
        return rgb if colour else rgb @ np.asarray(LUMINANCE)

    def _image_mean(self, node, output, colour):
        return self._image_values(node, output, colour).mean(axis=0)

    def _image_channel(self, socket):
        """(Image Texture node, its output, channel) where ``socket`` is fed by one
        channel of an image's colour through a Separate Color (RGB mode) or
        Separate XYZ node, as glTF imports pack roughness and metallic (G and B
        of one image); channel None where the image feeds it directly; None for
        anything else (or an image without pixels)."""
        source, output = self._source(socket)
        channel = None
        if source is not None and (source.bl_idname == "ShaderNodeSeparateXYZ" or
                                   source.bl_idname == "ShaderNodeSeparateColor"
                                   and source.mode == "RGB"):
            channel = {"Red": 0, "Green": 1, "Blue": 2, "X": 0, "Y": 1, "Z": 2}.get(
                output.name)
            source, output = self._source(source.inputs[0])
            if channel is None or output is None or output.name != "Color":
                return None
        if source is None or source.bl_idname != "ShaderNodeTexImage" or \
                source.image is None or not len(source.image.pixels):
            return None
        return source, output, channel

    def _channel_values(self, found, colour):
        """Per-pixel values (N, 3) or (N,) of :meth:`_image_channel`'s ``found``."""
        node, output, channel = found
        if channel is None:
            return self._image_values(node, output, colour)
        values = self._image_values(node, output, True)[:, channel]
        return np.repeat(values[:, None], 3, axis=1) if colour else values

    def value(self, node, name, label=None):
        """The value of input ``name`` of ``node`` (float or (3,) array), noting links."""
        socket = node.inputs[name]
        colour = socket.type == "RGBA"
        label = f"{node.name}: {label or name}"
        source, output = self._source(socket)
        own = socket.default_value
        own = np.asarray(own[:3], dtype=np.float64) if colour else float(own)
        if source is None:
            value = own
        elif source.bl_idname in ("ShaderNodeRGB", "ShaderNodeValue"):
            raw = output.default_value
            if colour:
                value = np.asarray(raw[:3] if hasattr(raw, "__len__") else [raw] * 3, float)
            else:
                value = float(np.dot(raw[:3], LUMINANCE)) if hasattr(raw, "__len__") \
                    else float(raw)
        elif self._image_channel(socket) is not None:
            found = self._image_channel(socket)
            values = self._channel_values(found, colour)
            value = values.mean(axis=0)
            plan = self.per_pixel.get((node.name, name))
            what = f"image '{found[0].image.name}'" + (
                "" if found[2] is None else f" (its {'RGB'[found[2]]} channel)")
            if plan is None:
                self.derived.approximated.append(
                    f"{label}: {what} taken at its mean ({_fmt(value)}); "
                    f"the texture stays in the material but is not applied per pixel")
            elif plan["kind"] == "roughness":
                low, high = np.percentile(values, [1.0, 99.0])
                plan.update(low=float(np.clip(low, 0.0, 1.0)), high=float(np.clip(high, 0, 1)))
        elif (node.name, name) in self.per_pixel and \
                self.per_pixel[(node.name, name)]["kind"] in ("colour", "tint", "metallic",
                                                              "coat_tint"):
            value = own
        else:
            value = own
            self.derived.approximated.append(
                f"{label}: driven by '{source.name}' ({source.bl_idname}); its unlinked value "
                f"{_fmt(own)} is used")
        self.derived.inputs[label] = np.round(np.atleast_1d(value), 6).tolist()
        return value

    def linked(self, node, name):
        socket = node.inputs.get(name)
        return socket is not None and self._source(socket)[0] is not None

    # --- shaders ---------------------------------------------------------------------------
    def colour(self, node, name):
        """A colour input in [0, 1]; one applied per pixel at least COLOUR_FLOOR."""
        colour = np.clip(self.value(node, name), 0.0, 1.0)
        if (node.name, name) in self.per_pixel:
            colour = np.maximum(colour, COLOUR_FLOOR)
        return colour

    def varying(self, node, name) -> bool:
        """True if input ``name`` is driven by a node chain (not an RGB / Value node)."""
        socket = node.inputs.get(name)
        source = self._source(socket)[0] if socket is not None else None
        return source is not None and source.bl_idname not in ("ShaderNodeRGB",
                                                                "ShaderNodeValue")

    def _bsdf_nodes(self, socket, found):
        """The BSDF nodes (Principled, Diffuse, Glossy) reached from shader ``socket``
        through Mix and Add Shaders, appended to ``found`` once each."""
        source = self._source(socket)[0]
        if source is None:
            return found
        if source.bl_idname in ("ShaderNodeMixShader", "ShaderNodeAddShader"):
            for child in source.inputs:
                if child.type == "SHADER":
                    self._bsdf_nodes(child, found)
        elif source.bl_idname in BSDF_NODES and source not in found:
            found.append(source)
        return found

    def plan_spatial(self, surface):
        """Which inputs the lookup applies per pixel (glossy_addon.spatial), from the
        BSDFs the Material Output's ``surface`` socket reaches: for a single BSDF
        see :meth:`plan_single`; for several (through Mix and Add Shaders) a colour
        texture where its node alone makes a part (the diffuse part of the only
        diffuse BSDF, the glossy part of the only glossy one: a factor, exact as
        the single BSDF's), the Normal where every BSDF takes the same link, and a
        Roughness image where one BSDF alone has a roughness."""
        nodes = self._bsdf_nodes(surface, [])
        if len(nodes) == 1:
            self.plan_single(nodes[0])
            return
        if not nodes:
            return
        contributions = [self._parts_of(node) for node in nodes]
        for node, (colour_input, part, exact, _) in zip(nodes, contributions, strict=True):
            others = [made for other, (_, _, _, made) in zip(nodes, contributions, strict=True)
                      if other is not node]
            if part is not None and self.varying(node, colour_input) and \
                    not any(part in made for made in others):
                self.per_pixel[(node.name, colour_input)] = {
                    "kind": "colour", "node": node.name, "input": colour_input, "part": part,
                    "exact": exact, "split": False}
        sources = {self._source(node.inputs["Normal"])[1] for node in nodes}
        if len(sources) == 1 and None not in sources:
            for node in nodes:
                self.per_pixel[(node.name, "Normal")] = {"kind": "normal", "node": node.name,
                                                         "input": "Normal"}
        rough = [node for node in nodes if node.bl_idname != "ShaderNodeBsdfDiffuse"]
        if len(rough) == 1:
            self._plan_roughness(rough[0])

    def _parts_of(self, node):
        """(colour input, the part linear in it or None, exact, every part the node
        makes) of a BSDF node: a Diffuse BSDF makes the diffuse part, a Glossy BSDF
        the glossy part (its colour exact but for Multiscatter GGX's energy term),
        a Principled both (its base colour the diffuse layer's alone when
        Metallic is 0; a metal's glossy part, approximate)."""
        kind = node.bl_idname
        if kind == "ShaderNodeBsdfDiffuse":
            return "Color", "diffuse", True, {"diffuse"}
        if kind == "ShaderNodeBsdfMetallic":  # a physical conductor takes no colour
            return "Base Color", "glossy" if node.fresnel_type == "F82" else None, False, \
                {"glossy"}
        if kind != "ShaderNodeBsdfPrincipled":
            return "Color", "glossy", node.distribution != "MULTI_GGX", {"glossy"}
        metallic = float(node.inputs["Metallic"].default_value)
        if self.linked(node, "Metallic") or 0.0 < metallic < 1.0:
            return "Base Color", None, False, {"diffuse", "glossy"}
        if metallic == 0.0:
            return "Base Color", "diffuse", True, {"diffuse", "glossy"}
        return "Base Color", "glossy", False, {"glossy"}

    def _plan_roughness(self, node):
        if "Roughness" in node.inputs and \
                self._image_channel(node.inputs["Roughness"]) is not None:
            self.per_pixel[(node.name, "Roughness")] = {"kind": "roughness", "node": node.name,
                                                        "input": "Roughness"}

    def plan_single(self, top):
        """Which inputs of the surface's only BSDF node ``top`` the lookup applies per
        pixel (module docstring of glossy_addon.spatial): its colour where the
        reflection is linear in it, its Normal, its Roughness from an image."""
        kind = top.bl_idname
        principled = kind == "ShaderNodeBsdfPrincipled"
        # The Metallic BSDF with F82 Tint is the Principled BSDF's metal (its Edge
        # Tint the Specular Tint); a physical conductor's colour is its n and k.
        f82_metal = kind == "ShaderNodeBsdfMetallic" and top.fresnel_type == "F82"
        colour_input, part, exact, split = "Color", "glossy", True, False
        metallic_varies = principled and self.varying(top, "Metallic")
        if metallic_varies:
            # A metallic texture: maps at Metallic 0 and 1 mixed per pixel (the
            # Principled BSDF is affine in it); the colour scales the diffuse part
            # and is split for the metal.
            colour_input, part, exact, split = "Base Color", "diffuse", True, True
            self.per_pixel[(top.name, "Metallic")] = {"kind": "metallic", "node": top.name,
                                                      "input": "Metallic"}
        elif principled:
            colour_input = "Base Color"
            metallic = float(top.inputs["Metallic"].default_value)
            part = None if self.linked(top, "Metallic") or 0.0 < metallic < 1.0 else \
                "diffuse" if metallic == 0.0 else "glossy"
            # A metal: two maps (base colours 0 and 1; a third of the coat alone) and
            # the energy term give the reflection at any colour exactly
            # (bake.colour_response).
            split = part == "glossy"
            exact = True
        elif kind == "ShaderNodeBsdfMetallic":
            colour_input = "Base Color"
            part, split, exact = ("glossy", True, True) if f82_metal else (None, False, False)
        elif kind == "ShaderNodeBsdfDiffuse":
            part = "diffuse"
        else:
            # Multiscatter GGX's energy term is not linear in the colour: split
            # (a white map times c and the energy term, bake.colour_response).
            split = top.distribution == "MULTI_GGX"
        if part is not None and self.varying(top, colour_input):
            self.per_pixel[(top.name, colour_input)] = {
                "kind": "colour", "node": top.name, "input": colour_input, "part": part,
                "exact": exact, "split": split}
        # The specular tint of a metal or dielectric: split like a metal's base colour
        # (one split per material: the base colour's comes first).
        tint_input = "Edge Tint" if f82_metal else "Specular Tint"
        if (principled or f82_metal) and part in ("glossy", "diffuse") and \
                not metallic_varies and self.varying(top, tint_input) and \
                not (split and (top.name, colour_input) in self.per_pixel):
            self.per_pixel[(top.name, tint_input)] = {
                "kind": "tint", "node": top.name, "input": tint_input, "split": True,
                "part": part}
        # A coat tint texture: a map of the coat alone, and everything below the
        # coat scaled per pixel by a function of the tint and the view
        # (bake.colour_response.coat_tint_factor).
        if principled and self.varying(top, "Coat Tint") and \
                not self.linked(top, "Coat Weight") and not self.linked(top, "Coat IOR") and \
                float(top.inputs["Coat Weight"].default_value) > 0.0:
            self.per_pixel[(top.name, "Coat Tint")] = {"kind": "coat_tint", "node": top.name,
                                                       "input": "Coat Tint"}
        if self.linked(top, "Normal"):
            self.per_pixel[(top.name, "Normal")] = {"kind": "normal", "node": top.name,
                                                    "input": "Normal"}
        if kind != "ShaderNodeBsdfDiffuse":
            self._plan_roughness(top)

    def verify_split(self, model):
        """Keep a split plan only where bake.colour_response splits the glossy part of
        ``model``: a colour plan falls back to the factor, a tint plan to its value
        (noted as taken at its value)."""
        from ..bake.brdf.split import split
        from ..bake.colour_response import response, with_metallic

        glossy, _ = split(model)
        metallic = any(plan["kind"] == "metallic" for plan in self.per_pixel.values())
        if metallic and with_metallic(glossy, 1.0) is None:  # not a Principled glossy part
            self.per_pixel = {key: plan for key, plan in self.per_pixel.items()
                              if plan["kind"] != "metallic"}
            metallic = False
        for key, plan in list(self.per_pixel.items()):
            if not plan.get("split"):
                continue
            parameter = "base_color" if plan["kind"] == "colour" else "specular_tint"
            part = with_metallic(glossy, 1.0) if metallic else glossy
            if part is not None and response(part, parameter) is not None:
                continue
            if plan["kind"] == "colour":
                plan["split"] = False
                plan["exact"] = plan["part"] == "diffuse"
            else:
                del self.per_pixel[key]
                label = f"{key[0]}: {key[1]}"
                self.derived.approximated.append(
                    f"{label}: taken at {_fmt(self.derived.inputs[label])}; the link stays in "
                    "the material but is not applied per pixel")

    def spatial_notes(self):
        """Derived.spatial and one 'approximated' line per input applied per pixel."""
        d = self.derived
        for (node_name, name), plan in self.per_pixel.items():
            label = f"{node_name}: {name}"
            if plan["kind"] == "colour" and "metallic" in {p["kind"] for p in
                                                           self.per_pixel.values()}:
                mean = np.maximum(np.clip(d.inputs[label], 0.0, 1.0), COLOUR_FLOOR)
                plan["mean"] = [float(c) for c in mean]
                d.approximated.append(
                    f"{label}: applied per pixel as a factor of the diffuse part baked at "
                    f"{_fmt(mean)} (exact) and to the metal through maps baked at base colours "
                    f"0 and 1{' (exact: bake.colour_response)' if plan['split'] else ''}")
                d.spatial[plan["kind"]] = {k: v for k, v in plan.items() if k != "kind"}
                continue
            if plan["kind"] == "coat_tint":
                plan.update(mean=[float(c) for c in np.clip(d.inputs[label], 0.0, 1.0)],
                            coat=float(np.ravel(d.inputs[f"{node_name}: Coat Weight"])[0]),
                            ior=float(np.ravel(d.inputs[f"{node_name}: Coat IOR"])[0]))
                d.approximated.append(
                    f"{label}: applied per pixel: a map of the coat alone, and the layers below "
                    "the coat (glossy and diffuse) scaled by T(tint, n.v) / T(mean, n.v) "
                    "(exact: bake.colour_response.coat_tint_factor; the Hybrid and Runtime "
                    "Sampling methods take the glossy part at the mean)")
                d.spatial[plan["kind"]] = {k: v for k, v in plan.items() if k != "kind"}
                continue
            if plan["kind"] == "metallic":
                plan["mean"] = float(np.clip(np.ravel(d.inputs[label])[0], 0.0, 1.0))
                d.approximated.append(
                    f"{label}: applied per pixel: maps baked at Metallic 0 and 1 mixed by it "
                    f"and the diffuse part scaled by (1 - metallic) / (1 - {plan['mean']:.3g}) "
                    "(exact: the Principled BSDF is affine in it)")
                d.spatial[plan["kind"]] = {k: v for k, v in plan.items() if k != "kind"}
                continue
            if plan["kind"] == "colour":
                mean = np.maximum(np.clip(d.inputs[label], 0.0, 1.0), COLOUR_FLOOR)
                plan["mean"] = [float(c) for c in mean]
                if plan["split"] and plan["input"] == "Color":  # a Multiscatter Glossy BSDF
                    d.approximated.append(
                        f"{label}: applied per pixel through a white map times the colour and "
                        "the Multiscatter energy term (exact: bake.colour_response; the Hybrid "
                        f"and Runtime Sampling methods scale the part baked at {_fmt(mean)})")
                    d.spatial[plan["kind"]] = {k: v for k, v in plan.items() if k != "kind"}
                    continue
                if plan["split"]:
                    d.approximated.append(
                        f"{label}: applied per pixel to the metal through maps baked at base "
                        "colours 0 and 1 (and the coat alone, if any) and the Multiscatter "
                        "energy term (exact: "
                        "bake.colour_response; the Hybrid and Runtime Sampling methods "
                        f"scale the part baked at {_fmt(mean)} instead)")
                    d.spatial[plan["kind"]] = {k: v for k, v in plan.items() if k != "kind"}
                    continue
                how = "exact: the reflection is linear in it" if plan["exact"] else \
                    ("approximate: the metal's Fresnel colour at grazing angles follows the "
                     "baked mean" if plan["part"] == "glossy" else "approximate")
                d.approximated.append(f"{label}: applied per pixel as a factor of the "
                                      f"{plan['part']} part baked at {_fmt(mean)} ({how})")
            elif plan["kind"] == "tint":
                diffuse = " (the diffuse layer's weight below follows the tint's value here: "\
                    "it changes by at most F0 of the diffuse)" if plan["part"] == "diffuse" \
                    else ""
                d.approximated.append(
                    f"{label}: applied per pixel through maps baked at tints 0 and 1 and the "
                    "Multiscatter energy term (exact for the reflection: "
                    f"bake.colour_response){diffuse}; the Hybrid and Runtime Sampling methods "
                    f"take its value {_fmt(d.inputs[label])}")
            elif plan["kind"] == "normal":
                d.approximated.append(f"{label}: the linked normal (normal or bump map) feeds "
                                      "the lookup's normal per pixel")
            elif "low" in plan:
                d.approximated.append(
                    f"{label}: varies from {plan['low']:.3g} to {plan['high']:.3g} (1st-99th "
                    "percentile): the map is baked at a few roughness values and blended per "
                    "pixel")
            d.spatial[plan["kind"]] = {k: v for k, v in plan.items() if k != "kind"}

    def shader(self, socket, path):
        source, _ = self._source(socket)
        if source is None:
            raise NodeReadError(f"{self.material.name}: {path} has no shader connected")
        kind = source.bl_idname
        if kind == "ShaderNodeBsdfPrincipled":
            return self.principled(source)
        if kind in ("ShaderNodeBsdfAnisotropic", "ShaderNodeBsdfGlossy"):
            return self.glossy(source)
        if kind == "ShaderNodeBsdfMetallic":
            return self.metallic(source)
        if kind == "ShaderNodeBsdfDiffuse":
            return self.diffuse(source)
        if kind == "ShaderNodeAddShader":
            parts = [self.shader(s, f"{path} > {source.name}") for s in source.inputs]
            parts = [p for p in parts if p]
            return None if not parts else parts[0] if len(parts) == 1 else \
                f"sum({'; '.join(parts)})"
        if kind == "ShaderNodeMixShader":
            return self.mix(source, path)
        if kind == "ShaderNodeGroup":
            raise NodeReadError(f"{self.material.name}: the surface goes through the node "
                                f"group '{source.name}', which Glossy cannot see into: "
                                "ungroup it (Ctrl+Alt+G) or choose another BRDF source")
        if kind == "ShaderNodeEmission":
            self.derived.approximated.append(
                f"{source.name}: Emission (no reflection): the lookup adds what it emits "
                "(glossy_addon.emission)")
            return None
        if kind in ("ShaderNodeBsdfTransparent", "ShaderNodeHoldout"):
            self.derived.ignored.append(f"{source.name}: {source.bl_label} (no reflection)")
            return None
        raise NodeReadError(f"{self.material.name}: Glossy cannot read the {source.bl_label} "
                            f"node '{source.name}' (it reads Principled, Metallic, Glossy and "
                            "Diffuse BSDFs, Mix and Add Shaders)")

    def mix(self, node, path):
        first = self.shader(node.inputs[1], f"{path} > {node.name}")
        second = self.shader(node.inputs[2], f"{path} > {node.name}")
        fac_source, _ = self._source(node.inputs["Fac"])
        black = "lambert:color=0"
        if fac_source is not None and fac_source.bl_idname == "ShaderNodeFresnel" \
                and not self.linked(fac_source, "IOR") and not self.linked(fac_source, "Normal"):
            ior = float(fac_source.inputs["IOR"].default_value)
            self.derived.inputs[f"{node.name}: Fresnel IOR"] = [round(ior, 6)]
            if ior > 1.0:
                return f"fresnel_mix(ior={ior:.6g}; {first or black}; {second or black})"
            fac = 0.0 if ior == 1.0 else 1.0
        else:
            fac = float(np.clip(self.value(node, "Fac"), 0.0, 1.0))
        parts = []
        if first and fac < 1.0:
            parts.append(first if fac == 0.0 else f"scale(k={1.0 - fac:.6g}; {first})")
        if second and fac > 0.0:
            parts.append(second if fac == 1.0 else f"scale(k={fac:.6g}; {second})")
        return None if not parts else parts[0] if len(parts) == 1 else \
            f"sum({'; '.join(parts)})"

    def _roughness(self, node, name="Roughness"):
        roughness = float(np.clip(self.value(node, name), 0.0, 1.0))
        if roughness < MIN_ROUGHNESS:
            self.derived.approximated.append(
                f"{node.name}: {name} {roughness:.3g} is below {MIN_ROUGHNESS} (Cycles renders "
                f"a perfect mirror); Glossy uses {MIN_ROUGHNESS}")
            roughness = MIN_ROUGHNESS
        return roughness

    def _note_normal(self, node, names=("Normal",)):
        for name in names:
            if (node.name, name) in self.per_pixel:
                continue
            if self.linked(node, name):
                self.derived.ignored.append(f"{node.name}: the link into {name} (normal or bump "
                                            "maps are not applied)")

    def glossy(self, node):
        roughness = self._roughness(node)
        anisotropy = float(np.clip(self.value(node, "Anisotropy"), -1.0, 1.0)) \
            if "Anisotropy" in node.inputs else 0.0
        rotation = float(self.value(node, "Rotation")) % 1.0 if "Rotation" in node.inputs \
            else 0.0
        colour = self.colour(node, "Color")
        self._note_normal(node, ("Normal", "Tangent"))
        model = GLOSSY_MODELS[node.distribution]
        return (f"{model}:roughness={roughness:.6g},anisotropy={anisotropy:.6g},"
                f"rotation={rotation:.6g},color={_fmt(colour)}")

    def _vector(self, node, name, low, high):
        """A vector input (3,) (the Metallic BSDF's IOR and Extinction) clipped to
        [low, high]; a link is noted and its unlinked value used."""
        socket = node.inputs[name]
        value = np.clip(np.asarray(socket.default_value[:3], dtype=np.float64), low, high)
        source, _ = self._source(socket)
        label = f"{node.name}: {name}"
        if source is not None:
            self.derived.approximated.append(
                f"{label}: driven by '{source.name}' ({source.bl_idname}); its unlinked value "
                f"{_fmt(value)} is used")
        self.derived.inputs[label] = np.round(value, 6).tolist()
        return value

    def metallic(self, node):
        """Cycles' Metallic BSDF as the Principled BSDF's metal layer (bake.brdf.principled):
        the same GGX (alpha = Roughness^2, the Principled anisotropy mapping) and
        multiscatter energy term, with the F82-tint Fresnel (Base Color, Edge Tint)
        or the physical conductor's (IOR n + i Extinction k)."""
        if node.distribution == "BECKMANN":
            raise NodeReadError(
                f"{self.material.name}: the Metallic BSDF '{node.name}' uses the Beckmann "
                "distribution, which Glossy reads in the Glossy BSDF only: choose GGX or "
                "Multiscatter GGX on the Metallic BSDF")
        if self.linked(node, "Thin Film Thickness") or \
                float(node.inputs["Thin Film Thickness"].default_value) > 0.0:
            self.derived.ignored.append(f"{node.name}: thin film (Thin Film Thickness)")
        self._note_normal(node, ("Normal", "Tangent"))
        values = {"metallic": "1", "roughness": _fmt(self._roughness(node))}
        if node.fresnel_type == "F82":
            values["base_color"] = _fmt(self.colour(node, "Base Color"))
            values["specular_tint"] = _fmt(np.clip(self.value(node, "Edge Tint"), 0, 1))
        values["anisotropy"] = _fmt(np.clip(self.value(node, "Anisotropy"), 0, 1))
        values["rotation"] = _fmt(float(self.value(node, "Rotation")) % 1.0)
        values["multiscatter"] = "1" if node.distribution == "MULTI_GGX" else "0"
        if node.fresnel_type != "F82":  # PHYSICAL_CONDUCTOR
            values["conductor_ior"] = _fmt(self._vector(node, "IOR", 0.0, 100.0))
            values["conductor_extinction"] = _fmt(self._vector(node, "Extinction", 0.0, 100.0))
        return "principled:" + ",".join(f"{k}={v}" for k, v in values.items())

    def diffuse(self, node):
        colour = self.colour(node, "Color")
        if float(self.value(node, "Roughness")) > 0.0:
            self.derived.approximated.append(f"{node.name}: Roughness > 0 (Oren-Nayar) is "
                                             "taken as Lambert")
        self._note_normal(node)
        return f"lambert:color={_fmt(colour)}"

    def principled(self, node):
        d = self.derived
        for name, unit in (("Transmission Weight", "transmission"),
                           ("Subsurface Weight", "subsurface"), ("Sheen Weight", "sheen"),
                           ("Thin Film Thickness", "thin film")):
            if name in node.inputs and (self.linked(node, name)
                                        or float(node.inputs[name].default_value) > 0.0):
                d.ignored.append(f"{node.name}: {unit} ({name})")
        if "Emission Strength" in node.inputs and (
                self.linked(node, "Emission Color") or self.linked(node, "Emission Strength")
                or float(node.inputs["Emission Strength"].default_value) > 0.0
                and any(node.inputs["Emission Color"].default_value[:3])):
            d.approximated.append(f"{node.name}: emission: not baked; the lookup adds it as "
                                  "Cycles emits it, below the coat (glossy_addon.emission)")
        if self.linked(node, "Alpha") or float(node.inputs["Alpha"].default_value) < 1.0:
            d.ignored.append(f"{node.name}: alpha (transparency)")
        if "Diffuse Roughness" in node.inputs and (
                self.linked(node, "Diffuse Roughness")
                or float(node.inputs["Diffuse Roughness"].default_value) > 0.0):
            d.approximated.append(f"{node.name}: Diffuse Roughness > 0 (Oren-Nayar) is taken "
                                  "as Lambert")
        self._note_normal(node, ("Normal", "Coat Normal", "Tangent"))
        base = self.colour(node, "Base Color")
        values = {
            "base_color": _fmt(base),
            "metallic": _fmt(np.clip(self.value(node, "Metallic"), 0, 1)),
            "roughness": _fmt(self._roughness(node)),
            "ior": _fmt(np.clip(self.value(node, "IOR"), 1.0, 10.0)),
            "specular_ior_level": _fmt(np.clip(self.value(node, "Specular IOR Level"), 0, 1)),
            "specular_tint": _fmt(np.clip(self.value(node, "Specular Tint"), 0, 1)),
            "anisotropy": _fmt(np.clip(self.value(node, "Anisotropic"), 0, 1)),
            "rotation": _fmt(float(self.value(node, "Anisotropic Rotation")) % 1.0),
            "coat_weight": _fmt(np.clip(self.value(node, "Coat Weight"), 0, 1)),
        }
        if float(values["coat_weight"]) > 0.0:
            values["coat_roughness"] = _fmt(max(float(np.clip(
                self.value(node, "Coat Roughness"), 0, 1)), MIN_ROUGHNESS))
            values["coat_ior"] = _fmt(np.clip(self.value(node, "Coat IOR"), 1.0, 10.0))
            values["coat_tint"] = _fmt(np.clip(self.value(node, "Coat Tint"), 0, 1))
        if float(node.inputs["IOR"].default_value) < 1.0 and not self.linked(node, "IOR"):
            d.approximated.append(f"{node.name}: IOR below 1 is taken as 1")
        values["multiscatter"] = "1" if node.distribution == "MULTI_GGX" else "0"
        return "principled:" + ",".join(f"{k}={v}" for k, v in values.items())


def output_node(material):
    """The Material Output Cycles renders (active, target All or Cycles), or None;
    in a material with Glossy's lookup attached, the user's own output (the
    lookup's output is active there, glossy_addon.nodes.user_output)."""
    if not material.use_nodes or material.node_tree is None:
        return None
    tree = material.node_tree
    from .nodes import is_lookup_node, user_output

    if any(is_lookup_node(node) for node in tree.nodes):
        node = user_output(material)
        return node if node is not None and node.target in ("ALL", "CYCLES") else None
    for target in ("CYCLES", "ALL"):
        try:
            node = tree.get_output_node(target)
        except (TypeError, ValueError):
            node = None
        if node is not None:
            return node
    return None


def read_material(material) -> Derived:
    """The Derived BRDF of ``material``'s nodes; NodeReadError if there is none."""
    from ..bake import brdf

    output = output_node(material)
    if output is None:
        raise NodeReadError(f"{material.name}: no Material Output node (or nodes are off)")
    reader = _Reader(material)
    if output.inputs["Volume"].is_linked and not output.inputs["Surface"].is_linked:
        raise NodeReadError(f"{material.name}: a volume-only material has no surface BRDF")
    if output.inputs["Volume"].is_linked:
        reader.derived.ignored.append(f"{output.name}: the volume shader")
    if output.inputs["Displacement"].is_linked:
        reader.derived.ignored.append(f"{output.name}: displacement")
    from .transparency import alpha_input, transparent_mix

    # A Mix Shader of a Transparent BSDF at the surface: the other shader is baked
    # whole, and the lookup mixes the Transparent BSDF in by the same Fac.
    cut = transparent_mix(output.inputs["Surface"])
    surface = cut[0].inputs[cut[1]] if cut is not None else output.inputs["Surface"]
    reader.plan_spatial(surface)
    spec = reader.shader(surface, output.name if cut is None else
                         f"{output.name} > {cut[0].name}")
    if cut is not None:
        reader.derived.approximated.append(
            f"{cut[0].name}: its Transparent BSDF: not baked; the lookup mixes it in by "
            "the same Fac, as Cycles does (glossy_addon.transparency)")
    if not spec:
        raise NodeReadError(f"{material.name}: the surface reflects nothing Glossy can bake "
                            f"({'; '.join(reader.derived.ignored) or 'no BSDF'})")
    try:
        model = brdf.parse(spec)
    except BakeError as error:
        raise NodeReadError(f"{material.name}: {error}") from None
    reader.verify_split(model)
    reader.spatial_notes()
    if cut is None and alpha_input(output.inputs["Surface"]) is not None:  # applied
        derived = reader.derived
        for line in [line for line in derived.ignored if line.endswith(": alpha (transparency)")]:
            derived.ignored.remove(line)
            derived.approximated.append(
                f"{line.rsplit(':', 1)[0]}: Alpha: not baked; the lookup mixes a Transparent "
                "BSDF in by it, as Cycles does (glossy_addon.transparency)")
    reader.derived.spec = model.spec
    return reader.derived
