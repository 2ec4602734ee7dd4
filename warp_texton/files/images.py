"""Reading and writing images: PNG/JPEG through Pillow, EXR through OpenEXR 3.x,
16-bit RGB PNG through imagecodecs and TIFF through tifffile (the ``formats`` extra).

Images are float32 arrays (H, W, C) with C in {1, 3}. Every write goes to a
temporary file in the destination folder and is renamed into place, so a
failed write leaves no partial file. Integer formats clip to [0, 1]; the
number of clipped pixels is returned and, above CLIP_WARN of the image,
reported once as a warning.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
import threading
import warnings
from pathlib import Path

import numpy as np

from ..core.checks import as_image, check_path
from ..core.errors import TextonError
from ..core.limits import check_memory

#: Extensions ``write_image`` accepts, with the Pillow format used for each.
PIL_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG"}
EXR = ".exr"
TIFF = (".tif", ".tiff")
#: The pixel types each extension stores, the first being the default.
DTYPES = {".png": ("uint8", "uint16"), ".jpg": ("uint8",), ".jpeg": ("uint8",), EXR: ("float32", "float16"),
          ".tif": ("float32", "float16", "uint16", "uint8"), ".tiff": ("float32", "float16", "uint16", "uint8")}
#: EXR compressions by name; pxr24 (for float32), b44, b44a, dwaa and dwab are lossy.
EXR_COMPRESSIONS = ("zip", "zips", "piz", "rle", "none", "pxr24", "b44", "b44a", "dwaa", "dwab")
#: TIFF compressions by name (zstd and lzw through imagecodecs).
TIFF_COMPRESSIONS = ("zlib", "zstd", "lzw", "none")
#: Warn when more than this fraction of the pixels is clipped by an integer format:
#: the tails of a faithful Gaussian texture clip a few tenths of a percent.
CLIP_WARN = 1e-2
#: TIFF files larger than this are written in tiles of TIFF_TILE pixels (and as
#: BigTIFF past 2**32 bytes), which image viewers and GIS read piecewise.
TIFF_TILED_BYTES = 64 << 20
TIFF_TILE = 512
FORMATS_EXTRA = "pip install 'warp-texton[formats]'"


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
    removed: list[Path] = []
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
    from ..core.checks import check_path

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


def exr_header(compression: str = "zip", **attributes) -> dict:
    """A scanline EXR header, ``compression`` by name (default ZIP, lossless), plus ``attributes``."""
    exr = _exr_module()
    if compression not in EXR_COMPRESSIONS:
        raise TextonError(f"compression must be one of {', '.join(EXR_COMPRESSIONS)} for EXR, got {compression!r}")
    return {"compression": getattr(exr, f"{compression.upper()}_COMPRESSION" if compression != "none"
                                   else "NO_COMPRESSION"), "type": exr.scanlineimage, **attributes}


def write_exr(path, img: np.ndarray, half: bool = False, compression: str = "zip", **attributes) -> None:
    """Write an (H, W, 1|3) array as an EXR ("Y" or "RGB" channels), atomically:
    float32, or half floats with ``half`` (values beyond ±65504 become ±65504)."""
    exr = _exr_module()
    header = exr_header(compression, **attributes)
    img = np.ascontiguousarray(img, dtype=np.float32)
    if half:
        img = convert_pixels(img, "float16")[0]
    channels = {"Y": np.ascontiguousarray(img[:, :, 0])} if img.shape[2] == 1 else {"RGB": img}
    with atomic_path(path) as tmp:
        try:
            _interruptible(lambda: exr.File(header, channels).write(str(tmp)), tmp, img.nbytes)
        except RuntimeError as exc:  # how OpenEXR reports a failed write (disk full, I/O error...)
            raise _write_error(exc, path, tmp) from None


#: Writes of more bytes than this run in a worker thread (see _interruptible).
THREADED_WRITE_BYTES = 16 << 20
#: Seconds between two looks at a pending signal while a worker thread writes.
WAIT_SLICE = 0.1


def _interruptible(write, tmp, nbytes: int) -> None:
    """Run ``write()``, one native call that releases the GIL (OpenEXR's write of a
    whole image: its Python binding offers no write in parts), so that Ctrl-C and
    SIGTERM still act within WAIT_SLICE: Python runs signal handlers only in the
    main thread between bytecodes, so a large write runs in a worker thread while
    the caller waits in short slices. An interrupted worker cannot be stopped; it
    finishes into the temporary file (which :func:`atomic_path` has removed) and
    removes the file again if the write re-created it."""
    if nbytes <= THREADED_WRITE_BYTES or threading.current_thread() is not threading.main_thread():
        write()
        return
    failure: list[BaseException] = []
    cancelled = threading.Event()

    def work() -> None:
        try:
            write()
        except BaseException as exc:  # handed to the caller below
            failure.append(exc)
        finally:
            if cancelled.is_set():
                with contextlib.suppress(OSError):
                    os.unlink(tmp)

    worker = threading.Thread(target=work, name="warp-texton-write", daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(WAIT_SLICE)
    except BaseException:
        cancelled.set()
        raise
    if failure:
        raise failure[0]


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


def check_image_memory(h: int, w: int, c: int, path, copies: float = 3.0, nbytes: float | None = None) -> None:
    """Refuse to read an (h, w, c) image whose pixels would not fit the memory budget:
    ``nbytes`` when given (:func:`~warp_texton.image_headers.decode_bytes`), else
    the decoded pixels plus the float32 image (``copies`` float32 images in all)."""
    need = float(h) * w * max(c, 1) * 4.0 * copies if nbytes is None else nbytes
    check_memory(need, f"{path}: a {w}x{h} image with {c} channels", "use a smaller image")


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
    return "texton_order" in header or header.get("texton_kind") == "tiling"


def read_image(path) -> np.ndarray:
    """Read an image file as float32 (H, W, C), C in {1, 3}.

    PNG, JPEG and the other formats Pillow reads are scaled from 8 or 16 bits
    to [0, 1]; EXR (by extension) is read through OpenEXR as stored; TIFF
    through tifffile when installed (integers scaled, floats as stored), and
    16-bit RGB PNG through imagecodecs. An alpha channel is dropped with a
    warning. A texton file (``.texton``, or an EXR written by
    :meth:`Texton.save`) is not an image: it is refused with a hint (read it
    with :func:`load_texton`). The file's declared size is checked against the
    memory budget before its pixels are decoded.

    Parameters
    ----------
    path : str or Path
        An image file.

    Returns
    -------
    float32 array (H, W, C)
        In [0, 1] for integer formats; EXR and float TIFF values as stored.

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
    header = read_exr_header(path) if ext == EXR else {}
    if ext == ".texton" or (ext == EXR and is_texton_header(header)):
        tiling = header.get("texton_kind") == "tiling"
        what = "tiling model" if tiling else "texton"
        where = "synthesize, view, info; docs/tiling.md" if tiling else \
            "synthesize, render-plane, mix, surface --texton, view, info"
        raise TextonError(
            f"{path}: is a {what} file, not an image; give an example image here, or use the {what} where "
            f"a model is expected (load_texton; on the command line: {where})"
        )
    if ext == EXR:
        return read_exr(path)[0]
    from .readers import read_pixels

    return as_image(read_pixels(path), str(path), limit=None)


