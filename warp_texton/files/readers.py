"""Decoding image files, priced from their headers before any pixel is decoded.

:func:`declared` reads the size, the samples per pixel and the sample type of
a PNG (its IHDR chunk), a JPEG (its SOF segment) or a TIFF (tifffile's first
page, which reads only the IFD); :func:`decode_bytes` prices the decoder's
buffers plus the float32 image, so that :func:`warp_texton.files.images.read_image` can
refuse a file over the memory budget while it has spent a few kilobytes;
:func:`read_pixels` does both and decodes (Pillow, imagecodecs, tifffile).

Pillow refuses images above ``PIL.Image.MAX_IMAGE_PIXELS`` (with a warning
above half of that) as decompression bombs. The memory budget does that job
here for every format, priced before decoding, so Pillow's limit is raised
(never lowered, and left off when unset) to the largest image the budget
could hold, while the package's reader opens and decodes a file
(:func:`_pillow_limit`; put back when the last such read ends): a file is
then refused once, by the budget, with one ``TextonError`` and no extra
warning line, and other code's Pillow calls keep their own limit.

TIFF layouts are read as declared: one page whose axes are ``YX`` (grey),
``YXS`` (interleaved samples) or ``SYX`` (planar samples), with 1 or 2 samples
(grey, grey + alpha) for ``minisblack`` and 3 or 4 (RGB, RGBA) for ``rgb``;
anything else (a stack of pages, a volume, CMYK, inverted grey) is refused
rather than guessed at.
"""

from __future__ import annotations

import contextlib
import logging
import struct
import threading
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import TextonError
from ..core.limits import check_memory, memory_budget

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Samples per pixel of each PNG colour type (3: palette indices).
PNG_SAMPLES = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
#: Bytes a pixel costs in Pillow's own store (it keeps every multi-band 8-bit
#: mode in 4 bytes) plus one converted copy (palette and bilevel images are
#: converted to L, RGB or RGBA before being read out).
PILLOW_BYTES = 8
#: Rows of pixels scaled to float32 at once (keeps the float temporaries small).
CHUNK_VALUES = 1 << 22
FLOAT32_MAX = float(np.finfo(np.float32).max)
FORMATS_EXTRA = "pip install 'warp-texton[formats]'"
#: The fewest bytes any accepted pixel costs (a float32 grey value and its mask).
MIN_PIXEL_BYTES = 5


@dataclass(frozen=True)
class Declared:
    """An image file's declared layout."""

    height: int
    width: int
    samples: int  # per pixel, alpha included
    itemsize: int  # bytes per decoded sample
    decoder: str  # "pillow", "png16" (imagecodecs), "tiff" (tifffile)
    planar: bool = False  # TIFF samples stored as (S, H, W)
    kind: str = "u"  # NumPy's dtype kind of the samples

    @property
    def channels(self) -> int:
        """Channels of the image once read: grey (1) or RGB (3); alpha is dropped."""
        return 1 if self.samples <= 2 else 3


def decode_bytes(d: Declared, file_bytes: int = 0) -> float:
    """Peak bytes of reading ``d``: the decoder's output (twice for tifffile, whose
    strip or tile buffers reach the whole image for a file stored as one strip;
    Pillow's store and a converted copy for Pillow, see PILLOW_BYTES), the
    float32 image and a one-byte-per-value finiteness mask, plus the file's
    bytes where the decoder reads it whole (imagecodecs)."""
    pixels = float(d.height) * d.width
    decoded = d.samples * d.itemsize
    pillow = PILLOW_BYTES if d.samples > 1 else 2 * d.itemsize  # one band: its store and a copy
    extra = {"pillow": pillow, "tiff": decoded, "png16": 0}[d.decoder]
    # integers wider than 16 bits are scaled in float64 (float32 would round them)
    wide = 8 * d.channels if d.itemsize > 2 and d.kind in "ui" else 0
    return pixels * (decoded + extra + 5 * d.channels + wide) + file_bytes


def png_header(path: Path) -> tuple[int, int, int, int] | None:
    """(height, width, bit depth, colour type) from a PNG's IHDR, or None if the file
    does not start like a PNG."""
    with open(path, "rb") as f:
        head = f.read(29)
    if len(head) < 26 or head[:8] != PNG_SIGNATURE:
        return None
    if head[12:16] != b"IHDR":
        raise TextonError(f"{path}: not a PNG that can be read (no IHDR chunk)")
    w, h = struct.unpack(">II", head[16:24])
    depth, ctype = head[24], head[25]
    if ctype not in PNG_SAMPLES or depth not in (1, 2, 4, 8, 16) or w == 0 or h == 0:
        raise TextonError(f"{path}: not a PNG that can be read (colour type {ctype}, bit depth {depth}, {w}x{h})")
    return h, w, depth, ctype


