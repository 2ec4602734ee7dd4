"""Reading and writing images: PNG/JPEG through Pillow, EXR through OpenEXR 3.x.

Images are float32 arrays (H, W, C) with C in {1, 3}. Every write goes to a
temporary file in the destination folder and is renamed into place, so a
failed write leaves no partial file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np

from ._checks import as_image
from .errors import TextonError

#: Extensions ``write_image`` accepts, with the Pillow format used for each.
PIL_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG"}
EXR = ".exr"


def _umask() -> int:
    # os.umask can only be read by setting it; restore it at once.
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it to ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched.
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise TextonError(f"{path}: the output folder {parent} does not exist")
    if path.is_dir():
        raise TextonError(f"{path}: is a folder; give a file name")
    fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{path.name}.", suffix=".part")
    os.close(fd)
    try:
        # mkstemp creates the file 0600; give the output the usual permissions.
        os.chmod(tmp, 0o666 & ~_umask())
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _exr_module():
    import OpenEXR  # imported lazily: the binding loads a sizeable library

    return OpenEXR


def exr_header(**attributes) -> dict:
    """A float32, ZIP-compressed (lossless) scanline EXR header plus ``attributes``."""
    exr = _exr_module()
    return {"compression": exr.ZIP_COMPRESSION, "type": exr.scanlineimage, **attributes}


def write_exr(path, img: np.ndarray, **attributes) -> None:
    """Write a float32 (H, W, 1|3) array as an EXR ("Y" or "RGB" channels), atomically."""
    exr = _exr_module()
    img = np.ascontiguousarray(img, dtype=np.float32)
    channels = {"Y": np.ascontiguousarray(img[:, :, 0])} if img.shape[2] == 1 else {"RGB": img}
    with atomic_path(path) as tmp:
        exr.File(exr_header(**attributes), channels).write(str(tmp))


def read_exr_header(path) -> dict:
    """The header attributes of an EXR file, without reading its pixels."""
    exr = _exr_module()
    try:
        return exr.File(str(path), header_only=True).header()
    except Exception as exc:
        raise TextonError(f"{path}: not a readable EXR file ({exc})") from None


def read_exr(path) -> tuple[np.ndarray, dict]:
    """Read an EXR file into float32 (H, W, C) plus its header; alpha is dropped."""
    exr = _exr_module()
    try:
        f = exr.File(str(path))
        header = f.header()
        channels = f.channels()
    except Exception as exc:
        raise TextonError(f"{path}: not a readable EXR file ({exc})") from None
    if "RGB" in channels:
        img = channels["RGB"].pixels
    elif "RGBA" in channels:
        warnings.warn(f"{path}: dropping the alpha channel", stacklevel=3)
        img = channels["RGBA"].pixels[:, :, :3]
    elif len(channels) == 1:
        img = next(iter(channels.values())).pixels
    elif "Y" in channels:
        img = channels["Y"].pixels
    else:
        names = ", ".join(sorted(channels))
        raise TextonError(
            f"{path}: EXR channels {names} are not an image; expected Y, RGB or RGBA"
        )
    img = np.asarray(img)
    if img.ndim == 2:
        img = img[:, :, None]
    if not np.issubdtype(img.dtype, np.floating):
        img = img.astype(np.float64) / float(np.iinfo(img.dtype).max)
    return as_image(img, str(path)), header


def _pil_to_array(im, path) -> np.ndarray:
    mode = im.mode
    if mode in ("I;16", "I;16B", "I;16L", "I;16N"):
        return np.asarray(im, dtype=np.float64) / 65535.0
    if mode == "I":
        a = np.asarray(im, dtype=np.float64)
        if a.min() < 0 or a.max() > 65535:
            raise TextonError(f"{path}: 32-bit integer pixels are not supported; use 8/16-bit or EXR")
        return a / 65535.0
    if mode == "F":
        return np.asarray(im, dtype=np.float64)
    if mode in ("LA", "PA", "RGBA") or (mode == "P" and "transparency" in im.info):
        warnings.warn(f"{path}: dropping the alpha channel", stacklevel=4)
        im = im.convert("RGBA").convert("RGB") if mode != "LA" else im.convert("L")
    elif mode == "1":
        im = im.convert("L")
    elif mode not in ("L", "RGB"):
        im = im.convert("RGB")
    return np.asarray(im, dtype=np.float64) / 255.0


def read_image(path) -> np.ndarray:
    """Read an image file as float32 (H, W, C), C in {1, 3}.

    PNG, JPEG and the other formats Pillow reads are scaled from 8 or 16 bits
    to [0, 1]; EXR (by extension) is read through OpenEXR as stored. An alpha
    channel is dropped with a warning.

    Raises
    ------
    TextonError
        If the file is missing, unreadable, not an image, or has NaN/inf pixels.

    Examples
    --------
    >>> from warp_texton import read_image
    >>> from warp_texton.demo import demo_texture_path
    >>> read_image(demo_texture_path()).shape
    (256, 256, 1)
    """
    path = Path(path)
    if not path.exists():
        raise TextonError(f"{path}: no such file")
    if not path.is_file():
        raise TextonError(f"{path}: not a file")
    if path.suffix.lower() == EXR:
        return read_exr(path)[0]
    from PIL import Image

    try:
        with Image.open(path) as im:
            im.load()
            a = _pil_to_array(im, path)
    except TextonError:
        raise
    except Exception as exc:
        raise TextonError(f"{path}: not an image that can be read ({exc})") from None
    return as_image(a, str(path))


def check_image_path(path) -> Path:
    """``path`` as a Path if its extension is one ``write_image`` writes (checked
    before long work, so that a bad name fails at once)."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext != EXR and ext not in PIL_FORMATS:
        raise TextonError(f"{path}: unsupported extension {ext or '(none)'!r}; use .png, .jpg, .jpeg or .exr")
    return path


def write_image(path, img) -> None:
    """Write an image atomically: EXR as float32 (lossless), PNG/JPEG as 8 bits.

    PNG and JPEG values are clipped to [0, 1] and rounded to 8 bits. The file
    appears only once it is complete.

    Raises
    ------
    TextonError
        For an unsupported extension, a missing folder, or a bad image.
    """
    path = check_image_path(path)
    ext = path.suffix.lower()
    img = as_image(img, "img")
    if ext == EXR:
        write_exr(path, img)
        return
    from PIL import Image

    q = np.round(np.clip(img, 0.0, 1.0) * 255.0).astype(np.uint8)
    pil = Image.fromarray(q[:, :, 0] if q.shape[2] == 1 else q)
    with atomic_path(path) as tmp:
        kwargs = {"quality": 95} if PIL_FORMATS[ext] == "JPEG" else {}
        pil.save(tmp, format=PIL_FORMATS[ext], **kwargs)