def image_size(path) -> tuple[int, int, int] | None:
    """(height, width, channels) that an image file's header declares, without
    decoding it (channels once read: 1 or 3), or None for formats whose header is
    not read here; callers that will analyse the image price that first."""
    from .readers import declared

    path = check_path(path, "path")
    if not path.is_file():
        return None
    if path.suffix.lower() == EXR:
        h, w, c = exr_size(read_exr_header(path), path)
        return h, w, 1 if c == 1 else 3
    d = declared(path)
    return None if d is None else (d.height, d.width, d.channels)


def check_image_path(path, name: str = "path") -> Path:
    """``path`` as a Path if its extension is one ``write_image`` writes and its
    name fits the file system (checked before long work, so that a bad name
    fails at once)."""
    path = check_output_name(path, name)
    ext = path.suffix.lower()
    if ext not in DTYPES:
        raise TextonError(f"{path}: unsupported extension {ext or '(none)'!r}; "
                          "use .png, .jpg, .jpeg, .exr, .tif or .tiff")
    return path


def check_dtype(path, dtype=None) -> str:
    """The pixel type ``write_image`` stores at ``path``: ``dtype`` if that format
    takes it, else the format's default."""
    ext = check_image_path(path).suffix.lower()
    if dtype is None:
        return DTYPES[ext][0]
    name = dtype if isinstance(dtype, str) else None
    if isinstance(dtype, (type, np.dtype)):
        try:
            name = np.dtype(dtype).name
        except TypeError:
            name = None
    if name not in DTYPES[ext]:
        raise TextonError(f"{path}: dtype must be one that {ext} stores ({', '.join(DTYPES[ext])}), not {dtype!r:.60}",
                          param="dtype")
    return name


