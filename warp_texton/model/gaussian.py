"""Gaussian texture models of an image: estimation, distance and sampling.

An image u of M × N pixels defines the circular Gaussian model with mean m and
kernel t_u = (u − m) / √(MN) (EUSIPCO eq. (3)): its covariance is t_u ⊛ t̃_u and
its spectrum |t̂_u|² (for colour, the 3 × 3 cross-spectra t̂_u t̂_u*). Sampling
it is a convolution of t_u with white noise (the ADSN).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft as sfft

from ..core.checks import as_image, check_bool, check_seed, check_shape
from ..core.errors import TextonError
from ..core.limits import check_memory, check_work

#: scipy.fft workers for every FFT of the package: all cores.
FFT_WORKERS = -1
#: Bytes per image value (pixel × channel) at the peak of periodic_component:
#: the image and its border jumps in float64, the smooth part's spectrum
#: (complex128 half-plane) and the smooth part, the float32 result.
PERIODIC_BYTES_PER_VALUE = 48
#: Bytes per value of gaussian_texture's FFT grid: the white noise and its
#: spectrum, the kernel's spectrum and the product's inverse, per channel.
ADSN_BYTES_PER_VALUE = 40


def periodic_component(u) -> np.ndarray:
    """The periodic component of Moisan's periodic-plus-smooth decomposition.

    u = p + s where s is smooth (discrete-harmonic inside the image) and p is
    periodic-friendly: its circular Laplacian equals the non-periodic Laplacian
    of u, so tiling p shows no border jump. p has the same mean as u.

    Parameters
    ----------
    u : array (H, W) or (H, W, C)

    Returns
    -------
    p : float32 array (H, W, C)
        Same mean as u, no jump across the image border.

    Raises
    ------
    TextonError
        For an image that is not a finite numeric (H, W[, C]) array, and one
        over the memory budget.

    Notes
    -----
    Derivation and its discrete Poisson solve: docs/model.md §2.

    References
    ----------
    L. Moisan, "Periodic plus smooth image decomposition", J. Math. Imag. Vis.
    39 (2011), 161–179; used as a preprocess by CGF §4.2.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import read_image, periodic_component
    >>> from warp_texton.demo import demo_texture_path
    >>> u = read_image(demo_texture_path())
    >>> p = periodic_component(u)
    >>> p.shape, bool(np.allclose(p.mean(), u.mean(), atol=1e-5))
    ((256, 256, 1), True)
    """
    u = as_image(u)
    check_memory(PERIODIC_BYTES_PER_VALUE * float(u.size), f"the periodic component of a {u.shape[1]}x{u.shape[0]} "
                 "image", "use a smaller image")
    u = u.astype(np.float64)
    m, n, _ = u.shape
    # v: the jump of u across the image border, seen from inside.
    v = np.zeros_like(u)
    jump_y = u[-1] - u[0]
    jump_x = u[:, -1] - u[:, 0]
    v[0] += jump_y
    v[-1] -= jump_y
    v[:, 0] += jump_x
    v[:, -1] -= jump_x
    denom = (
        2.0 * np.cos(2.0 * np.pi * np.arange(m) / m)[:, None]
        + 2.0 * np.cos(2.0 * np.pi * np.arange(n) / n)[None, :]
        - 4.0
    )
    denom[0, 0] = 1.0  # the smooth part has zero mean
    nc = n // 2 + 1
    s_hat = sfft.rfft2(v, axes=(0, 1), workers=FFT_WORKERS) / denom[:, :nc, None]
    s_hat[0, 0] = 0.0
    s = sfft.irfft2(s_hat, s=(m, n), axes=(0, 1), workers=FFT_WORKERS)
    return (u - s).astype(np.float32)


def normalized_kernel(u, periodic: bool = True, name: str = "u") -> tuple[np.ndarray, np.ndarray]:
    """Mean m and kernel t_u = (u − m)/√(MN) of the Gaussian model of u (EUSIPCO eq. (3)).

    Parameters
    ----------
    u : array (H, W) or (H, W, C)
        The image, M × N = H × W pixels.
    periodic : bool
        Use the periodic component of u (CGF §4.2) instead of u.
    name : str
        How error messages name the image.

    Returns
    -------
    mean : float64 array (C,)
    t : float64 array (H, W, C)
        The kernel t_u, whose DFT's squared modulus is the model's spectrum.

    Raises
    ------
    TextonError
        For an image without variance, and the errors of
        :func:`periodic_component`.

    Examples
    --------
    See :func:`warp_texton.noise.mixing.barycentre_spectrum`.
    """
    u = as_image(u, name)
    periodic = check_bool(periodic, "periodic")
    mean = u.reshape(-1, u.shape[2]).astype(np.float64).mean(axis=0)
    if periodic:
        u = periodic_component(u)
    t = (u.astype(np.float64) - mean) / np.sqrt(u.shape[0] * u.shape[1])
    floor = 1e-12 * max(1.0, float(np.abs(mean).max()))
    if not np.any(np.abs(t) > floor):
        raise TextonError(f"{name}: the image is constant (its variations are below {floor:.3g}, 1e-12 of "
                          "max(1, |mean|)); there is no variance to model", param=name)
    return mean, t


def ot_distance(t0_hat: np.ndarray, t1_hat: np.ndarray) -> float:
    """Squared OT distance between two circular Gaussian models (EUSIPCO eq. (1)).

    Both arguments are full DFTs on the same grid Θ, shape (M, N, C); the
    zero frequency is excluded. Returns d² = 1/|Θ| Σ_{ξ≠0} |t̂0|² + |t̂1|² − 2|t̂0* t̂1|,
    where the product is the per-frequency Hermitian product over channels.

    Parameters
    ----------
    t0_hat, t1_hat : complex array (M, N, C)
        The DFTs (``np.fft.fft2(t, axes=(0, 1))``) of two kernels, as
        :func:`normalized_kernel` returns them.

    Returns
    -------
    float
        d², the squared distance (take its square root for d).

    References
    ----------
    EUSIPCO eq. (1); docs/model.md §3.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton.model.gaussian import ot_distance
    >>> t = np.random.default_rng(0).standard_normal((8, 8, 1))
    >>> f = np.fft.fft2(t, axes=(0, 1))
    >>> round(ot_distance(f, f), 9), round(ot_distance(f, 2 * f) / ot_distance(f, 0 * f), 6)
    (0.0, 1.0)
    """
    a = np.sum(np.abs(t0_hat) ** 2 + np.abs(t1_hat) ** 2, axis=-1)
    cross = np.abs(np.sum(np.conj(t0_hat) * t1_hat, axis=-1))
    d = a - 2.0 * cross
    d[0, 0] = 0.0
    return float(max(d.sum(), 0.0) / (d.shape[0] * d.shape[1]))


def half_plane_weights(n: int) -> np.ndarray:
    """Weights that turn a sum over an rfft half-plane (last axis n//2 + 1) into
    the sum over the full n columns, for a quantity even in ξ: 1 for the zero
    column (and the Nyquist column when n is even), 2 for the others."""
    w = np.full(n // 2 + 1, 2.0)
    w[0] = 1.0
    if n % 2 == 0:
        w[-1] = 1.0
    return w


def relative_model_error_half(tu_hat: np.ndarray, t_hat: np.ndarray, n: int) -> float:
    """:func:`relative_model_error` from rfft half-planes (M, n//2 + 1, C) of real kernels.

    Every term of the RME is even in ξ for real kernels (|ẑ(−ξ)| = |ẑ(ξ)|), so the
    half-plane with :func:`half_plane_weights` gives the full-grid sums.
    """
    w = half_plane_weights(n)[None, :]
    var = np.sum(tu_hat.real ** 2 + tu_hat.imag ** 2, axis=-1)
    model = np.sum(t_hat.real ** 2 + t_hat.imag ** 2, axis=-1)
    cross = np.abs(np.sum(np.conj(tu_hat) * t_hat, axis=-1))
    d = var + model - 2.0 * cross
    var[0, 0] = d[0, 0] = 0.0
    return float(np.sqrt(max((w * d).sum(), 0.0) / (w * var).sum()))


def relative_model_error(tu_hat: np.ndarray, t_hat: np.ndarray) -> float:
    """RME of EUSIPCO §3.2: √(d²_OT(t_u, t) / Σ_{ξ≠0} |t̂_u|² · |Θ|).

    The numerator is the OT distance of eq. (1) (with its factor 2: a perfect
    model scores 0), the denominator the marginal variance of the model of u.
    """
    var = np.sum(np.abs(tu_hat) ** 2, axis=-1)
    var[0, 0] = 0.0
    n = tu_hat.shape[0] * tu_hat.shape[1]
    return float(np.sqrt(ot_distance(tu_hat, t_hat) * n / var.sum()))


def gaussian_texture(u, shape=None, *, seed: int = 0, periodic: bool = True) -> np.ndarray:
    """Sample the Gaussian model of u (the ADSN, "Gaussian version" of CGF Fig. 7).

    At u's own shape the sample is circular: m + t_u ⊛ W with W a standard
    white noise on the same grid, so it tiles seamlessly. At any other shape
    it is the non-periodic ADSN on Z² restricted to the output (EUSIPCO §2.2,
    §2.4): t_u is zero-padded, convolved with white noise on a circular domain
    Θ ⊇ Ω − S, and cropped, so the covariance is the plain autocorrelation of
    t_u. Colour channels share one white noise, which keeps the cross-spectra.

    Parameters
    ----------
    u : array (H, W) or (H, W, C)
        Example texture.
    shape : (height, width), optional
        Output size; u's own size by default.
    seed : int
        Seed of the white noise.
    periodic : bool
        Model the periodic component of u (recommended for non-periodic
        photographs, CGF §4.2).

    Returns
    -------
    float32 array (height, width, C) with the same mean as u.

    Raises
    ------
    TextonError
        For an image that is not a finite numeric (H, W[, C]) array or is
        constant, a bad ``shape`` or ``seed``, and a sample over the memory or
        work budget.

    Notes
    -----
    Use it to judge whether a texture is Gaussian enough for texton noise: if
    the Gaussian version looks like the input, a texton will too.

    References
    ----------
    Galerne, Gousseau, Morel, "Random phase textures", IEEE TIP 2011; EUSIPCO §2.

    Examples
    --------
    >>> from warp_texton import read_image, gaussian_texture
    >>> from warp_texton.demo import demo_texture_path
    >>> u = read_image(demo_texture_path())
    >>> g = gaussian_texture(u, seed=1)                    # 256 x 256, tiles
    >>> big = gaussian_texture(u, shape=(600, 800), seed=1)
    >>> g.shape, big.shape
    ((256, 256, 1), (600, 800, 1))
    """
    u = as_image(u)
    seed = check_seed(seed)
    m, n, c = u.shape
    out_shape = (m, n) if shape is None else check_shape(shape)
    grid = out_shape if out_shape == (m, n) else (
        sfft.next_fast_len(out_shape[0] + m - 1, real=True), sfft.next_fast_len(out_shape[1] + n - 1, real=True))
    what = f"a {out_shape[1]}x{out_shape[0]} Gaussian texture of a {n}x{m} image"
    check_memory(ADSN_BYTES_PER_VALUE * float(grid[0]) * grid[1] * c, what, "use a smaller shape or image")
    check_work(3.0 * c * grid[0] * grid[1] * math.log2(max(grid[0] * grid[1], 2)), what,
               "use a smaller shape or image")
    mean, t = normalized_kernel(u, periodic=periodic)
    rng = np.random.default_rng(seed)
    if out_shape == (m, n):
        grid = (m, n)
        crop = (m, n)
    else:
        # Θ must contain Ω − S: output plus kernel extent, rounded to a fast size.
        grid = (sfft.next_fast_len(out_shape[0] + m - 1, real=True),
                sfft.next_fast_len(out_shape[1] + n - 1, real=True))
        crop = out_shape
    w = rng.standard_normal(grid)
    w_hat = sfft.rfft2(w, workers=FFT_WORKERS)
    t_hat = sfft.rfft2(t, s=grid, axes=(0, 1), workers=FFT_WORKERS)
    g = sfft.irfft2(t_hat * w_hat[:, :, None], s=grid, axes=(0, 1), workers=FFT_WORKERS)
    out = g[: crop[0], : crop[1]] + mean
    return np.ascontiguousarray(out, dtype=np.float32)
