"""Make the repository importable as the add-on package ``glossy`` (a symlink, as
a developer's checkout would be). Import this before ``glossy``."""

import atexit
import os
import shutil
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
_packages = Path(tempfile.mkdtemp(prefix="glossy_checkout_"))
os.symlink(REPO, _packages / "glossy")
atexit.register(shutil.rmtree, _packages, True)  # the link only, never the checkout
sys.path.insert(0, str(_packages))
