"""Reading and writing images: PNG/JPEG through Pillow, EXR through OpenEXR 3.x.

Images are float32 arrays (H, W, C) with C in {1, 3}. Every write goes to a
temporary file in the destination folder and is renamed into place, so a
failed write leaves no partial file.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np

from ._checks import as_image, check_path
from .errors import TextonError
from .limits import check_memory

#: Extensions ``write_image`` accepts, with the Pillow format used for each.
PIL_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG"}
EXR = ".exr"


def _umask() -> int:
    # os.umask can only be read by setting it; restore it at once.
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: Longest file name (bytes) assumed where the file system does not say.
NAME_MAX = 255
#: Temporary files are ``.NAME.PID-HOST.RANDOM.part``: PID and HOST (a short
#: hash of the host name) say who writes it, so that a later write to the same
#: path can remove what a killed process left behind.
PART_SUFFIX = ".part"


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return NAME_MAX


def host_tag() -> str:
    import socket
    import zlib

    return f"{zlib.crc32(socket.gethostname().encode()) & 0xFFFF:04x}"


def _part_prefix(name: str, limit: int) -> str:
    """``.NAME.``, shortened (with a hash of the whole name) so that the temporary
    name stays within the file system's limit even when NAME is close to it."""
    import hashlib

    # room for "PID-HOST." (at most 7 + 1 + 4 + 1), mkstemp's 8 random characters and ".part"
    room = limit - (14 + 8 + len(PART_SUFFIX))
    prefix = f".{name}."
    if len(os.fsencode(prefix)) <= room:
        return prefix
    digest = hashlib.sha1(os.fsencode(name)).hexdigest()[:8]
    keep = os.fsencode(name)[: max(0, room - 12)].decode("utf-8", "ignore")
    return f".{keep}~{digest}."


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # someone else's live process, or we cannot tell: leave it
    return True


