"""BRDF library: one interface for analytic, Cycles-exact, measured and tabulated models.

``parse(spec)`` turns a spec string into a model:

- ``name:key=value,...`` for a registered model (``ggx:roughness=0.3,anisotropy=0.8``,
  ``ward:ax=0.04,ay=0.04,ks=0.8``, ``phong:n=100``, ...; ``models()`` lists them);
- ``sum(A; B; ...)`` for a sum, ``layer(ior=1.5; TOP; BASE)`` for a coat,
  ``scale(k=0.5; A)`` for a constant weight and ``fresnel_mix(ior=1.5; A; B)`` for
  a Mix Shader driven by Blender's Fresnel node (combine.py);
- ``table:file=PATH.npz`` and ``merl:file=PATH.binary`` for data;
- ``bump:file=H.exr,scale=2`` or ``bump:preset=gaussian,slope=0.2``: the table
  computed from a height field (bake.bumpbrdf, Cabral, Max & Springmeyer).

Every model gives ``f(wi, wo)`` (..., 3), ``sample(wo, u)``, ``pdf(wi, wo)``,
``albedo(wo)``, ``spec`` (canonical) and ``spec_hash()`` (base.py).
"""

from . import classic, cycles, fresnel, lobes, principled  # noqa: F401  (registers the models)
from .base import BRDF, REGISTRY, parse_model
from .combine import FresnelMix, Layer, Scale, Sum
from .merl import MerlBRDF
from .params import SpecError
from .tabulated import AnisotropicTable, IsotropicTable, load_table

__all__ = ["parse", "models", "BRDF", "SpecError", "Sum", "Layer", "Scale", "FresnelMix",
           "IsotropicTable",
           "AnisotropicTable", "MerlBRDF", "fresnel"]


def models() -> dict:
    """{name: one-line description} of the models ``parse`` knows."""
    described = {name: (cls.__doc__ or "").strip().splitlines()[0]
                 for name, cls in REGISTRY.items() if name not in ("table",)}
    described["table"] = "tabulated BRDF from an .npz file: table:file=PATH"
    described["merl"] = "MERL measured BRDF: merl:file=PATH"
    described["bump"] = ("BRDF of a bumpy surface from its height field: "
                         "bump:file=H.exr,scale=S or bump:preset=gaussian|noise|grooves")
    described["sum"] = "sum(A; B; ...): the sum of several models"
    described["layer"] = "layer(ior=1.5; TOP; BASE): a dielectric coat over a base"
    described["scale"] = "scale(k=0.5; A): a model times a constant (grey or r/g/b)"
    described["fresnel_mix"] = ("fresnel_mix(ior=1.5; A; B): (1 - F(n.v)) A + F(n.v) B, a Mix "
                                "Shader driven by a Fresnel node")
    return dict(sorted(described.items()))


def _split_top(text: str) -> list:
    parts, depth, start = [], 0, 0
    for index, char in enumerate(text):
        if char == "(":
            depth += 1
        elif char == ")":
            depth -= 1
            if depth < 0:
                raise SpecError(f"unbalanced ')' in {text!r}")
        elif char == ";" and depth == 0:
            parts.append(text[start:index])
            start = index + 1
    if depth:
        raise SpecError(f"unbalanced '(' in {text!r}")
    parts.append(text[start:])
    return [p.strip() for p in parts]


#: Limits of a spec string, checked before anything is parsed: real materials
#: nest sum/layer two or three deep and name a handful of models; a spec past
#: these is a mistake (or an attack) that would otherwise cost minutes.
MAX_SPEC_LENGTH = 4096
MAX_SPEC_DEPTH = 8
MAX_SPEC_MODELS = 32


def _check_size(text: str) -> None:
    if len(text) > MAX_SPEC_LENGTH:
        raise SpecError(f"a BRDF spec of {len(text)} characters is too long "
                        f"(at most {MAX_SPEC_LENGTH})")
    depth = deepest = 0
    for char in text:
        depth += (char == "(") - (char == ")")
        deepest = max(deepest, depth)
    if deepest > MAX_SPEC_DEPTH:
        raise SpecError(f"a BRDF spec nested {deepest} deep is too deep "
                        f"(sum/layer at most {MAX_SPEC_DEPTH} deep)")
    models = text.count(":") + text.lower().count("layer(") + text.lower().count("scale(") \
        + text.lower().count("fresnel_mix(")
    if models > MAX_SPEC_MODELS:
        raise SpecError(f"a BRDF spec of {models} models is too large "
                        f"(at most {MAX_SPEC_MODELS})")


def parse(spec) -> BRDF:
    """A BRDF model from a spec string (or the model itself). Raises SpecError,
    at once for a spec longer, deeper or larger than the MAX_SPEC_* limits."""
    if isinstance(spec, BRDF):
        return spec
    if not isinstance(spec, str) or not spec.strip():
        raise SpecError(f"a BRDF spec must be a non-empty string, not {spec!r}")
    text = spec.strip()
    _check_size(text)
    head = text.split("(", 1)[0].strip().lower()
    if head in ("sum", "layer", "scale", "fresnel_mix") and text.endswith(")") and "(" in text:
        inner = _split_top(text[text.index("(") + 1:-1])
        if head == "sum":
            return Sum([parse(part) for part in inner])
        if head == "scale":
            if len(inner) != 2 or not inner[0].startswith("k="):
                raise SpecError("scale takes (k=VALUE; MODEL)")
            from .params import Param

            k = Param("k", None, 0.0, 1e3, "weight", rgb=True).convert("scale", inner[0][2:])
            return Scale(k, parse(inner[1]))
        if head == "fresnel_mix":
            if len(inner) != 3 or not inner[0].startswith("ior="):
                raise SpecError("fresnel_mix takes (ior=VALUE; A; B)")
            try:
                ior = float(inner[0][4:])
            except ValueError:
                raise SpecError(f"fresnel_mix: ior={inner[0][4:]!r} is not a number") from None
            return FresnelMix(ior, parse(inner[1]), parse(inner[2]))
        if len(inner) != 3 or not inner[0].startswith("ior="):
            raise SpecError("layer takes (ior=VALUE; TOP; BASE)")
        try:
            ior = float(inner[0][4:])
        except ValueError:
            raise SpecError(f"layer: ior={inner[0][4:]!r} is not a number") from None
        return Layer(ior, parse(inner[1]), parse(inner[2]))
    name, _, body = text.partition(":")
    name = name.strip().lower()
    if name == "bump":
        from ..bumpbrdf import bump_model

        return bump_model(body)
    if name in ("table", "merl"):
        key, _, path = body.partition("=")
        if key.strip() != "file" or not path.strip():
            raise SpecError(f"{name}: expected {name}:file=PATH")
        return load_table(path.strip()) if name == "table" else MerlBRDF.load(path.strip())
    return parse_model(text)
