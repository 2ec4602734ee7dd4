"""Discrete spot noise (EUSIPCO Algorithm 1): the discrete reference of texton noise."""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft

from ..core.checks import check_mni, check_seed, check_shape
from ..core.errors import TextonError
from .histogram import refuse_transform
from ..core.limits import check_memory, check_work
from .texton import Texton


def dsn(texton: Texton, shape, *, mni: float = 30.0, seed: int = 0) -> np.ndarray:
    """Discrete spot noise of the texton coefficients on an H × W raster.

    The coefficients α are used as a discrete spot h on Z². Following
    EUSIPCO Algorithm 1, n ~ Poisson(λ|Ω̄|) impacts are drawn uniformly on
    Ω̄ = Ω − S_h, and f = m + (Σ_i h(x − x_i) − λ Σ h) / √λ with
    λ = mni / |S_h| (|S_h| = number of non-zero coefficients). The sum over
    impacts is computed as the FFT convolution of the impact-count image with
    h, which is the same sum. For an order-0 texton this is texton noise with
    impacts on the integer grid; for higher orders it omits the b̂ factor.

    Parameters
    ----------
    texton : Texton
    shape : (height, width)
    mni : float
        Mean number of impacts per pixel, λ |S_h|.
    seed : int

    Returns
    -------
    float32 array (height, width, C)

    Raises
    ------
    TextonError
        For a ``texton`` that is not a :class:`Texton`, or that has a histogram
        transform (this reference draws the Gaussian model: use
        :func:`~warp_texton.synthesize` for the example's colours), a bad
        ``shape``, ``mni`` or ``seed``, and a raster over the memory or work budget.

    Notes
    -----
    It is the CPU reference for an order-0 texton (the discrete SOT of
    ``analyze(u, order=0)``); it runs on NumPy, not on Warp.

    References
    ----------
    EUSIPCO §2.4, Algorithm 1.

    Examples
    --------
    >>> from warp_texton import read_image, analyze, dsn
    >>> from warp_texton.demo import demo_texture_path
    >>> t0 = analyze(read_image(demo_texture_path()), size=32, order=0)   # the discrete SOT
    >>> f = dsn(t0, (256, 384), mni=30, seed=2)
    >>> f.shape, f.dtype
    ((256, 384, 1), dtype('float32'))
    """
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    refuse_transform(texton, "dsn (the discrete spot noise of the Gaussian model)",
                     "use synthesize for the example's colours, or analyse the example with histogram='gaussian'")
    h, w = check_shape(shape)
    mni = check_mni(mni)
    seed = check_seed(seed)
    r, s, c = texton.coeffs.shape
    area = int(np.count_nonzero(texton.support_mask)) or r * s
    lam = mni / area
    # Ω̄ = Ω − S_h: impacts up to (r−1, s−1) above-left of the frame still reach it.
    eh, ew = h + r - 1, w + s - 1
    grid = (sfft.next_fast_len(eh, real=True), sfft.next_fast_len(ew, real=True))
    impacts = lam * eh * ew
    impacts += 10 * np.sqrt(impacts)
    cells = float(grid[0]) * grid[1]
    what = f"discrete spot noise of {w}x{h} pixels at MNI {mni:g}"
    # impact indices (int64), the count image, the spectra (complex128 half-planes) and the convolution per channel
    check_memory(8.0 * impacts + cells * (16.0 + 24.0 * c), what, "use a lower mni or a smaller shape")
    check_work(impacts + 3.0 * (c + 1) * cells * np.log2(max(cells, 2.0)), what, "use a lower mni or a smaller shape")
    a = texton.coeffs.astype(np.float64)
    rng = np.random.default_rng(seed)
    n = rng.poisson(lam * eh * ew)
    idx = rng.integers(0, eh * ew, size=n)
    counts = np.bincount(idx, minlength=eh * ew).reshape(eh, ew).astype(np.float64)
    p_hat = sfft.rfft2(counts, s=grid, workers=-1)
    a_hat = sfft.rfft2(a, s=grid, axes=(0, 1), workers=-1)
    conv = sfft.irfft2(p_hat[:, :, None] * a_hat, s=grid, axes=(0, 1), workers=-1)
    # counts index k ↔ impact at k − (r−1, s−1); pixel x sees Σ_k P(k) α(x + (r−1, s−1) − k)
    f = conv[r - 1: r - 1 + h, s - 1: s - 1 + w]
    out = texton.mean + (f - lam * a.sum(axis=(0, 1))) / np.sqrt(lam)
    return np.ascontiguousarray(out, dtype=np.float32)
