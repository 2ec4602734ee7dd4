"""Texture mixing (CGF §7, after Xia et al. 2014).

Two Gaussian models with kernels t_u and t_v are mixed along the optimal
transport geodesic between them: τ_ρ = (1 − ρ) τ_0 + ρ τ_1 with τ_1 = t_v and
τ_0 = t_u rephased onto t_v, frequency by frequency, by the phase of the
Hermitian product t̂_u* t̂_v (which aligns the colour vectors). A texton is
computed for each τ_ρ with the same white-noise start, so neighbouring ρ give
neighbouring textons. Spatially varying noise then lets each impact take the
texton of the region it falls in, with a random sign ε = ±1 so that textons of
non-zero sum add no mean (a marked Poisson process); the mean colour is
interpolated per pixel.

Histogram-preserving textons (docs/histogram.md, "Mixing") mix in their
Gaussian space: the Gaussian models mix as above, and the colour map of ρ is
the displacement interpolation of the two examples' marginals, the lookup
tables (quantile functions) and centres interpolated linearly, which needs the
two transforms to share their colour axes (grey textures always do). Mixed
noise maps each pixel through the colour maps of its neighbouring textons,
weighted as its mean is.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.fft as sfft

from ..model.noise_tables import at_mni
from ..core.checks import as_image, as_real_array, check_bool, check_mni, check_seed, check_shape
from ..core.runtime import resolve_device
from ..model.analysis import (check_analysis_cost, check_size_fits, texton_from_spectrum,
                       texton_half_spectrum, unit_phase)
from ..model.analysis_options import AnalysisOptions
from ..core.errors import TextonError
from ..core.limits import check_memory
from ..model.gaussian import FFT_WORKERS, normalized_kernel
from ..model.histogram import HistogramTransform
from .colours import noise_moments
from .engine import noise_setup, padded_coeffs, params_record
from .raster import Regions, raster, raster_geometry
from ..model.texton import Texton

#: Host memory per mixed texton besides its coefficients (8 bytes each at most): its rho (a
#: float in an array and in a list, 40 bytes), the Texton object and its metadata; measured
#: (tracemalloc, 2000 textons of 8x8 RGB) 1.55 KiB a texton in all, against this estimate's 2.56 KiB.
MIX_STEP_BYTES = 1024


def mix_bytes(steps: float, size: int, channels: int = 3) -> float:
    """Bytes of ``steps`` mixed textons of ``size`` x ``size`` (and their rhos)."""
    return float(steps) * (MIX_STEP_BYTES + 8.0 * size * size * channels)

def barycentre_spectrum(tu_hat: np.ndarray, tv_hat: np.ndarray, rho: float) -> np.ndarray:
    """τ̂_ρ = (1 − ρ) τ̂_0 + ρ t̂_v with τ̂_0 = t̂_u · (t̂_u* t̂_v)/|t̂_u* t̂_v| (CGF §7).

    The spectrum of the barycentre kernel: ``e^{iφ}`` = (t̂_u* t̂_v)/|t̂_u* t̂_v|
    is, at every frequency, the phase of the Hermitian product over the
    channels (1 where that product is 0: t̂_u is kept). The model of τ_ρ lies
    on the OT geodesic: d(t_u, τ_ρ) = ρ d(t_u, t_v), d(τ_ρ, t_v) = (1 − ρ) d(t_u, t_v)
    for the distance of EUSIPCO eq. (1) (:func:`warp_texton.model.gaussian.ot_distance`,
    which returns d²; proof in docs/model.md §11). This is the building block
    of :func:`warp_texton.mix_textons`; use it to study the models themselves.

    Parameters
    ----------
    tu_hat : complex array (..., C)
        DFT (full or rfft half-plane) of a real kernel, channels last.
    tv_hat : complex array (..., C)
        DFT of a second real kernel on the same grid, of the same shape.
    rho : float
        Not checked: values outside [0, 1] extrapolate along the line.

    Returns
    -------
    complex array of the same shape

    References
    ----------
    CGF §7; Xia et al. 2014 (see :func:`warp_texton.mix_textons`).

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import read_image
    >>> from warp_texton.demo import demo_texture_path
    >>> from warp_texton.model.gaussian import normalized_kernel, ot_distance
    >>> from warp_texton.noise.mixing import barycentre_spectrum
    >>> u = read_image(demo_texture_path())
    >>> _, tu = normalized_kernel(u)           # t_u = (p - m) / sqrt(MN), p the periodic component
    >>> _, tv = normalized_kernel(0.6 * np.rot90(u) + 0.3)
    >>> fu, fv = np.fft.fft2(tu, axes=(0, 1)), np.fft.fft2(tv, axes=(0, 1))
    >>> d = np.sqrt(ot_distance(fu, fv))
    >>> for rho in (0.25, 0.5, 0.75):
    ...     tau = barycentre_spectrum(fu, fv, rho)
    ...     print(rho, round(np.sqrt(ot_distance(fu, tau)) / d, 6), round(np.sqrt(ot_distance(tau, fv)) / d, 6))
    0.25 0.25 0.75
    0.5 0.5 0.5
    0.75 0.75 0.25
    """
    cross = np.sum(np.conj(tu_hat) * tv_hat, axis=-1)
    # where the product vanishes any unit phase is a geodesic: keep t̂_u as it is
    phase = np.where(cross != 0, unit_phase(cross), 1.0)
    return (1.0 - rho) * tu_hat * phase[..., None] + rho * tv_hat


def _check_rhos(rhos, size: int) -> list[float]:
    a = as_real_array(rhos, "rhos", "numbers in [0, 1]")
    if a.ndim > 1:
        raise TextonError(f"rhos must be numbers in [0, 1] (a sequence), got an array of shape {a.shape}", param="rhos")
    # before the list of rhos and the textons it asks for (RGB at most)
    check_memory(mix_bytes(a.size, size), f"mixing {a.size} textons of {size}x{size}",
                 "use fewer rhos or a smaller size", param="rhos", mentions=("rhos", "size"))
    values = [float(r) for r in np.atleast_1d(a)]
    if not values:
        raise TextonError("rhos must hold at least one value in [0, 1]", param="rhos")
    bad = [r for r in values if not (0.0 <= r <= 1.0)]
    if bad:
        raise TextonError(f"rhos must lie in [0, 1]; got {bad[0]!r}", param="rhos")
    return values


def _as_rgb(a: np.ndarray, c: int) -> np.ndarray:
    return np.repeat(a, c, axis=-1) if a.shape[-1] == 1 and c == 3 else a


def _model(x, grid, name: str, periodic: bool):
    """(mean, half spectrum, lag-0 covariance) of an image or a texton on ``grid``."""
    if isinstance(x, Texton):
        if x.size[0] > grid[0] or x.size[1] > grid[1]:
            raise TextonError(
                f"{name}: a {x.size[1]}x{x.size[0]} texton does not fit the {grid[1]}x{grid[0]} grid of the "
                "other image; mix it with a larger image, or with a texton", param=name
            )
        t_hat = texton_half_spectrum(x, grid)
        cov = x.covariance()
        return x.mean.astype(np.float64), t_hat, cov
    u = as_image(x, name)
    m, n = grid
    h0, w0 = (u.shape[0] - m) // 2, (u.shape[1] - n) // 2
    mean, t = normalized_kernel(u[h0:h0 + m, w0:w0 + n], periodic=periodic, name=name)
    flat = t.reshape(-1, t.shape[2])
    return mean, sfft.rfft2(t, axes=(0, 1), workers=FFT_WORKERS), flat.T @ flat


def mix_textons(
    u,
    v,
    rhos,
    *,
    size: int = 64,
    order: int = 1,
    iterations: int = 50,
    seed: int = 0,
    periodic: bool = True,
    color_correction: bool = True,
    support: str = "square",
    progress: bool = False,
    options: AnalysisOptions | None = None,
) -> list[Texton]:
    """Textons along the optimal-transport path from the texture u to v.

    Parameters
    ----------
    u : image array (H, W[, C]) or Texton
        The first texture (ρ = 0). Images of different sizes are
        centre-cropped to the common size; a grey input is mixed with an
        RGB one as three equal channels. A Texton stands for its own
        Gaussian model.
    v : image array (H, W[, C]) or Texton
        The second texture (ρ = 1), as ``u``.
    rhos : sequence of float in [0, 1]
        Mixing parameters: 0 gives u's model, 1 gives v's.
    size : int
        As in :func:`warp_texton.analyze`.
    order : {0, 1, 3, 5}
        As in :func:`warp_texton.analyze`.
    iterations : int
        As in :func:`warp_texton.analyze`.
    seed : int
        As in :func:`warp_texton.analyze`. Every ρ starts from the same white noise (the seed), so the
        textons are comparable across ρ; they are a continuous function of ρ,
        though after many iterations a step of 0.05 can move them as far as a
        change of seed (the projections are not convex).
    periodic : bool
        As in :func:`warp_texton.analyze`.
    color_correction : bool
        As in :func:`warp_texton.analyze`.
    support : {"square", "disk"}
        As in :func:`warp_texton.analyze`.
    progress : bool
        Show a progress bar over the ρ values.
    options : AnalysisOptions, optional
        ``size``, ``order``, ``iterations``, ``seed``, ``periodic``,
        ``color_correction`` and ``support`` as one value
        (:class:`~warp_texton.AnalysisOptions`), in place of those keywords,
        which must then keep their defaults. Its ``histogram`` must be
        "gaussian": histogram transforms are mixed from textons that carry them
        (give ``u`` and ``v`` as textons from ``analyze(..., histogram="preserve")``).

    Returns
    -------
    list of Texton
        One per ρ, in the order of ``rhos``. Texton ρ models the barycentre
        τ_ρ = (1 − ρ) τ_0 + ρ t_v of the two models, its mean is
        (1 − ρ) m_u + ρ m_v, and ``metadata["rho"]`` holds ρ. With the same
        options and seed, ρ = 0 gives the texton ``analyze(u)`` gives (to
        float32 rounding, when u is at the common size) and ρ = 1 that of
        ``analyze(v)``.

    Raises
    ------
    TextonError
        For ``rhos`` that are not numbers, empty, or outside [0, 1]; a
        ``size``, ``order``, ``iterations``, ``seed`` or ``support`` that
        :func:`analyze` would refuse; a common size smaller than ``size``; a
        texton larger than the other image; an image that is not a numeric
        (H, W[, C]) array with C in {1, 3, 4} (an alpha channel is dropped
        with a warning), holds NaN or infinite values, or is constant. The
        message names ``u`` or ``v``. Also, when one input is a texton with a
        histogram transform, an other input that is not one, and two
        transforms whose colour axes differ (their lookup tables cannot be
        interpolated channel by channel).

    Notes
    -----
    One white-noise start for all ρ makes the textons comparable: a
    continuous function of ρ, much closer to their neighbours than to another
    seed's textons (docs/model.md §11, "one texton per ρ from the same white
    noise").

    References
    ----------
    CGF §7; G.-S. Xia, S. Ferradans, G. Peyré, J.-F. Aujol, "Synthesizing and
    mixing stationary Gaussian texture models", SIAM J. Imaging Sci. 2014.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import read_image, analyze, mix_textons
    >>> from warp_texton.demo import demo_texture_path
    >>> u = read_image(demo_texture_path())      # grass, 256 x 256, grey
    >>> v = 0.6 * np.rot90(u) + 0.3              # turned by 90 degrees, brighter, less contrast
    >>> textons = mix_textons(u, v, np.linspace(0, 1, 5), size=32, iterations=30)
    >>> [t.metadata["rho"] for t in textons]
    [0.0, 0.25, 0.5, 0.75, 1.0]
    >>> [round(float(t.mean[0]), 3) for t in textons]
    [0.466, 0.495, 0.523, 0.551, 0.58]

    The ends are the single-texture textons (same options, same seed):

    >>> bool(np.allclose(textons[0].coeffs, analyze(u, size=32, iterations=30).coeffs, atol=1e-6))
    True
    >>> bool(np.allclose(textons[-1].coeffs, analyze(v, size=32, iterations=30).coeffs, atol=1e-6))
    True

    A texton can stand for a texture; a grey texture mixes with an RGB one as RGB:

    >>> rgb = np.stack([u[:, :, 0], 0.9 * u[:, :, 0], 0.5 * np.fliplr(u[:, :, 0])], axis=-1)
    >>> half = mix_textons(textons[0], rgb, 0.5, size=32, iterations=30)[0]
    >>> half.channels, half.metadata["rho"]
    (3, 0.5)

    Two histogram-preserving textons mix their colour maps too (the lookup
    tables interpolated: ρ = ½ has the quantiles halfway between):

    >>> a, b = analyze(u, size=32, histogram="preserve"), analyze(v, size=32, histogram="preserve")
    >>> mid = mix_textons(a, b, [0.5], size=32, iterations=30)[0]
    >>> bool(np.allclose(mid.histogram.lut, (a.histogram.lut + b.histogram.lut) / 2))
    True
    """
    o = AnalysisOptions.given(options, size=size, order=order, iterations=iterations, seed=seed, periodic=periodic,
                              color_correction=color_correction, support=support)
    if o.histogram != "gaussian":
        raise TextonError(f"histogram {o.histogram!r} of options: mix_textons mixes the histogram transforms of "
                          "textons that carry them; give u and v as textons from analyze(..., "
                          "histogram='preserve'), with options of histogram 'gaussian'", param="histogram")
    size, order, iterations, seed = o.size, o.order, o.iterations, o.seed
    periodic, color_correction, support = o.periodic, o.color_correction, o.support
    transforms = _mixed_transforms(u, v)
    rhos = _check_rhos(rhos, size)
    progress = check_bool(progress, "progress")
    # images are converted once (an RGBA input warns once)
    u = u if isinstance(u, Texton) else as_image(u, "u")
    v = v if isinstance(v, Texton) else as_image(v, "v")
    shapes = [x.shape for x in (u, v) if not isinstance(x, Texton)]
    if shapes:
        grid = (min(s[0] for s in shapes), min(s[1] for s in shapes))
    else:
        side = 2 * max(max(t.size) for t in (u, v)) + 2 * size
        grid = (side, side)
    check_size_fits(size, grid, "u, v", "the common grid of both images")
    c = max(x.shape[2] if not isinstance(x, Texton) else x.channels for x in (u, v))
    check_analysis_cost(grid, c, iterations, f"mixing {len(rhos)} textons on a {grid[1]}x{grid[0]} grid",
                        textons=len(rhos), size=size)
    mu, tu_hat, cov_u = _model(u, grid, "u", periodic)
    mv, tv_hat, cov_v = _model(v, grid, "v", periodic)
    c = max(tu_hat.shape[-1], tv_hat.shape[-1])
    mu, mv = _as_rgb(mu[None], c)[0], _as_rgb(mv[None], c)[0]
    tu_hat, tv_hat = _as_rgb(tu_hat, c), _as_rgb(tv_hat, c)
    rows = range(len(rhos))
    if progress:
        from ..core.progress import bar

        rows = bar(rows, desc="mix", unit="texton")
    out = []
    for k in rows:
        rho = rhos[k]
        tau_hat = barycentre_spectrum(tu_hat, tv_hat, rho)
        cov = None
        if color_correction:
            tau = sfft.irfft2(tau_hat, s=grid, axes=(0, 1), workers=FFT_WORKERS).reshape(-1, c)
            cov = tau.T @ tau
        texton = texton_from_spectrum(tau_hat, grid[1], (1.0 - rho) * mu + rho * mv, size, order,
                                      iterations, seed, covariance=cov, support=support)
        texton.metadata.update(rho=rho, periodic=bool(periodic))
        if transforms is not None:
            tu, tv = transforms
            texton = replace(texton, histogram=tu.mixed(tv, rho))
        out.append(texton)
    return out


def _mixed_transforms(u, v) -> tuple[HistogramTransform, HistogramTransform] | None:
    """The histogram transforms of u and v, which mix when both have one on the same colour axes."""
    tr = [x.histogram if isinstance(x, Texton) else None for x in (u, v)]
    if tr[0] is None and tr[1] is None:
        return None
    if tr[0] is None or tr[1] is None:
        name = "u" if tr[0] is None else "v"
        raise TextonError(f"{name}: mixing a histogram-preserving texton needs another one: give {name} as a texton "
                          "from analyze(..., histogram='preserve'), or mix textons without histogram transforms",
                          param=name)
    a, b = tr[0], tr[1]
    assert a is not None and b is not None
    if a.channels != b.channels or a.lut.shape != b.lut.shape or not np.allclose(a.matrix, b.matrix, atol=1e-6):
        raise TextonError("u, v: their histogram transforms have different colour axes (principal axes), so their lookup "
                          "tables cannot be interpolated channel by channel; mix grey textures, textures of the "
                          "same colour axes, or textons without histogram transforms", param="u")
    return a, b


def _check_textons(textons) -> list[Texton]:
    if isinstance(textons, Texton):
        textons = [textons]
    try:
        textons = list(textons)
    except TypeError:
        raise TextonError("textons must be a sequence of Texton") from None
    if not textons or not all(isinstance(t, Texton) for t in textons):
        raise TextonError("textons must be a non-empty sequence of Texton")
    if len({t.histogram is None for t in textons}) > 1:
        raise TextonError("textons: some have a histogram transform and some do not; mixed noise needs all or "
                          "none of them histogram-preserving", param="textons")
    first = textons[0]
    for k, t in enumerate(textons[1:], 1):
        if (t.size, t.order, t.channels) != (first.size, first.order, first.channels):
            raise TextonError(
                f"textons[{k}] is {t.size[1]}x{t.size[0]}, order {t.order}, {t.channels} channels, but "
                f"textons[0] is {first.size[1]}x{first.size[0]}, order {first.order}, {first.channels} "
                "channels; mixed noise needs textons of one size, order and channel count"
            )
    return textons


def _check_weights(weights, shape) -> np.ndarray | None:
    """None for "strips", else the (H, W) float32 ρ map."""
    if isinstance(weights, str):
        if weights != "strips":
            raise TextonError(f"weights must be 'strips' or an (H, W) map of values in [0, 1], got {weights!r}")
        return None
    rho = as_real_array(weights, "weights", "'strips' or an (H, W) map of values in [0, 1]")
    if rho.ndim == 3 and rho.shape[2] == 1:
        rho = rho[:, :, 0]
    if rho.shape != tuple(shape):
        raise TextonError(f"weights map has shape {rho.shape}; it must match the raster shape {tuple(shape)}",
                          param="weights map")
    if not np.isfinite(rho).all():
        raise TextonError("weights map contains NaN or infinite values; values must lie in [0, 1]", param="weights map")
    if rho.min() < 0.0 or rho.max() > 1.0:
        raise TextonError(f"weights map values must lie in [0, 1]; found {rho.min():g} to {rho.max():g}",
                          param="weights map")
    return np.ascontiguousarray(rho, dtype=np.float32)


def synthesize_mixed(
    textons,
    weights="strips",
    shape=(512, 512),
    *,
    mni: float = 30.0,
    seed: int = 0,
    scale: float = 1.0,
    offset=(0.0, 0.0),
    device=None,
    method: str = "auto",
) -> np.ndarray:
    """Spatially varying texton noise: each impact takes the texton of its region.

    g(x) = m(x) + Σ_j ε_j h_{r(x_j)}(x − x_j) / √λ with ε_j = ±1 at random and
    r(x_j) the texton of the region where the impact lands (CGF §7). Textons
    ``textons[r]`` stand for ρ = r / (R − 1).

    Parameters
    ----------
    textons : sequence of Texton
        R textons of one size, order and channel count (e.g. from :func:`mix_textons`).
    weights : "strips" or array (H, W) of ρ in [0, 1]
        Regions are read where each impact's texton has its centre (CGF §7
        tests x_j ∈ D_r for a kernel centred on x_j), so textures cover their
        regions and blend over about a texton's width across the borders.
        "strips": R vertical strips across the raster, as in CGF Fig. 5; the
        mean goes linearly from the first texton's to the last's. A map: each
        impact takes texton round(ρ (R − 1)) at the nearest pixel; the mean at
        each pixel is the textons' means interpolated at its ρ.
    shape : (height, width)
        Raster size in pixels (see :func:`warp_texton.synthesize`).
    mni : float
        Mean number of impacts per point (see :func:`warp_texton.synthesize`).
    seed : int
        The noise's seed (see :func:`warp_texton.synthesize`).
    scale : float
        Pixels per texel (see :func:`warp_texton.synthesize`).
    offset : (x, y)
        Noise position of the raster's top-left corner, texels (see
        :func:`warp_texton.synthesize`). There is no rotation: strips and maps
        live in the raster's frame.
    device : str, optional
        Warp device (see :func:`warp_texton.synthesize`).
    method : {"auto", "splat", "gather"}
        How the raster is computed (see :func:`warp_texton.synthesize`).

    Returns
    -------
    float32 array (H, W, C)
        λ = mni / support_area of the texton with the largest support, and
        the impacts are those :func:`synthesize` draws for that texton with
        the same ``mni`` and ``seed``; the signs make the sum zero-mean
        whatever the textons' integrals.

    Raises
    ------
    TextonError
        For ``textons`` that is empty, holds something other than
        Textons, or mixes sizes, orders or channel counts, or textons
        with and without histogram transforms (one texton alone is accepted; one whose coefficients are all zero gives
        its regions the mean alone); ``weights`` that is neither "strips" nor
        a map of the raster's shape ((H, W) or (H, W, 1)) with finite values
        in [0, 1]; and the ``shape``, ``mni``, ``seed``, ``scale``,
        ``offset``, ``device`` and ``method`` errors of :func:`synthesize`.

    References
    ----------
    CGF §7, Fig. 5; docs/model.md §11.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import read_image, mix_textons, synthesize_mixed
    >>> from warp_texton.demo import demo_texture_path
    >>> u = read_image(demo_texture_path())
    >>> v = 0.6 * np.rot90(u) + 0.3
    >>> textons = mix_textons(u, v, np.linspace(0, 1, 11), size=32, iterations=30)

    From u on the left to v on the right, in 11 strips; the mean ramps from
    u's to v's:

    >>> strips = synthesize_mixed(textons, "strips", shape=(128, 512), seed=1, device="cpu")
    >>> strips.shape, strips.dtype
    ((128, 512, 1), dtype('float32'))
    >>> round(float(strips[:, :40].mean()), 2), round(float(strips[:, -40:].mean()), 2)
    (0.48, 0.6)

    Any layout: v inside a disc, u outside, a soft edge in between:

    >>> y, x = np.mgrid[:256, :256]
    >>> rho = np.clip((80 - np.hypot(x - 128, y - 128)) / 20, 0, 1)
    >>> disc = synthesize_mixed(textons, rho, shape=(256, 256), seed=1, device="cpu")
    """
    textons = _check_textons(textons)
    h, w = check_shape(shape)
    rho = _check_weights(weights, (h, w))
    seed = check_seed(seed)
    mni = check_mni(mni)
    textons = [at_mni(t, mni) for t in textons]  # the histogram tables of this MNI's noise
    # one λ for every texton: that of the widest support (zero textons are allowed in a mix)
    widest = max(textons, key=lambda t: t.support_area)
    setup = noise_setup(widest, mni)
    origin, step = raster_geometry((h, w), scale, 0.0, offset)
    device = resolve_device(device)
    p = params_record(widest, setup, seed)
    p["mean"] = 0.0
    p["integral"] = 0.0  # the random signs make the sum zero-mean
    pad_rows, pad_cols = setup.coeffs.shape[:2]
    stack = np.zeros((len(textons), pad_rows, pad_cols, 3), np.float32)
    for k, t in enumerate(textons):
        stack[k] = padded_coeffs(t)
    c = textons[0].channels
    # grey textons: one float a texel and a pixel through the kernels
    out = raster(p, setup, stack, textons[0].order, (h, w), origin, step, device, method, scale,
                 regions=Regions(len(textons), rho), lanes=1 if c == 1 else 3)
    means = np.stack([t.mean for t in textons]).astype(np.float64)  # (R, C)
    knots = np.linspace(0.0, 1.0, len(textons)) if len(textons) > 1 else np.zeros(1)
    out = out[:, :, :c]
    if textons[0].histogram is not None:
        return _mixed_colours(out, textons, knots, (np.arange(w) + 0.5) / w if rho is None else rho)
    for ch in range(c):
        if rho is None:  # strips: the mean depends on the column only
            out[:, :, ch] += np.interp((np.arange(w) + 0.5) / w, knots, means[:, ch]).astype(np.float32)[None, :]
        else:
            out[:, :, ch] += np.interp(rho, knots, means[:, ch]).astype(np.float32)
    return np.ascontiguousarray(out)


def _mixed_colours(noise: np.ndarray, textons: list[Texton], knots: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """Colours of mean-free mixed noise (H, W, C): each pixel standardised by the
    interpolated standard deviation and mapped through its neighbouring textons'
    colour maps, with the weights that interpolate the mean at its ρ (an (H, W)
    map, or the (W,) columns of strips)."""
    h, w, c = noise.shape
    rho = np.broadcast_to(rho, (h, w)).ravel()
    weights = np.stack([np.interp(rho, knots, np.eye(len(textons))[k]) for k in range(len(textons))])
    stds = np.stack([noise_moments(t)[1] for t in textons])  # (R, C)
    g = noise.reshape(-1, c) / (weights.T @ stds)
    out = np.zeros((h * w, c))
    for k, t in enumerate(textons):
        near = np.flatnonzero(weights[k] > 0)
        if near.size:
            assert t.histogram is not None
            out[near] += weights[k, near, None] * t.histogram.to_colours(g[near])
    return out.reshape(h, w, c).astype(np.float32)
