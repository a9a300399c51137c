"""``python -m bake``: see bake/cli.py."""

import sys

from .cli import run

sys.exit(run())