def convert_pixels(img: np.ndarray, dtype: str, *, in_place: bool = False) -> tuple[np.ndarray, int]:
    """(pixels as ``dtype``, number of pixels with a value clipped).

    uint8/uint16 store [0, 1] scaled to the type's range, rounded; values
    outside are clipped. float16 clips to its finite range ±65504; float32
    stores the values as they are. Large chunks go through here: pixels are
    tested one by one only when the extremes are out of range, and
    ``in_place`` lets the clipping and scaling reuse ``img`` (float32; the
    caller gives it up) instead of allocating copies.
    """
    img = np.asarray(img, np.float32)
    if dtype == "float32":
        return img, 0
    lo, hi = (-65504.0, 65504.0) if dtype == "float16" else (0.0, 1.0)
    clipped = 0
    if img.size and not (img.min() >= lo and img.max() <= hi):
        over = img.min(axis=-1) < lo
        over |= img.max(axis=-1) > hi
        clipped = int(np.count_nonzero(over))
        del over
        img = np.clip(img, lo, hi, out=img if in_place else None)
        in_place = True  # a copy of ours now
    if dtype == "float16":
        return img.astype(np.float16), clipped
    scaled = np.multiply(img, np.float32(np.iinfo(dtype).max), out=img if in_place else None)
    np.rint(scaled, out=scaled)
    return scaled.astype(dtype), clipped


def report_clipped(name, clipped: int, total: int, dtype: str) -> None:
    """Warn once when more than CLIP_WARN of ``total`` pixels were clipped."""
    if total and clipped > CLIP_WARN * total:
        keep = "use .exr, .tif or .zarr with a float type to keep them" if dtype.startswith("uint") else \
            "use float32 to keep them"
        where = "[0, 1]" if dtype.startswith("uint") else "the float16 range"
        warnings.warn(f"{name}: {clipped} of {total} pixels ({100.0 * clipped / total:.3g} %) had values outside "
                      f"{where}, clipped for {dtype}; {keep}", stacklevel=3)