def png_declared(path: Path, codecs: bool) -> Declared | None:
    """The PNG's layout; 16-bit colour, grey + alpha and RGBA go to imagecodecs when
    ``codecs`` (Pillow reads them with 8 bits)."""
    head = png_header(path)
    if head is None:
        return None
    h, w, depth, ctype = head
    samples = PNG_SAMPLES[ctype]
    if ctype == 3:  # palette: read as RGB (or RGBA with a transparency chunk)
        return Declared(h, w, 4, 1, "pillow")
    if depth == 16 and ctype != 0 and codecs:
        return Declared(h, w, samples, 2, "png16")
    return Declared(h, w, samples, 2 if depth == 16 and ctype == 0 else 1, "pillow")


#: JPEG start-of-frame markers (baseline, progressive, lossless...; not DHT, JPG, DAC).
_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def jpeg_declared(path: Path) -> Declared | None:
    """The JPEG's size and components from its first SOF segment, or None if the
    file does not start like a JPEG or has no readable SOF (Pillow then says why)."""
    with open(path, "rb") as f:
        if f.read(2) != b"\xff\xd8":
            return None
        while True:
            byte = f.read(1)
            while byte == b"\xff":  # fill bytes before a marker
                marker = f.read(1)
                if marker != b"\xff":
                    break
            else:
                return None
            if not marker:
                return None
            code = marker[0]
            if 0xD0 <= code <= 0xD9 or code == 0x01:  # markers without a length
                continue
            size = f.read(2)
            if len(size) < 2:
                return None
            length = struct.unpack(">H", size)[0]
            if code in _SOF:
                body = f.read(6)
                if len(body) < 6:
                    return None
                h, w = struct.unpack(">HH", body[1:5])
                comps = body[5]
                if h == 0 or w == 0 or comps not in (1, 3, 4):
                    return None
                return Declared(h, w, 1 if comps == 1 else 3, 1, "pillow")
            f.seek(length - 2, 1)


def tiff_declared(path: Path, tif) -> Declared | None:
    """The layout of an open ``tifffile.TiffFile``, or None for what Pillow reads
    better (palette and bilevel images); refuses what is ambiguous."""
    pages = len(tif.pages)
    if pages != 1:
        raise TextonError(f"{path}: a TIFF with {pages} pages (a stack or several images); give a file with "
                          "one image, or extract the page you mean")
    page = tif.pages.first
    photometric = getattr(page.photometric, "name", str(page.photometric)).lower()
    dtype = np.dtype(page.dtype) if page.dtype is not None else None
    if photometric in ("palette",) or dtype is None or dtype.kind == "b":
        return None
    series = tif.series[0]
    axes, shape = series.axes, tuple(int(n) for n in series.shape)
    if axes == "YX":
        h, w, s, planar = *shape, 1, False
    elif axes == "YXS":
        (h, w, s), planar = shape, False
    elif axes == "SYX":
        (s, h, w), planar = shape, True
    else:
        raise TextonError(f"{path}: a TIFF of shape {shape} with axes {axes!r}; expected one image with axes "
                          "YX, YXS or SYX (height, width, samples)")
    allowed = {"minisblack": (1, 2), "rgb": (3, 4), "ycbcr": (3,)}.get(photometric, ())
    if s not in allowed:
        raise TextonError(f"{path}: a {photometric} TIFF with {s} samples per pixel is not read; expected grey "
                          "(minisblack, 1 sample, or 2 with alpha) or RGB (3 samples, or 4 with alpha)")
    if dtype.kind not in "uif" or dtype.itemsize > 8:
        raise TextonError(f"{path}: a TIFF with {dtype} samples is not read; use integers or floats")
    return Declared(h, w, s, dtype.itemsize, "tiff", planar, dtype.kind)


