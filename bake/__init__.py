"""Glossy's baker: pure NumPy (+ OpenEXR), never imports bpy.

Usable alone as ``python -m bake ...`` and as a subpackage of the installed
Blender extension. Only relative imports are used inside this package.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
