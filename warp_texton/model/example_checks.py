"""Is an example a texture a texton can learn? Warnings for real photographs.

A texton of side s reproduces the covariance of the example within an
(2s − 1)² window, under the assumption that the example is a sample of one
stationary texture (EUSIPCO §3). Photographs break that in a few common ways,
each a warning here (an :class:`~warp_texton.core.errors.ExampleWarning`) that
``analyze`` gives and the command line prints on one line:

* too large (:class:`LargeExampleWarning`): the analysis works on every pixel,
  so its time grows with the example's area, while the texton sees only
  features up to its own side;
* too smooth (:class:`SmoothExampleWarning`): most of the variance lies at
  wavelengths longer than half the texton's side (an upscaled photograph, a
  texture photographed too close): the noise shows texton-sized blotches;
* not stationary (:class:`NonStationaryWarning`): the local mean or contrast
  changes across the example (uneven lighting, a scene rather than a texture);
* a texton past half the example (:class:`LargeTextonWarning`, docs/limits.md).

:func:`downscale` and a crop (``u[y:y + h, x:x + w]``; ``--crop`` on the
command line) fix the first two; docs/photographs.md shows how. The
thresholds were set on scikit-image's grass, gravel and brick, GIMP's
patterns, their upscaled and unevenly lit versions, and scikit-image's
photographs (camera, astronaut, coffee, chelsea, rocket, moon): every texture
passes, every photograph and altered texture warns.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..core.checks import as_image, check_int
from ..core.errors import ExampleWarning, TextonError

#: Examples with more pixels than this get a :class:`LargeExampleWarning`.
LARGE_EXAMPLE_PIXELS = 1024 * 1024
#: The share of the variance at wavelengths longer than half the texton's side past
#: which an example is too smooth (textures measured 0.03-0.48, photographs and 4×
#: upscaled textures 0.62-0.87).
SMOOTH_SHARE = 0.55
#: Blocks of a grid of at most 4 × 4, each at least the texton's side and 64 px: the spread of
#: their means (their standard deviation over the example's) past which an example is
#: not stationary (textures measured 0.03-0.22, photographs and unevenly lit textures
#: 0.42-0.76) ...
MEAN_SPREAD = 0.3
#: The smallest block side: smaller blocks' means vary by chance (the thresholds were
#: measured on blocks of 64 px and more).
MIN_BLOCK = 64
#: ... or the ratio of their largest to their smallest standard deviation (textures
#: at most 1.7, photographs and lit textures 2-14).
CONTRAST_RATIO = 2.0


class LargeExampleWarning(ExampleWarning):
    """The example has more than :data:`LARGE_EXAMPLE_PIXELS` pixels."""


class SmoothExampleWarning(ExampleWarning):
    """Most of the example's variance lies at wavelengths longer than half the texton."""


class NonStationaryWarning(ExampleWarning):
    """The example's local mean or contrast varies across it."""


class LargeTextonWarning(ExampleWarning):
    """The texton is larger than half the example (docs/limits.md)."""


def downscale(u, factor: int) -> np.ndarray:
    """The example ``u`` shrunk ``factor`` times: each output pixel the mean of a
    ``factor`` × ``factor`` block (rows and columns past a whole block dropped).

    For a photograph whose features are larger than the texton, or too large to
    analyse quickly (docs/photographs.md): shrinking by f makes features f times
    smaller, in texels, and the analysis about f² times faster.

    Parameters
    ----------
    u : array (H, W) or (H, W, C)
        The example; integer arrays are scaled by their dtype's range.
    factor : int
        From 1 (a float32 copy) to min(H, W).

    Returns
    -------
    float32 array (H // factor, W // factor, C)

    Raises
    ------
    TextonError
        For an image ``analyze`` refuses and a ``factor`` outside [1, min(H, W)].

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import downscale
    >>> downscale(np.arange(16.0).reshape(4, 4), 2)[..., 0]
    array([[ 2.5,  4.5],
           [10.5, 12.5]], dtype=float32)
    """
    u = as_image(u)
    m, n, c = u.shape
    factor = check_int(factor, "factor", minimum=1, maximum=min(m, n))
    h, w = m // factor, n // factor
    blocks = u[:h * factor, :w * factor].reshape(h, factor, w, factor, c)
    return blocks.mean(axis=(1, 3), dtype=np.float64).astype(np.float32)


def crop_box(box, shape, name: str = "crop") -> tuple[int, int, int, int]:
    """``box`` = (x, y, width, height) checked to lie inside an image of ``shape``."""
    if not isinstance(box, (tuple, list)) or len(box) != 4:
        raise TextonError(f"{name} must be (x, y, width, height), got {box!r:.60}", param=name)
    x, y = (check_int(v, f"{name} {k}", minimum=0) for v, k in zip(box[:2], "xy"))
    w, h = (check_int(v, f"{name} {k}", minimum=1) for v, k in zip(box[2:], ("width", "height")))
    m, n = shape[:2]
    if x + w > n or y + h > m:
        raise TextonError(f"{name} {w}x{h} at ({x}, {y}) does not fit in the {n}x{m} image", param=name)
    return x, y, w, h


