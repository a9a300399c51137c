"""Parameters of BRDF models and the spec strings that name them.

A spec is ``name:key=value,key=value`` (DESIGN.md), e.g. ``ggx:roughness=0.3``.
Scalars are plain numbers; colours are one number (grey) or three joined by
``/`` (``color=0.9/0.6/0.2``). Errors name the bad key or value and the
allowed range.
"""

import math
from dataclasses import dataclass

from ..errors import BakeError

__all__ = ["Param", "SpecError", "parse_pairs", "format_value"]


class SpecError(BakeError):
    """A BRDF spec string or parameter is invalid."""


@dataclass(frozen=True)
class Param:
    """One model parameter: name, default (None = required/derived), range and meaning."""

    name: str
    default: object
    low: float
    high: float
    doc: str
    rgb: bool = False

    def convert(self, model: str, raw):
        """Validate ``raw`` (string or number) and return a float or an (r, g, b) tuple."""
        if isinstance(raw, str):
            parts = raw.split("/")
            try:
                values = [float(p) for p in parts]
            except ValueError:
                raise SpecError(f"{model}: {self.name}={raw!r} is not a number") from None
        elif isinstance(raw, (tuple, list)):
            values = [float(v) for v in raw]
        else:
            values = [float(raw)]
        if len(values) not in ((1, 3) if self.rgb else (1,)):
            shape = "one number or three joined by '/'" if self.rgb else "one number"
            raise SpecError(f"{model}: {self.name} takes {shape}, got {raw!r}")
        for value in values:
            if not math.isfinite(value) or not self.low <= value <= self.high:
                raise SpecError(
                    f"{model}: {self.name}={value:g} is out of range "
                    f"[{self.low:g}, {self.high:g}] ({self.doc})"
                )
        if self.rgb:
            return tuple(values * 3) if len(values) == 1 else tuple(values)
        return values[0]


def parse_pairs(text: str, model: str) -> dict:
    """'a=1,b=2/3/4' -> {'a': '1', 'b': '2/3/4'} with clear errors."""
    pairs = {}
    if not text.strip():
        return pairs
    for item in text.split(","):
        if "=" not in item:
            raise SpecError(f"{model}: expected key=value, got {item.strip()!r}")
        key, value = (part.strip() for part in item.split("=", 1))
        if not key or not value:
            raise SpecError(f"{model}: expected key=value, got {item.strip()!r}")
        if key in pairs:
            raise SpecError(f"{model}: {key} given twice")
        pairs[key] = value
    return pairs


def format_value(value) -> str:
    """Shortest text that parses back to the same float(s)."""
    if isinstance(value, tuple):
        if len(set(value)) == 1:
            return format_value(value[0])
        return "/".join(format_value(v) for v in value)
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text
