"""Render #5's attached acceptance scene with EEVEE inside a ``blender`` executable.

    blender --background WORKDIR/scene.blend --python binary_views.py -- WORKDIR

Writes lookup/normals/ids EXRs and views.json (_acceptance_scene.render_views).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _acceptance_scene  # noqa: E402

_acceptance_scene.render_views(Path(sys.argv[sys.argv.index("--") + 1]))
