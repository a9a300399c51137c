"""``python -m bake``: see bake/cli.py."""

import sys

from .cli import main

sys.exit(main())
