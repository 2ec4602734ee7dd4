"""Texton noise and tiling models outside the package's own calls: the device API for users' Warp
kernels (``warp_api``), and shader exports (``export``) in the registry's languages (``languages``),
one package each: GLSL (``glsl``) and OSL (``osl``), each exporting either model kind.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.lazy import lazy_names

if TYPE_CHECKING:
    from .export import export_shader, write_shader_preview
    from .warp_api import pack_plane, pack_filtered, pack_surface, pack_colours, pack_tiling

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "export_shader": "export",
    "write_shader_preview": "export",
    "pack_plane": "warp_api",
    "pack_filtered": "warp_api",
    "pack_surface": "warp_api",
    "pack_colours": "warp_api",
    "pack_tiling": "warp_api",
}

__all__ = ["export_shader", "pack_colours", "pack_filtered", "pack_plane", "pack_surface", "pack_tiling",
           "write_shader_preview"]


__getattr__, __dir__ = lazy_names(__name__, _LAZY)
