"""Argument checks shared by the public functions.

Each check raises :class:`TextonError` with a message that names the argument
and what would be accepted, and with the argument's name as its ``param``, so
that callers never see a NumPy traceback for a user mistake. Numbers are numbers: strings such as ``"30"`` are refused where
a number is meant, rather than converted.

Image values. An integer image array is scaled by its dtype's range, as image
files are: unsigned integers to [0, 1] (``uint8`` / 255, ``uint16`` / 65535),
signed integers by their largest value (to about [−1, 1], as scikit-image's
``img_as_float``), booleans to 0 and 1. Float arrays are taken as they are.
Values whose magnitude exceeds :data:`MAX_VALUE` are refused where they feed
the analysis or the noise: sums and squares of such values over an image or a
texton would overflow float32 (docs/limits.md).
"""

from __future__ import annotations

import math
import numbers
import os
import warnings
from pathlib import Path

import numpy as np

from .errors import TextonError
from .limits import check_memory

#: Channel counts an image may have once loaded: grey or RGB.
CHANNELS = (1, 3)
#: Largest magnitude of an image value, texton coefficient or mean colour that
#: the analysis and the noise accept. Spectra are sums over up to 2**28 pixels
#: and the spectral projection multiplies two of them in complex64; noise sums
#: up to ~1e8 texton values per point in float32. 1e10 keeps both below
#: float32's 3.4e38 with a wide margin, and far above any image's values
#: (8/16-bit images are in [0, 1]; HDR radiances stay below ~1e6).
MAX_VALUE = 1.0e10
#: Smallest MNI: the noise divides by √λ in float32, and λ = MNI / area(supp h)
#: must stay well inside float32's range for every texton size.
MIN_MNI = 1.0e-3
#: Largest texton side: analysed (``size``) or read from a file (textons are small by design).
MAX_TEXTON_SIDE = 4096
#: Largest magnitude float32 can hold.
FLOAT32_MAX = float(np.finfo(np.float32).max)
#: The range of a positive real argument (:func:`check_positive`): the value and its
#: reciprocal are both normal float32 numbers (2**-126 to 2**126), so that neither the
#: float32 copies the kernels take nor the quantities derived from them (a cell's size
#: and its inverse, a texel size and the texels per unit) reach 0 or overflow.
MIN_POSITIVE = float(np.finfo(np.float32).tiny)
MAX_POSITIVE = 1.0 / MIN_POSITIVE


def is_real(value) -> bool:
    """True for a real number (Python or NumPy), False for bools, strings and the rest."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _float(value) -> float:
    """A real number as a float; an integer too large for one is infinite (and refused as such)."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def check_path(value, name: str) -> Path:
    """A file name: a ``str`` or ``os.PathLike`` (not None, bytes or a number)."""
    if isinstance(value, str) or (isinstance(value, os.PathLike) and isinstance(os.fspath(value), str)):
        if not str(value) or "\x00" in str(value):  # a Path too: it holds a NUL as any string does
            raise TextonError(f"{name} must be a non-empty file name without NUL characters, got {value!r:.80}",
                              param=name)
        return value if isinstance(value, Path) else Path(value)
    raise TextonError(f"{name} must be a file name (str or path), got {type(value).__name__} {value!r:.60}",
                      param=name)


def as_real_array(value, name: str, what: str = "an array of numbers") -> np.ndarray:
    """``value`` as a float64 array, refusing strings, objects, booleans and complex
    numbers (which ``np.asarray(..., float)`` would convert or fail on)."""
    try:
        a = np.asarray(value)
    except Exception:  # ragged sequences and the like
        raise TextonError(f"{name} must be {what}, got {value!r:.80}", param=name) from None
    if a.dtype.kind not in "iuf":
        raise TextonError(f"{name} must be {what}, got {_describe(a, value)}", param=name)
    if a.dtype != np.float64:
        check_memory(8.0 * a.size, f"{name}: {a.size} values", f"give fewer values for {name}", param=name)
    with np.errstate(over="ignore"):
        return a.astype(np.float64, copy=False)


def _describe(a: np.ndarray, value) -> str:
    if a.dtype.kind in "US":
        return f"text {value!r:.60}"
    if a.dtype.kind == "b":
        return "booleans"
    if a.dtype.kind == "c":
        return "complex numbers"
    return f"{type(value).__name__} {value!r:.60}"


