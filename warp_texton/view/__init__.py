"""The viewer: the HTTP server (``server``), the ``Viewer`` it serves without HTTP (``viewer``),
its queries, caches, inputs, pictures, the commands that reproduce its exports and its
WebGL2 mode; the page is package data in ``static/``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .server import serve
    from .viewer import Viewer

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "serve": "server",
    "Viewer": "viewer",
}

__all__ = ["Viewer", "serve"]


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
