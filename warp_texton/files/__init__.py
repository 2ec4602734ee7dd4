"""Files: images read and written (PNG, JPEG, EXR, TIFF), their headers priced before decoding,
and folders written atomically. Above ``core`` only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.lazy import lazy_names

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


__getattr__, __dir__ = lazy_names(__name__, _LAZY)
