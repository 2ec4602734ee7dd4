"""The viewer: the HTTP server (``server``), the ``Viewer`` it serves without HTTP (``viewer``),
its queries, caches, inputs, pictures, the commands that reproduce its exports and its
WebGL2 mode; the page is package data in ``static/``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.lazy import lazy_names

if TYPE_CHECKING:
    from .server import serve
    from .viewer import Viewer

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "serve": "server",
    "Viewer": "viewer",
}

__all__ = ["Viewer", "serve"]


#: 0.2's warp_texton.view was a module, warp_texton.view.server now: its other names are reached here
#: with a DeprecationWarning (warp_texton.MOVED_MODULES).
__getattr__, __dir__ = lazy_names(__name__, _LAZY, moved="server")
