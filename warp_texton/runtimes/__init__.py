"""Texton noise outside the package's own calls: the device API for users' Warp kernels
(``warp_api``), and shader exports (``export``) in GLSL (``glsl``) and OSL (``osl``).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .export import export_shader, write_shader_preview
    from .warp_api import pack_plane, pack_filtered, pack_surface, pack_colours

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "export_shader": "export",
    "write_shader_preview": "export",
    "pack_plane": "warp_api",
    "pack_filtered": "warp_api",
    "pack_surface": "warp_api",
    "pack_colours": "warp_api",
}

__all__ = ["export_shader", "pack_colours", "pack_filtered", "pack_plane", "pack_surface", "write_shader_preview"]


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
