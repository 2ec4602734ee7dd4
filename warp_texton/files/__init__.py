"""Files: images read and written (PNG, JPEG, EXR, TIFF), their headers priced before decoding,
and folders written atomically. Above ``core`` only.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .images import read_image, write_image, image_size
    from .folders import atomic_folder

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "read_image": "images",
    "write_image": "images",
    "image_size": "images",
    "atomic_folder": "folders",
}

__all__ = ["atomic_folder", "image_size", "read_image", "write_image"]


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