def check_range(a: np.ndarray, name: str, limit: float | None, what: str = "values") -> None:
    """Refuse NaN, infinite and (with ``limit``) out-of-range entries of ``a``."""
    if a.size == 0:
        return
    finite = np.isfinite(a)
    if not finite.all():
        bad = int(a.size - np.count_nonzero(finite))
        raise TextonError(f"{name}: contains {bad} NaN or infinite values; {what} must be finite", param=name)
    bound = FLOAT32_MAX if limit is None else limit
    lo, hi = float(a.min()), float(a.max())
    if max(-lo, hi) > bound:
        raise TextonError(
            f"{name}: {what} range from {lo:.3g} to {hi:.3g}; accepted: within ±{bound:.3g}"
            + ("" if limit is None else " (larger values would overflow float32 arithmetic; rescale them)"),
            param=name)


def as_image(u, name: str = "u", *, finite: bool = True, limit: float | None = MAX_VALUE) -> np.ndarray:
    """Return ``u`` as a C-contiguous float32 array of shape ``(H, W, C)``.

    A 2-D array is one channel. Four channels are read as RGBA: the alpha is
    dropped with a warning. Any other channel count is refused, as are empty
    arrays and (with ``finite``) NaN or infinite pixels, and values beyond
    ±``limit`` (:data:`MAX_VALUE` by default; ``None``: float32's range).
    Integer arrays are scaled by their dtype's range (see the module's notes).
    """
    a = _image_array(u, name)
    # the float32 copy (and a float64 one for integers): an array view may be far larger than its memory
    check_memory(a.shape[0] * a.shape[1] * min(a.shape[2], 3) * (12.0 if a.dtype.kind in "uib" else 4.0),
                 f"{name}: a {a.shape[1]}x{a.shape[0]} image", "use a smaller image", param=name)
    c = a.shape[2]
    if c == 4:
        warnings.warn(f"{name}: dropping the alpha channel of an RGBA image", stacklevel=3)
        a = a[:, :, :3]
    elif c not in CHANNELS:
        raise TextonError(
            f"{name}: has {c} channels; expected 1 (grey), 3 (RGB) or 4 (RGBA, alpha dropped)", param=name
        )
    if a.dtype == bool:
        a = a.astype(np.float32)
    elif a.dtype.kind in "ui":
        # as image files are: by the dtype's range (float64 first: int32/64 exceed float32's mantissa)
        a = a.astype(np.float64) / float(np.iinfo(a.dtype).max)
    elif finite:
        check_range(a, name, limit, "pixels")  # before float32 could turn them into inf
    a = np.ascontiguousarray(a, dtype=np.float32)
    if finite and not np.isfinite(a).all():
        bad = int(np.count_nonzero(~np.isfinite(a)))
        raise TextonError(f"{name}: contains {bad} NaN or infinite values; pixels must be finite", param=name)
    return a


def _image_array(u, name: str) -> np.ndarray:
    """``u`` as a non-empty (H, W, C) array of real numbers or booleans, as it is."""
    if isinstance(u, (str, bytes)) or u is None:
        raise TextonError(f"{name}: expected a numeric image array, got {type(u).__name__} {u!r:.60}", param=name)
    try:
        a = np.asarray(u)
    except Exception as exc:  # ragged lists and the like
        raise TextonError(f"{name}: not an image array ({exc})", param=name) from None
    if a.dtype == object or not (np.issubdtype(a.dtype, np.number) or a.dtype == bool):
        raise TextonError(f"{name}: expected a numeric image array, got dtype {a.dtype}", param=name)
    if np.iscomplexobj(a):
        raise TextonError(f"{name}: expected a real image, got a complex array", param=name)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3:
        raise TextonError(
            f"{name}: expected an image of shape (H, W) or (H, W, C), got shape {a.shape}", param=name
        )
    if a.shape[0] == 0 or a.shape[1] == 0:
        raise TextonError(f"{name}: the image is empty (shape {a.shape})", param=name)
    return a