def write_image(path, img, *, dtype=None, compression=None) -> int:
    """Write an image atomically; return the number of pixels clipped.

    By extension, with the pixel type ``dtype`` (the first is the default):

    | extension | ``dtype`` | ``compression`` |
    | --- | --- | --- |
    | ``.exr`` | ``"float32"``, ``"float16"`` (half; values beyond ±65504 clipped) | ``"zip"`` (default), ``"zips"``, ``"piz"``, ``"rle"``, ``"none"`` are lossless; ``"pxr24"`` (lossy for float32), ``"b44"``, ``"b44a"``, ``"dwaa"``, ``"dwab"`` are lossy |
    | ``.png`` | ``"uint8"``, ``"uint16"`` (16-bit RGB through ``imagecodecs``: Pillow writes no 48-bit PNG) | deflate |
    | ``.jpg``, ``.jpeg`` | ``"uint8"`` (quality 95) | — |
    | ``.tif``, ``.tiff`` | ``"float32"``, ``"float16"``, ``"uint16"``, ``"uint8"``, through ``tifffile``; tiled 512 × 512 above 64 MiB, BigTIFF past 4 GiB | ``"zlib"`` (default), ``"zstd"``, ``"lzw"``, ``"none"`` |

    Integer types hold [0, 1] scaled to their range, rounded; values outside
    are clipped, and when more than 1 % of the pixels are (``CLIP_WARN``; the
    tails of a faithful Gaussian texture clip a few tenths of a percent) a
    warning says how many, once. 16-bit RGB PNG and TIFF need the
    ``formats`` extra (``pip install "warp-texton[formats]"``: ``imagecodecs``,
    ``tifffile``); :func:`read_image` reads them back at full depth. The file
    appears only once it is complete.

    Parameters
    ----------
    path : str or Path
        Its extension chooses the format.
    img : array (H, W) or (H, W, C)
    dtype : str, optional
        "uint8", "uint16", "float16" or "float32", as the format allows.
    compression : str, optional
        EXR: one of EXR_COMPRESSIONS (default "zip", lossless); TIFF: one of
        TIFF_COMPRESSIONS (default "zlib"). PNG is always deflated.

    Returns
    -------
    int
        Pixels with a value clipped to the stored range.

    Raises
    ------
    TextonError
        For an unsupported extension, type or compression, a missing folder, a
        name longer than the file system allows (before writing), or a bad
        image.
    OSError
        When the write fails (a full disk): it names ``path`` and leaves no
        file.

    Examples
    --------
    >>> from warp_texton import read_image, write_image
    >>> from warp_texton.demo import demo_texture_path
    >>> u = read_image(demo_texture_path())      # (256, 256, 1) float32 in [0, 1]
    >>> write_image("grass.exr", u)              # lossless float32
    0
    >>> write_image("grass.png", u)              # 8-bit
    0
    >>> write_image("grass_16.png", u, dtype="uint16")
    0
    >>> write_image("grass_half.exr", u, dtype="float16", compression="piz")
    0
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     write_image("too_bright.png", u * 3)   # clipped to [0, 1], with a warning
    51752
    >>> len(caught)
    1
    """
    path = check_image_path(path)
    ext = path.suffix.lower()
    dtype = check_dtype(path, dtype)
    img = as_image(img, "img", limit=None)
    if compression is not None and not isinstance(compression, str):
        raise TextonError(f"compression must be a name such as 'zip' (EXR) or 'zlib' (TIFF), got "
                          f"{type(compression).__name__} {compression!r:.60}", param="compression")
    if compression is not None and ext not in (EXR, *TIFF):
        raise TextonError(f"{path}: compression applies to .exr and .tif/.tiff outputs, not {ext}")
    if ext == EXR:
        clipped = convert_pixels(img, dtype)[1]
        write_exr(path, img, half=dtype == "float16", compression=compression or "zip")
    elif ext in TIFF:
        data, clipped = convert_pixels(img, dtype)
        _write_tiff(path, data, compression or "zlib")
    else:
        data, clipped = convert_pixels(img, dtype)
        if dtype == "uint16":
            _write_png16(path, data)
        else:
            from PIL import Image

            pil = Image.fromarray(data[:, :, 0] if data.shape[2] == 1 else data)
            with atomic_path(path) as tmp:
                kwargs = {"quality": 95} if PIL_FORMATS[ext] == "JPEG" else {}
                pil.save(tmp, format=PIL_FORMATS[ext], **kwargs)
    report_clipped(path, clipped, img.shape[0] * img.shape[1], dtype)
    return clipped


def _optional(name: str, what: str):
    try:
        return __import__(name)
    except ImportError:
        raise TextonError(f"{what} needs the {name} package: {FORMATS_EXTRA}") from None


def _write_png16(path, data: np.ndarray) -> None:
    """A 16-bit PNG: grey through Pillow; RGB through imagecodecs (Pillow writes no 48-bit PNG)."""
    if data.shape[2] == 1:
        from PIL import Image

        pil = Image.fromarray(np.ascontiguousarray(data[:, :, 0]))
        with atomic_path(path) as tmp:
            pil.save(tmp, format="PNG")
        return
    codecs = _optional("imagecodecs", "a 16-bit RGB PNG")
    encoded = codecs.png_encode(np.ascontiguousarray(data))
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(encoded)


def _write_tiff(path, data: np.ndarray, compression: str) -> None:
    if compression not in TIFF_COMPRESSIONS:
        raise TextonError(f"compression must be one of {', '.join(TIFF_COMPRESSIONS)} for TIFF, got {compression!r}")
    tifffile = _optional("tifffile", "TIFF output")
    if compression in ("zstd", "lzw"):
        _optional("imagecodecs", f"{compression} TIFF compression")
    big = data.nbytes > TIFF_TILED_BYTES
    kwargs = {"tile": (TIFF_TILE, TIFF_TILE)} if big else {}
    with atomic_path(path) as tmp:
        tifffile.imwrite(tmp, data[:, :, 0] if data.shape[2] == 1 else data,
                         photometric="minisblack" if data.shape[2] == 1 else "rgb",
                         compression=None if compression == "none" else compression,
                         bigtiff=data.nbytes > (1 << 32) - (1 << 26), **kwargs)