def to_float32(a: np.ndarray, channels: int) -> np.ndarray:
    """The first ``channels`` of (H, W, S) pixels as float32: integers scaled by their
    type's range, floats as they are; in blocks of rows, so that no float64 copy
    of the whole image is made. For 8 and 16-bit integers the float32 division
    gives the same bits as a float64 division rounded to float32 (double rounding
    is innocuous for a quotient when 53 >= 2·24 + 2)."""
    h, w = a.shape[:2]
    out = np.empty((h, w, channels), np.float32)
    step = max(1, CHUNK_VALUES // max(1, w * channels))
    kind, size = a.dtype.kind, a.dtype.itemsize
    scale = float(np.iinfo(a.dtype).max) if kind in "ui" else 1.0
    for i in range(0, h, step):
        block = a[i:i + step, :, :channels]
        if kind == "f" and size > 4 and block.size and np.nanmax(np.abs(block)) > FLOAT32_MAX:
            raise TextonError(f"pixels beyond float32's range (±{FLOAT32_MAX:.3g})")
        if kind in "ui" and size > 2:
            out[i:i + step] = block.astype(np.float64) / scale
        elif kind in "ui":
            np.divide(block, np.float32(scale), out=out[i:i + step], dtype=np.float32)
        else:
            out[i:i + step] = block
    return out


def check_declared(d: Declared, path, file_bytes: int = 0) -> None:
    """Refuse a declared image whose decoding would exceed the memory budget."""
    check_memory(decode_bytes(d, file_bytes), f"{path}: a {d.width}x{d.height} image of {d.samples} "
                 f"{8 * d.itemsize}-bit sample{'s' if d.samples > 1 else ''} per pixel", "use a smaller image")


_pillow_lock = threading.Lock()
_pillow_readers = 0  # the package's Pillow reads in progress, in any thread
_pillow_saved: int | None = None  # Pillow's limit before the first of them
_pillow_raised: int | None = None  # the limit they set


@contextlib.contextmanager
def _pillow_limit() -> Iterator[None]:
    """Pillow's bomb limit no lower than the budget's largest image while the package's
    reader opens and decodes a file (see the module notes), put back when the last
    such read in any thread ends, unless someone changed it meanwhile."""
    global _pillow_readers, _pillow_saved, _pillow_raised
    from PIL import Image

    with _pillow_lock:
        if _pillow_readers == 0:
            _pillow_saved = Image.MAX_IMAGE_PIXELS
        _pillow_readers += 1
        if Image.MAX_IMAGE_PIXELS is not None:
            Image.MAX_IMAGE_PIXELS = max(Image.MAX_IMAGE_PIXELS, memory_budget() // MIN_PIXEL_BYTES)
        _pillow_raised = Image.MAX_IMAGE_PIXELS
    try:
        yield
    finally:
        with _pillow_lock:
            _pillow_readers -= 1
            if _pillow_readers == 0 and Image.MAX_IMAGE_PIXELS == _pillow_raised:
                Image.MAX_IMAGE_PIXELS = _pillow_saved


@contextlib.contextmanager
def _quiet_tifffile():
    """tifffile logs what it finds odd in a file (to stderr, where logging is not
    configured); the reader reads or refuses the file with one message, so the
    records of this thread are dropped while it reads."""
    me = threading.get_ident()
    log = logging.getLogger("tifffile")

    def other_threads(record: logging.LogRecord) -> bool:
        return record.thread != me

    log.addFilter(other_threads)
    try:
        yield
    finally:
        log.removeFilter(other_threads)


def declared(path: Path) -> Declared | None:
    """The layout a PNG, JPEG or TIFF file declares (None for other formats, or a
    TIFF that Pillow reads), from its header alone."""
    if path.suffix.lower() in (".tif", ".tiff"):
        try:
            import tifffile
        except ImportError:
            return None
        try:
            with _quiet_tifffile(), tifffile.TiffFile(str(path)) as tif:
                return tiff_declared(path, tif)
        except TextonError:
            raise
        except Exception as exc:
            raise TextonError(f"{path}: not a TIFF image that can be read ({exc})") from None
    return png_declared(path, _has_codecs()) or jpeg_declared(path)


def _has_codecs() -> bool:
    try:
        import imagecodecs  # noqa: F401
    except ImportError:
        return False
    return True


def read_pixels(path: Path) -> np.ndarray:
    """The pixels of an image file (not EXR) as float32 (H, W, 1|3), alpha dropped
    with a warning; the declared size is priced before decoding."""
    ext = path.suffix.lower()
    if ext in (".tif", ".tiff"):
        a = _read_tiff(path)
        if a is not None:
            return a
    codecs = _has_codecs()
    d = png_declared(path, codecs)
    if d is None:
        d = jpeg_declared(path)
    elif d.decoder == "png16":
        check_declared(d, path, path.stat().st_size)
        return _read_png16(path)
    elif not codecs and png_header(path)[2:] in ((16, 2), (16, 4), (16, 6)):  # type: ignore[index]
        warnings.warn(f"{path}: a 16-bit colour or grey + alpha PNG read with 8 bits; {FORMATS_EXTRA} reads "
                      "all 16", stacklevel=3)
    if d is not None:
        check_declared(d, path)
    return _read_pillow(path, d)


def _without_alpha(a: np.ndarray, path) -> np.ndarray:
    """Decoded (H, W[, S]) pixels as float32 grey or RGB, any alpha dropped with a warning."""
    a = a.reshape(a.shape[0], a.shape[1], -1)
    samples = int(a.shape[-1])
    _alpha(path, samples, 6)
    return to_float32(a, 1 if samples <= 2 else 3)


def _alpha(path, samples: int, stacklevel: int = 5) -> None:
    if samples in (2, 4):
        warnings.warn(f"{path}: dropping the alpha channel", stacklevel=stacklevel)


def _read_png16(path: Path) -> np.ndarray:
    import imagecodecs

    try:
        a = np.asarray(imagecodecs.png_decode(path.read_bytes()))
    except Exception as exc:
        raise TextonError(f"{path}: not a PNG that can be read ({exc})") from None
    return _without_alpha(a, path)


def _read_pillow(path: Path, d: Declared | None) -> np.ndarray:

    with _pillow_limit():
        return _read_pillow_scoped(path, d)


def _read_pillow_scoped(path: Path, d: Declared | None) -> np.ndarray:
    from PIL import Image

    try:
        with warnings.catch_warnings():
            # only for formats whose header is not read here (d is None): their
            # size is priced just below, after Pillow has read the header
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            im = Image.open(path)
        with im:
            w, h = im.size
            if d is None:
                bands = len(im.getbands())
                d = Declared(h, w, bands, 2 if im.mode.startswith("I;16") else (4 if im.mode in "IF" else 1),
                             "pillow")
                check_declared(d, path)
            im.load()
            return _pil_pixels(im, path)
    except TextonError:
        raise
    except Image.DecompressionBombError:
        raise TextonError(f"{path}: an image larger than the memory budget can hold (Pillow's limit of "
                          f"{Image.MAX_IMAGE_PIXELS} pixels)") from None
    except Exception as exc:
        raise TextonError(f"{path}: not an image that can be read ({exc})") from None


def _pil_pixels(im, path) -> np.ndarray:
    mode = im.mode
    if mode.startswith("I;16"):
        return to_float32(np.asarray(im)[:, :, None].astype(np.uint16, copy=False), 1)
    if mode == "I":
        a = np.asarray(im)
        if a.size and (a.min() < 0 or a.max() > 65535):
            raise TextonError(f"{path}: 32-bit integer pixels are not supported; use 8/16-bit or EXR")
        return to_float32(a.astype(np.uint16)[:, :, None], 1)
    if mode == "F":
        return np.ascontiguousarray(np.asarray(im, np.float32)[:, :, None])
    if mode == "P":
        im = im.convert("RGBA" if "transparency" in im.info else "RGB")
    elif mode == "PA":
        im = im.convert("RGBA")
    elif mode == "1":
        im = im.convert("L")
    elif mode not in ("L", "LA", "RGB", "RGBA"):
        im = im.convert("RGB")
    a = np.asarray(im)
    return _without_alpha(a, path)


def _read_tiff(path: Path) -> np.ndarray | None:
    """A TIFF as its first page declares it, through tifffile, or None without
    tifffile or for palette and bilevel TIFFs (Pillow reads those)."""
    try:
        import tifffile
    except ImportError:
        return None
    with _quiet_tifffile():
        return _decode_tiff(path, tifffile)


def _decode_tiff(path: Path, tifffile) -> np.ndarray | None:
    try:
        tif = tifffile.TiffFile(str(path))
    except Exception as exc:
        raise TextonError(f"{path}: not a TIFF image that can be read ({exc})") from None
    with tif:
        try:
            d = tiff_declared(path, tif)
        except TextonError:
            raise
        except Exception as exc:
            raise TextonError(f"{path}: not a TIFF image that can be read ({exc})") from None
        if d is None:
            return None
        check_declared(d, path)
        try:
            a = np.asarray(tif.pages.first.asarray(maxworkers=1))
        except Exception as exc:
            raise TextonError(f"{path}: not a TIFF image that can be read ({exc})") from None
    a = np.moveaxis(a.reshape(d.samples, d.height, d.width), 0, -1) if d.planar \
        else a.reshape(d.height, d.width, d.samples)
    _alpha(path, d.samples)
    try:
        return to_float32(a, d.channels)
    except TextonError as exc:
        raise TextonError(f"{path}: {exc}") from None