def check_int(value, name: str, *, minimum: int | None = None, maximum: int | None = None,
              choices=None) -> int:
    """An integer argument, optionally bounded or drawn from ``choices``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TextonError(f"{name} must be an integer, got {value!r:.60}", param=name)
    value = int(value)
    if choices is not None and value not in choices:
        listed = ", ".join(str(c) for c in choices)
        raise TextonError(f"{name} must be one of {listed}, got {value}", param=name)
    if minimum is not None and value < minimum:
        raise TextonError(f"{name} must be at least {minimum}, got {value}", param=name)
    if maximum is not None and value > maximum:
        raise TextonError(f"{name} must be at most {maximum}, got {value}", param=name)
    return value


def _finite_positive(value, name: str) -> float:
    if not is_real(value):
        raise TextonError(f"{name} must be a positive number, got {value!r:.60}", param=name)
    value = _float(value)
    if not math.isfinite(value) or value <= 0.0:
        raise TextonError(f"{name} must be a finite number > 0, got {value}", param=name)
    return value


def check_positive(value, name: str) -> float:
    """A finite, strictly positive real number within [MIN_POSITIVE, MAX_POSITIVE]
    (about 1.2e-38 to 8.5e37): itself and its reciprocal fit float32."""
    value = _finite_positive(value, name)
    if not MIN_POSITIVE <= value <= MAX_POSITIVE:
        raise TextonError(f"{name} must be between {MIN_POSITIVE:.3g} and {MAX_POSITIVE:.3g} (it and its reciprocal "
                          f"must fit float32), got {value:g}", param=name)
    return value


def check_mni(mni, name: str = "mni") -> float:
    """A mean number of impacts per point: a finite number >= MIN_MNI (larger
    values are bounded by the work budget and the cell limits)."""
    mni = _finite_positive(mni, name)
    if mni < MIN_MNI:
        raise TextonError(f"{name} must be at least {MIN_MNI:g} (the noise divides by the square root of the "
                          f"intensity), got {mni:g}", param=name)
    return check_positive(mni, name)


def check_real(value, name: str, *, minimum: float | None = None, maximum: float | None = None) -> float:
    """A finite real number, optionally within [minimum, maximum]."""
    if not is_real(value):
        raise TextonError(f"{name} must be a number, got {value!r:.60}", param=name)
    value = _float(value)
    if not math.isfinite(value):
        raise TextonError(f"{name} must be a finite number, got {value}", param=name)
    if minimum is not None and value < minimum:
        raise TextonError(f"{name} must be at least {minimum:g}, got {value:g}", param=name)
    if maximum is not None and value > maximum:
        raise TextonError(f"{name} must be at most {maximum:g}, got {value:g}", param=name)
    return value


def check_bool(value, name: str) -> bool:
    """A flag: True or False (NumPy booleans too), not a string or a number."""
    if not isinstance(value, (bool, np.bool_)):
        raise TextonError(f"{name} must be True or False, got {value!r:.60}", param=name)
    return bool(value)


def check_seed(seed) -> int:
    """A user seed: any integer in [0, 2**32)."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral):
        raise TextonError(f"seed must be an integer in [0, 2**32), got {seed!r:.60}", param="seed")
    if not 0 <= int(seed) < 2**32:
        raise TextonError(f"seed must be an integer in [0, 2**32), got {seed}", param="seed")
    return int(seed)


def check_shape(shape, name: str = "shape", *, max_pixels: int = 1 << 28) -> tuple[int, int]:
    """An output raster shape ``(H, W)`` of positive integers that fits in memory."""
    if isinstance(shape, (str, bytes)):
        raise TextonError(f"{name} must be a pair (height, width), got {shape!r:.60}", param=name)
    try:
        h, w = shape
    except Exception:  # not iterable, wrong length, or an array that refuses to unpack
        raise TextonError(f"{name} must be a pair (height, width), got {shape!r:.60}", param=name) from None
    h = check_int(h, f"{name}[0] (height)", minimum=1)
    w = check_int(w, f"{name}[1] (width)", minimum=1)
    if h * w > max_pixels:
        raise TextonError(
            f"{name} ({h}, {w}), a {w}x{h} raster, is too large: at most {max_pixels} pixels ({h * w} asked)", param=name
        )
    return h, w


def options_or_keywords(cls, value, name: str, defaults, keywords: dict):
    """The frozen option value of a call that takes both ``name=`` (a ``cls``) and the
    keywords it stands for (the fields of ``cls``).

    ``value`` itself when given, provided each keyword still holds its default in
    ``defaults`` (a ``cls``; None: ``cls()``); else ``cls`` made from the keywords,
    the fields they leave out taken from ``defaults``. A setting given twice is
    refused, naming the keyword, so that it has one place.
    """
    base = cls() if defaults is None else defaults
    if value is None:
        return cls(**{**{f: getattr(base, f) for f in cls.__dataclass_fields__}, **keywords})
    if not isinstance(value, cls):
        article = "an" if cls.__name__[0] in "AEIOU" else "a"
        raise TextonError(f"{name} must be {article} {cls.__name__}, got {type(value).__name__}", param=name)
    for key, given in keywords.items():
        if not _is_default(given, getattr(base, key)):
            raise TextonError(f"{key} is given both as a keyword ({given!r:.60}) and in {name} "
                              f"({getattr(value, key)!r:.60}); give it in one place", param=key)
    return value


def _is_default(value, default) -> bool:
    """``value`` is ``default`` as a caller leaves it (arrays and odd types compared safely)."""
    if value is default:
        return True
    if value is None or default is None or isinstance(value, (bool, np.bool_)) != isinstance(default, bool):
        return False
    try:
        return type(value) is type(default) and bool(value == default)
    except (TypeError, ValueError):
        return False