def remove_leftovers(path) -> list[Path]:
    """Remove the temporary files that writers of ``path`` on this machine left
    behind when they were killed (their process no longer exists); returns them.

    Only files named as :func:`atomic_path` names them, for this very path and
    this host, are touched.
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    prefix = _part_prefix(path.name, _name_max(parent))
    host = host_tag()
    removed = []
    try:
        candidates = [e for e in os.scandir(parent) if e.name.startswith(prefix) and e.name.endswith(PART_SUFFIX)]
    except OSError:
        return removed
    for entry in candidates:
        tag = entry.name[len(prefix):].split(".", 1)[0]  # "PID-HOST"
        pid, _, who = tag.partition("-")
        if who != host or not pid.isdigit() or _pid_alive(int(pid)):
            continue
        with contextlib.suppress(OSError):
            os.unlink(entry.path)
            removed.append(Path(entry.path))
    return removed


def check_output_name(path, name: str = "output") -> Path:
    """``path`` as a Path whose file name the file system can hold (checked before long work)."""
    from ._checks import check_path

    path = check_path(path, name)
    parent = path.parent if str(path.parent) else Path(".")
    limit = _name_max(parent) if parent.is_dir() else NAME_MAX
    if len(os.fsencode(path.name)) > limit:
        raise TextonError(f"{path}: the file name is {len(os.fsencode(path.name))} bytes long; "
                          f"the file system allows at most {limit}")
    return path


def _write_error(exc: BaseException, path: Path, tmp: str) -> OSError:
    """A failed write as an OSError that names ``path`` (not the temporary file)."""
    if isinstance(exc, OSError):
        err, text = exc.errno, exc.strerror or str(exc)
    else:  # libraries that report I/O failures as RuntimeError (OpenEXR)
        text = str(exc).replace(str(tmp), str(path))
        err = next((e for e in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EACCES, errno.EIO)
                    if os.strerror(e).lower() in text.lower()), errno.EIO)
        text = os.strerror(err) if err != errno.EIO else f"could not write the file ({text})"
    return OSError(err, text, str(path))


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it to ``path`` on success.

    On any exception (Ctrl-C and SystemExit included; the command line turns
    SIGTERM into SystemExit) the temporary file is removed and ``path`` is
    untouched. An I/O failure of the write (disk full, quota, read-only file
    system) is raised as an OSError naming ``path``, not the temporary file
    (:func:`write_exr` turns OpenEXR's RuntimeError into one too). A process killed outright (SIGKILL) leaves its temporary
    file, named ``.NAME.PID-HOST.RANDOM.part``; the next write to the same path
    on this machine removes it (:func:`remove_leftovers`).
    """
    path = check_output_name(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise TextonError(f"{path}: the output folder {parent} does not exist")
    if path.is_dir():
        raise TextonError(f"{path}: is a folder; give a file name")
    remove_leftovers(path)
    prefix = _part_prefix(path.name, _name_max(parent)) + f"{os.getpid()}-{host_tag()}."
    try:
        fd, tmp = tempfile.mkstemp(dir=parent, prefix=prefix, suffix=PART_SUFFIX)
    except OSError as exc:
        raise _write_error(exc, path, "") from None
    os.close(fd)
    try:
        # mkstemp creates the file 0600; give the output the usual permissions.
        os.chmod(tmp, 0o666 & ~_umask())
        try:
            yield tmp
            os.replace(tmp, path)
        except OSError as exc:
            raise _write_error(exc, path, tmp) from None
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
        try:
            exr.File(exr_header(**attributes), channels).write(str(tmp))
        except RuntimeError as exc:  # how OpenEXR reports a failed write (disk full, I/O error...)
            raise _write_error(exc, path, tmp) from None


def read_exr_header(path) -> dict:
    """The header attributes of an EXR file, without reading its pixels."""
    exr = _exr_module()
    try:
        return exr.File(str(path), header_only=True).header()
    except Exception as exc:
        raise TextonError(f"{path}: not a readable EXR file ({exc})") from None


def exr_size(header: dict, path) -> tuple[int, int, int]:
    """(height, width, channels) that an EXR header declares."""
    try:
        (x0, y0), (x1, y1) = (np.asarray(c, np.int64) for c in header["dataWindow"])
        channels = len(header.get("channels", ())) or 1
    except (KeyError, TypeError, ValueError):
        raise TextonError(f"{path}: not a readable EXR file (no data window)") from None
    return int(y1 - y0 + 1), int(x1 - x0 + 1), channels


def check_image_memory(h: int, w: int, c: int, path, copies: float = 3.0) -> None:
    """Refuse to read an (h, w, c) image whose pixels would not fit the memory budget:
    the decoded pixels plus the float32 image (``copies`` float32 images in all)."""
    check_memory(float(h) * w * max(c, 1) * 4.0 * copies, f"{path}: a {w}x{h} image with {c} channels",
                 "use a smaller image")


def read_exr(path, max_side: int | None = None, what: str = "image") -> tuple[np.ndarray, dict]:
    """Read an EXR file into float32 (H, W, C) plus its header; alpha is dropped.

    The header is read first: a file whose size exceeds ``max_side`` or the
    memory budget is refused before its pixels are read.
    """
    exr = _exr_module()
    header = read_exr_header(path)
    h, w, c = exr_size(header, path)
    if h < 1 or w < 1:
        raise TextonError(f"{path}: the EXR {what} is empty ({w}x{h})")
    if max_side is not None and max(h, w) > max_side:
        raise TextonError(f"{path}: a {w}x{h} EXR {what}; at most {max_side} texels per side are accepted")
    check_image_memory(h, w, c, path)
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
    return as_image(img, str(path), limit=None), header


def is_texton_header(header: dict) -> bool:
    """True when EXR header attributes are those of a texton written by this package."""
    return "texton_order" in header


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
    channel is dropped with a warning. A texton file (``.texton``, or an EXR
    written by :meth:`Texton.save`) is not an image: it is refused with a hint
    (read it with :func:`load_texton`). The file's declared size is checked
    against the memory budget before its pixels are decoded.

    Raises
    ------
    TextonError
        If the file is missing, unreadable, not an image, a texton, larger than
        the memory budget allows, or has NaN/inf pixels.

    Examples
    --------
    >>> from warp_texton import read_image
    >>> from warp_texton.demo import demo_texture_path
    >>> read_image(demo_texture_path()).shape
    (256, 256, 1)
    """
    path = check_path(path, "path")
    if not path.exists():
        raise TextonError(f"{path}: no such file")
    if not path.is_file():
        raise TextonError(f"{path}: not a file")
    ext = path.suffix.lower()
    if ext == ".texton" or (ext == EXR and is_texton_header(read_exr_header(path))):
        raise TextonError(
            f"{path}: is a texton file, not an image; give an example image here, or use the texton where "
            "a texton is expected (load_texton; on the command line: synthesize, render-plane, mix, surface --texton)"
        )
    if ext == EXR:
        return read_exr(path)[0]
    from PIL import Image

    try:
        with Image.open(path) as im:
            w, h = im.size
            check_image_memory(h, w, len(im.getbands()), path, copies=4.0)  # float64 decode + float32
            im.load()
            a = _pil_to_array(im, path)
    except TextonError:
        raise
    except Exception as exc:
        raise TextonError(f"{path}: not an image that can be read ({exc})") from None
    return as_image(a, str(path), limit=None)


def check_image_path(path, name: str = "path") -> Path:
    """``path`` as a Path if its extension is one ``write_image`` writes and its
    name fits the file system (checked before long work, so that a bad name
    fails at once)."""
    path = check_output_name(path, name)
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
    img = as_image(img, "img", limit=None)
    if ext == EXR:
        write_exr(path, img)
        return
    from PIL import Image

    q = np.round(np.clip(img, 0.0, 1.0) * 255.0).astype(np.uint8)
    pil = Image.fromarray(q[:, :, 0] if q.shape[2] == 1 else q)
    with atomic_path(path) as tmp:
        kwargs = {"quality": 95} if PIL_FORMATS[ext] == "JPEG" else {}
        pil.save(tmp, format=PIL_FORMATS[ext], **kwargs)
