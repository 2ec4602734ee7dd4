"""Small image files whose headers declare huge images (the readers must refuse
them from the header, before decoding): a real tiny image with its declared
width and height patched."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np


def png_declaring(path: Path, width: int, height: int, *, mode: str = "RGB", bits: int = 8) -> Path:
    """A tiny PNG (``mode`` L, LA, RGB, RGBA or P; 8 or 16 bits) whose IHDR says width x height."""
    from PIL import Image

    channels = {"L": 1, "LA": 2, "RGB": 3, "RGBA": 4, "P": 1}[mode]
    if bits == 16:
        import imagecodecs

        a = np.zeros((4, 4, channels), np.uint16)
        path.write_bytes(imagecodecs.png_encode(a if channels > 1 else a[:, :, 0]))
    else:
        Image.new(mode, (4, 4)).save(path)
    data = bytearray(path.read_bytes())
    data[16:24] = struct.pack(">II", width, height)
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])))
    path.write_bytes(bytes(data))
    return path


def tiff_declaring(path: Path, width: int, height: int, *, samples: int = 3, dtype=np.uint16) -> Path:
    """A tiny TIFF whose ImageWidth and ImageLength say width x height, stored as one strip."""
    import tifffile

    shape = (4, 4, samples) if samples > 1 else (4, 4)
    extra = {"extrasamples": ["unassalpha"]} if samples in (2, 4) else {}
    tifffile.imwrite(path, np.zeros(shape, dtype), photometric="rgb" if samples >= 3 else "minisblack",
                     compression="zlib", metadata=None, **extra)
    with tifffile.TiffFile(path) as tif:
        tags = tif.pages.first.tags
        spots = [(tags[name].valueoffset, tags[name].dtype) for name in ("ImageWidth", "ImageLength", "RowsPerStrip")]
        order = tif.byteorder
    data = bytearray(path.read_bytes())
    for (offset, kind), value in zip(spots, (width, height, height)):
        fmt = order + ("H" if int(kind) == 3 else "I")
        data[offset:offset + struct.calcsize(fmt)] = struct.pack(fmt, value)
    path.write_bytes(bytes(data))
    return path
