"""The viewer's inputs: the image, texton or tiling model given at start, and the images
the page uploads for mixing, parsed defensively (size-checked before decoding)."""

from __future__ import annotations

import hashlib
import io
import os
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import TextonError
from ..files.images import read_image
from ..core.limits import check_memory
from ..model.texton import Texton, load_texton
from ..model.tiling import TilingModel
from .queries import BadRequest

#: Uploaded second inputs (mixing): bytes, pixels, how many are kept.
MAX_UPLOAD_BYTES = 32 << 20
MAX_UPLOAD_PIXELS = 4096 * 4096
MAX_UPLOADS = 4
#: Peak bytes per pixel of decoding an upload: PIL's decoded image, NumPy's copy
#: of it and the float32 RGBA image the reader returns, with their conversions
#: (docs/limits.md: measured 4096² RGB PNG).
UPLOAD_BYTES_PER_PIXEL = 40


@dataclass(frozen=True)
class Source:
    """An input given at start (or uploaded): an image to analyse, a texton, or a tiling model
    (``analyze(..., method="tiling")``, shown as server tiles: :mod:`~warp_texton.view.viewer`)."""

    name: str
    path: str | None
    image: np.ndarray | None
    texton: Texton | TilingModel | None
    digest: str

    @property
    def kind(self) -> str:
        """"image", "texton" or "tiling"."""
        if isinstance(self.texton, TilingModel):
            return "tiling"
        return "texton" if self.texton is not None else "image"

    @property
    def channels(self) -> int:
        if self.image is not None:
            return self.image.shape[2]
        assert self.texton is not None, "a source holds an image or a texton"
        return self.texton.channels


def digest(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else str(p).encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


def _is_texton_file(path: Path) -> bool:
    if path.suffix.lower() == ".texton":
        return True
    if path.suffix.lower() != ".exr":
        return False
    try:
        load_texton(path)
    except TextonError:
        return False
    return True


def _is_tiling_file(path: Path) -> bool:
    if path.suffix.lower() != ".exr" or not path.is_file():
        return False
    from ..files.images import read_exr_header
    from ..model.tiling import is_tiling_header

    try:
        return is_tiling_header(read_exr_header(path))
    except TextonError:
        return False


def load_source(input, what: str = "input", tiling: bool = True) -> Source:
    """A Source from a path (texton or tiling model file, or image), a Texton or a TilingModel
    (refused with ``tiling=False``: the inputs of mixing)."""
    if isinstance(input, TilingModel) or (isinstance(input, (str, os.PathLike)) and _is_tiling_file(Path(input))):
        if not tiling:
            raise TextonError(f"{what}: a tiling model (method 'tiling') cannot be mixed; mixing takes images "
                              "and textons", param=what)
    if isinstance(input, TilingModel):
        colours = () if input.histogram is None else (input.histogram.to_json().encode(),)
        return Source("tiling model", None, None, input,
                      digest(b"tiling", input.example.tobytes(), input.side, input.sharpness, input.guide_weight,
                             input.blend, *colours))
    if isinstance(input, Texton):
        colours = () if input.histogram is None else (input.histogram.to_json().encode(),)
        return Source("texton", None, None, input,
                      digest(input.coeffs.tobytes(), input.mean.tobytes(), input.order, *colours))
    if not isinstance(input, (str, os.PathLike)):
        raise TextonError(f"{what} must be the path of an image, texton or tiling model file, or a Texton or "
                          f"TilingModel, got {type(input).__name__}", param=what)
    path = Path(input)
    if not path.is_file():
        raise TextonError(f"{what}: {path}: no such file", param=what)
    with open(path, "rb") as f:
        key = digest(f.read())
    resolved = str(path.resolve())
    if _is_texton_file(path):
        return Source(path.name, resolved, None, load_texton(path), key)
    return Source(path.name, resolved, read_image(path), None, key)


def price_upload(data: bytes) -> None:
    """Refuse an upload whose header declares an image over the bounds or the memory
    budget, before anything is decoded (cheap: a server prices it before it waits for
    a computation slot, and again in the slot)."""
    from PIL import Image

    if len(data) > MAX_UPLOAD_BYTES:
        raise BadRequest(f"upload larger than {MAX_UPLOAD_BYTES >> 20} MiB", 413)
    if data[:4] == b"\x76\x2f\x31\x01":  # an EXR header may declare any size: not from a request
        raise BadRequest("upload a PNG or JPEG image; give an EXR or a texton file at start (--mix)")
    try:
        with warnings.catch_warnings():  # PIL's DecompressionBombWarning: the size is checked below
            warnings.simplefilter("ignore")
            with Image.open(io.BytesIO(data)) as im:  # reads the header only
                w, h = im.size
    except Exception:
        raise BadRequest("the upload is not an image that can be read") from None
    if w * h > MAX_UPLOAD_PIXELS:
        raise BadRequest(f"the uploaded image is {w}x{h}; at most {MAX_UPLOAD_PIXELS} pixels", 413)
    # the size its header declares, priced before decoding (a few KB of PNG can declare 4096²)
    check_memory(float(w) * h * UPLOAD_BYTES_PER_PIXEL, f"decoding the uploaded {w}x{h} image",
                 "upload a smaller image")


def decode_upload(data: bytes, name: str, workdir: Path) -> Source:
    """An uploaded image, parsed defensively: its size read from its header and
    priced (:func:`~warp_texton.core.limits.check_memory`) before decoding, then read by
    the package's reader from a private temporary file. Run it in a computation slot."""
    price_upload(data)
    fd, tmp = tempfile.mkstemp(dir=workdir, suffix=".img")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            image = read_image(tmp)
    except TextonError:
        raise BadRequest("the upload is not an image that can be read") from None
    finally:
        os.unlink(tmp)
    return Source(name, None, image, None, digest(data))


def safe_name(name: str) -> str:
    """An uploaded file's name, kept to letters, digits and ``._-`` (64 at most)."""
    keep = "".join(c for c in name if c.isalnum() or c in "._-")[:64]
    return keep or "upload"
