"""The Blender extension: ``build_extension`` writes a zip that Blender 4.2+ installs, whose add-on
makes a material from a photograph (``bpy.ops.warp_texton.material_from_image``).

Its modules: :mod:`~warp_texton.blender.manifest` (the manifest and Blender's platforms),
:mod:`~warp_texton.blender.wheels` (the wheels bundled), :mod:`~warp_texton.blender.materials` (what the
add-on computes inside Blender: the analysis, the OSL source, the bakes; no ``bpy``) and
:mod:`~warp_texton.blender.extension` (the zip). ``addon/`` holds the add-on's ``__init__.py``, copied
into the zip: it imports ``bpy`` and runs only in Blender.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.lazy import lazy_names

if TYPE_CHECKING:
    from .extension import build_extension
    from .manifest import PLATFORMS

_LAZY = {"build_extension": "extension", "PLATFORMS": "manifest"}

__all__ = ["PLATFORMS", "build_extension"]

__getattr__, __dir__ = lazy_names(__name__, _LAZY)