def low_frequency_share(t_hat: np.ndarray, n: int, size: int) -> float:
    """The share of the variance at wavelengths longer than ``size`` / 2 pixels: frequencies
    (cycles per pixel) below 2 / ``size``, from the rfft half-plane ``t_hat`` (M, n//2 + 1, C)
    of a kernel on an M × n grid (the mean excluded)."""
    m, nc = t_hat.shape[:2]
    power = np.einsum("ijc,ijc->ij", t_hat.real, t_hat.real) + np.einsum("ijc,ijc->ij", t_hat.imag, t_hat.imag)
    # the half-plane's columns other than 0 (and n/2 for an even n) stand for two frequencies
    weight = np.full(nc, 2.0)
    weight[0] = 1.0
    if n % 2 == 0:
        weight[-1] = 1.0
    fy = np.fft.fftfreq(m)[:, None]
    fx = np.arange(nc)[None, :] / n
    radius = np.hypot(fy, fx)
    power = power * weight
    power[0, 0] = 0.0
    total = float(power.sum())
    if total <= 0.0:
        return 0.0
    return float(power[radius < 2.0 / size].sum()) / total


def block_spread(u: np.ndarray, size: int) -> tuple[float, float] | None:
    """(spread of the block means over the example's standard deviation, largest over
    smallest block standard deviation) on a grid of g × g blocks of side at least
    ``size`` and :data:`MIN_BLOCK` (g from 2 to 4) of the example's luminance (channel mean); None when not even
    2 × 2 such blocks fit."""
    m, n = u.shape[:2]
    g = min(4, min(m, n) // max(size, MIN_BLOCK))
    if g < 2:
        return None
    y = u.mean(axis=2, dtype=np.float64)
    bm, bn = m // g, n // g
    blocks = y[:bm * g, :bn * g].reshape(g, bm, g, bn).transpose(0, 2, 1, 3).reshape(g * g, -1)
    sd = float(y.std())
    if sd <= 0.0:
        return None
    block_sd = blocks.std(axis=1)
    ratio = float(block_sd.max() / block_sd.min()) if block_sd.min() > 0 else math.inf
    return float(blocks.mean(axis=1).std()) / sd, ratio


def _advice(factor: int) -> str:
    return f"give downscale a factor of {factor}, or crop an evenly lit patch (docs/photographs.md)"


def warn_large(shape, size: int, name: str = "u") -> None:
    """The size warnings, before the analysis starts: a large example, a texton past half of it."""
    m, n = shape[:2]
    if m * n > LARGE_EXAMPLE_PIXELS:
        factor = math.ceil(math.sqrt(m * n / LARGE_EXAMPLE_PIXELS))
        warnings.warn(LargeExampleWarning(
            f"{name}: a {n}x{m} example is large: the analysis time grows with its {m * n / 1e6:.1f} megapixels "
            f"while a {size}x{size} texton sees features of at most {size} px; {_advice(factor)}",
            param=name, mentions=("downscale",)), stacklevel=3)
    if size > (min(m, n) + 1) // 2:
        warnings.warn(LargeTextonWarning(
            f"size {size} is more than half the {n}x{m} example: the texton models this image's own features "
            f"rather than its texture (docs/limits.md); use size <= {(min(m, n) + 1) // 2}, unless the example "
            "is a seamless tile", param="size", mentions=("size",)), stacklevel=3)


def warn_unsuited(u: np.ndarray, t_hat: np.ndarray, size: int, name: str = "u") -> None:
    """The content warnings, from the example ``u`` (H, W, C) and the rfft half-plane of
    its kernel (``analyze`` computes both): too smooth, not stationary."""
    m, n = u.shape[:2]
    share = low_frequency_share(t_hat, n, size)
    if share > SMOOTH_SHARE:
        # shrinking by f shortens every wavelength f times: the smallest f that passes
        factor = next((f for f in range(2, max(min(m, n) // size, 1) + 1)
                       if low_frequency_share(t_hat, n, f * size) <= SMOOTH_SHARE), None)
        advice = (_advice(factor) + ", or use a larger size" if factor is not None
                  else "crop a patch of finer texture or use a larger size (docs/photographs.md)")
        warnings.warn(SmoothExampleWarning(
            f"{name}: {100 * share:.0f} % of the example's variance lies at wavelengths longer than {size / 2:g} px, "
            f"half the texton's side: the noise will show blotches as large as the texton (an upscaled photograph, "
            f"or one taken too close?); {advice}", param=name, mentions=("size", "downscale")),
            stacklevel=3)
    spread = block_spread(u, size)
    if spread is not None and (spread[0] > MEAN_SPREAD or spread[1] > CONTRAST_RATIO):
        warnings.warn(NonStationaryWarning(
            f"{name}: the example is not stationary: across it, the local mean varies by {spread[0]:.2f} of its "
            f"standard deviation and the local contrast by a factor of {spread[1]:.1f} (uneven lighting, or a scene "
            "rather than a texture?); the texton averages them. Crop an evenly lit patch of one texture "
            "(docs/photographs.md)", param=name), stacklevel=3)
