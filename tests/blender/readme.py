"""The README's headless pipeline block, for the tests that run it verbatim."""

import re

from tests.conftest import ROOT


def pipeline_block() -> str:
    """The README's fenced ``sh`` block of headless commands, verbatim."""
    blocks = re.findall(r"```sh\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    blocks = [block for block in blocks if "bpy.ops.glossy.capture_probes()" in block]
    assert len(blocks) == 1, "README.md must hold one sh block with the pipeline"
    return blocks[0]


def pipeline_expressions() -> list[str]:
    """The Python of each ``--python-expr "..."`` in that block, in order."""
    expressions = re.findall(r'--python-expr "(.*?)"', pipeline_block(), re.S)
    assert expressions, "no --python-expr in the README's pipeline block"
    return expressions
