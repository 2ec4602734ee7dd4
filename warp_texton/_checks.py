"""Argument checks shared by the public functions.

Each check raises :class:`TextonError` with a message that names the argument
and what would be accepted, so that callers never see a NumPy traceback for a
user mistake.
"""

from __future__ import annotations

import math
import numbers
import warnings

import numpy as np

from .errors import TextonError

#: Channel counts an image may have once loaded: grey or RGB.
CHANNELS = (1, 3)


def as_image(u, name: str = "u", *, finite: bool = True) -> np.ndarray:
    """Return ``u`` as a C-contiguous float32 array of shape ``(H, W, C)``.

    A 2-D array is one channel. Four channels are read as RGBA: the alpha is
    dropped with a warning. Any other channel count is refused, as are empty
    arrays and (with ``finite``) NaN or infinite pixels.
    """
    try:
        a = np.asarray(u)
    except Exception as exc:  # ragged lists and the like
        raise TextonError(f"{name}: not an image array ({exc})") from None
    if a.dtype == object or not (np.issubdtype(a.dtype, np.number) or a.dtype == bool):
        raise TextonError(f"{name}: expected a numeric image array, got dtype {a.dtype}")
    if np.iscomplexobj(a):
        raise TextonError(f"{name}: expected a real image, got a complex array")
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3:
        raise TextonError(
            f"{name}: expected an image of shape (H, W) or (H, W, C), got shape {a.shape}"
        )
    if a.shape[0] == 0 or a.shape[1] == 0:
        raise TextonError(f"{name}: the image is empty (shape {a.shape})")
    c = a.shape[2]
    if c == 4:
        warnings.warn(f"{name}: dropping the alpha channel of an RGBA image", stacklevel=3)
        a = a[:, :, :3]
    elif c not in CHANNELS:
        raise TextonError(
            f"{name}: has {c} channels; expected 1 (grey), 3 (RGB) or 4 (RGBA, alpha dropped)"
        )
    a = np.ascontiguousarray(a, dtype=np.float32)
    if finite and not np.isfinite(a).all():
        bad = int(np.count_nonzero(~np.isfinite(a)))
        raise TextonError(f"{name}: contains {bad} NaN or infinite values; pixels must be finite")
    return a


def check_int(value, name: str, *, minimum: int | None = None, choices=None) -> int:
    """An integer argument, optionally bounded below or drawn from ``choices``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TextonError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if choices is not None and value not in choices:
        listed = ", ".join(str(c) for c in choices)
        raise TextonError(f"{name} must be one of {listed}, got {value}")
    if minimum is not None and value < minimum:
        raise TextonError(f"{name} must be at least {minimum}, got {value}")
    return value


def check_positive(value, name: str) -> float:
    """A finite, strictly positive real number."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TextonError(f"{name} must be a positive number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value <= 0.0:
        raise TextonError(f"{name} must be a finite number > 0, got {value}")
    return value


def check_seed(seed) -> int:
    """A user seed: any integer in [0, 2**32)."""
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral):
        raise TextonError(f"seed must be an integer in [0, 2**32), got {seed!r}")
    if not 0 <= int(seed) < 2**32:
        raise TextonError(f"seed must be an integer in [0, 2**32), got {seed}")
    return int(seed)


def check_shape(shape, name: str = "shape", *, max_pixels: int = 1 << 28) -> tuple[int, int]:
    """An output raster shape ``(H, W)`` of positive integers that fits in memory."""
    try:
        h, w = shape
    except (TypeError, ValueError):
        raise TextonError(f"{name} must be a pair (height, width), got {shape!r}") from None
    h = check_int(h, f"{name}[0] (height)", minimum=1)
    w = check_int(w, f"{name}[1] (width)", minimum=1)
    if h * w > max_pixels:
        raise TextonError(
            f"{name} {h}x{w} is too large: at most {max_pixels} pixels ({h * w} asked)"
        )
    return h, w
