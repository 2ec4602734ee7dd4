"""Relief from the noise: exact gradients, normal maps and height maps.

:func:`gradient` differentiates what :func:`~warp_texton.evaluate` and
:func:`~warp_texton.synthesize` return, for texton noise (each impact's texton
differentiated for its own interpolation order) and for tiling models (the blend with
its weights' derivative), through the histogram tables (T'(g) ∇g) where a model has them.
:func:`normal_map` and :func:`height_map` take the luminance (the channel mean, as the
tiling guide does) or one channel as the height. docs/relief.md.

Kernels driven here: ``warp_texton.kernels.noise_gradient``.
"""

from __future__ import annotations

import numpy as np

from ..model.noise_tables import at_mni
from ..core.checks import check_positive, check_seed
from ..core.errors import TextonError
from ..core.limits import check_memory
from ..core.runtime import init_warp, resolve_device, split_launch
from ..model.histogram import GAUSS_RANGE
from ..model.texton import Texton
from ..model.tiling import TilingModel
from .colours import noise_moments
from .filter_options import FilterOptions
from .engine import CELL_FACTOR, POINT_BYTES, check_cell_range, check_points_cost, noise_params, noise_setup
from .noise_options import NoiseOptions
from .raster import check_points, raster_placement
from .synthesis import check_tiling_period, check_tiling_reach, synthesize
from .tiling import lattice_struct, refuse_texton_options, tiling_struct

#: Bytes a point of a gradient holds on its way (its position, the kernels' 3 × 3 result, the (C, 2) output).
GRADIENT_BYTES = POINT_BYTES + 36 + 24
#: The normal maps' conventions: the sign of the image-y component (OpenGL and glTF: green points up the image).
CONVENTIONS = {"opengl": 1.0, "directx": -1.0}


def _check_filter(filter) -> None:
    if filter is not None and FilterOptions.of(filter).kind != "none":
        raise TextonError(f"filter {filter!r}: gradients are of the unfiltered noise only (filter='none'); "
                          "a filtered value has no exact derivative here", param="filter")


def value_slopes(model, pts: np.ndarray, noise: NoiseOptions | None, seed: int, period, device, texton_options):
    """(N, 3, 3) float32: rows value, ∂/∂x, ∂/∂y (three lanes) of the model's noise before its tables."""
    from ..kernels import noise_gradient

    wp = init_warp()
    n = pts.shape[0]
    out = np.zeros((n, 3, 3), np.float32)
    if isinstance(model, TilingModel):
        refuse_texton_options(texton_options)
        seed = check_seed(seed)
        check_tiling_reach(pts)
        per = check_tiling_period(period)
        device = resolve_device(device)
        tiling_struct(model, seed, device)  # the model's arrays on the device

        def launch(a, b):
            t = tiling_struct(model, seed, device)
            lat = lattice_struct(model, per)
            res = wp.zeros(b - a, dtype=wp.mat33, device=device)
            wp.launch(noise_gradient.tiling_gradient_points, dim=b - a,
                      inputs=[t, lat, wp.array(pts[a:b], dtype=wp.vec2d, device=device), res], device=device)
            out[a:b] = res.numpy()
    else:
        assert noise is not None
        setup = noise_setup(model, noise.mni, noise.period, noise.cell_factor)
        model = at_mni(model, noise.mni)  # the histogram tables of this MNI's noise (and their slopes)
        if n:
            check_cell_range(pts[:, 0].min() - setup.hi[0], pts[:, 0].max() - setup.lo[0], setup.cell[0], "points")
            check_cell_range(pts[:, 1].min() - setup.hi[1], pts[:, 1].max() - setup.lo[1], setup.cell[1], "points")
        check_points_cost(setup, n, f"gradients at {n} points")
        device = resolve_device(device)
        p = noise_params(model, setup, noise.seed, noise.poisson)
        coeffs = wp.array(setup.coeffs, dtype=wp.vec3, device=device)

        def launch(a, b):
            res = wp.zeros(b - a, dtype=wp.mat33, device=device)
            wp.launch(noise_gradient.texton_gradient_points, dim=b - a,
                      inputs=[p, coeffs, wp.array(pts[a:b], dtype=wp.vec2d, device=device), res], device=device)
            out[a:b] = res.numpy()

    split_launch(device, noise_gradient, n, launch)
    return out


def table_slopes(model, values: np.ndarray) -> np.ndarray:
    """(N, C, C) float64: the Jacobian d colour_r / d value_c of the model's histogram transform
    (``to_colours``) at the noise values (N, C), entry [n, r, c]: the tables' linear segments'
    slopes, 0 where a table is clamped (beyond its ends)."""
    tr = model.histogram
    c = model.channels
    mean, std = noise_moments(model)
    g = (values[:, :c].astype(np.float64) - mean) / std
    k = tr.lut.shape[1]
    per = (k - 1) / (2.0 * GAUSS_RANGE)
    pos = (g + GAUSS_RANGE) * per
    i0 = np.minimum(np.clip(pos, 0.0, k - 1).astype(np.int64), k - 2)
    ch = np.arange(c)[None, :]
    slope = (tr.lut[ch, i0 + 1] - tr.lut[ch, i0]) * per * ((pos >= 0.0) & (pos <= k - 1))
    return np.einsum("nc,cr->nrc", slope / std, tr.matrix)


def _colour_gradient(model, slopes: np.ndarray) -> np.ndarray:
    """(N, C, 2) float32 of the kernels' (N, 3, 3) value-and-gradient rows, through the model's tables."""
    c = model.channels
    grad = np.stack([slopes[:, 1, :c], slopes[:, 2, :c]], axis=-1)  # (N, C, 2)
    if model.histogram is not None and len(grad):
        grad = np.einsum("nrc,nck->nrk", table_slopes(model, slopes[:, 0, :c]), grad.astype(np.float64))
    return np.ascontiguousarray(grad, dtype=np.float32)


def gradient(
    model: Texton | TilingModel,
    points=None,
    *,
    shape=None,
    mni: float = 30.0,
    seed: int = 0,
    scale: float = 1.0,
    rotation: float = 0.0,
    offset=(0.0, 0.0),
    period=None,
    device=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    noise: NoiseOptions | None = None,
    pixel_offset=(0, 0),
    filter="none",
) -> np.ndarray:
    """Exact derivatives of the noise that :func:`evaluate` and :func:`synthesize` give.

    At points: ``gradient(model, points)`` is (N, C, 2), entry [n, c] = (∂/∂x, ∂/∂y) of
    channel c of ``evaluate(model, points)`` at point n, in value units per texel. On a
    raster: ``gradient(model, shape=(H, W), scale=..., rotation=..., offset=...)`` is
    (H, W, C, 2), the derivatives of ``synthesize(model, (H, W), ...)`` per *pixel*
    (∂/∂column, ∂/∂row): the texel gradient times the raster's step, so a scaled or
    rotated raster's relief is its image's.

    Texton noise: ∇g = Σ_j ∇h(x − x_j) / √λ over the impacts of the value (same seeds,
    same cells). Orders 3 and 5 (B-splines, C² and C⁴) are exact. Order 1 (bilinear) is
    piecewise linear: on its kinks (x − x_j with an integer coordinate) the slope of the
    texel cell to the right (below), the one the value reads; elsewhere exact. Order 0
    (nearest) is piecewise constant: its gradient is 0 (exactly, almost everywhere).
    Tiling models: the blend's derivative with its weights' (barycentric, sharpened,
    guided) and the bilinear example's, one-sided on its kinks; the weights the cutoff
    drops are left out as in the value. Histogram tables are differentiated along:
    T'(g) ∇g, 0 where a table clamps.

    Parameters
    ----------
    model : Texton or TilingModel
    points : array (N, 2), optional
        Positions (x, y) in texel units (as :func:`evaluate`); give either ``points`` or ``shape``.
    shape : (H, W), optional
        A raster placed by ``scale``, ``rotation``, ``offset`` and ``pixel_offset`` as in
        :func:`synthesize`.
    mni, seed, period, device, poisson, cell_factor, noise
        As in :func:`synthesize` (a tiling model takes ``seed``, ``period`` and ``device``).
    filter : "none"
        Only the unfiltered noise has a gradient here: other filters are refused.

    Returns
    -------
    float32 array (N, C, 2) or (H, W, C, 2)

    Raises
    ------
    TextonError
        For both or neither of ``points`` and ``shape``, a ``filter`` other than "none",
        and the errors of :func:`evaluate` and :func:`synthesize`.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, evaluate, gradient
    >>> t = Texton(np.random.default_rng(0).normal(0, 0.1, (8, 8, 1)), mean=[0.5], order=3)
    >>> x = np.array([[10.3, 4.7]])
    >>> g = gradient(t, x, seed=1, device="cpu")
    >>> e = 1e-3
    >>> fd = (evaluate(t, x + [e, 0], seed=1, device="cpu") - evaluate(t, x - [e, 0], seed=1, device="cpu")) / (2 * e)
    >>> bool(abs(g[0, 0, 0] - fd[0, 0]) < 1e-2 * max(1.0, abs(fd[0, 0])))
    True
    """
    _check_filter(filter)
    if (points is None) == (shape is None):
        raise TextonError("gradient takes either points (N, 2) or shape=(H, W), not both or neither",
                          param="points", mentions=("points", "shape"))
    if not isinstance(model, (Texton, TilingModel)):
        raise TextonError(f"model must be a Texton or a TilingModel, got {type(model).__name__}", param="model")
    texton_options = dict(mni=(mni, 30.0), poisson=(poisson, "exact"), cell_factor=(cell_factor, CELL_FACTOR),
                          noise=(noise, None))
    opts = None
    if isinstance(model, Texton):
        opts = NoiseOptions.given(noise, mni=mni, seed=seed, period=period, poisson=poisson, cell_factor=cell_factor)
    if points is not None:
        pts = np.ascontiguousarray(check_points(points, GRADIENT_BYTES, "gradients at"), np.float64)
        return _colour_gradient(model, value_slopes(model, pts, opts, seed, period, device, texton_options))
    (h, w), first, origin, step = raster_placement(shape, scale, rotation, offset, pixel_offset)
    check_memory(float(h * w) * (GRADIENT_BYTES + 16), f"gradients of a {w}x{h} raster", "use a smaller shape",
                 param="shape")
    jj, ii = np.meshgrid(np.arange(w, dtype=np.float64) + first[1] + 0.5,
                         np.arange(h, dtype=np.float64) + first[0] + 0.5)
    pts = np.stack([origin[0] + step[0, 0] * jj + step[0, 1] * ii,
                    origin[1] + step[1, 0] * jj + step[1, 1] * ii], axis=-1).reshape(-1, 2)
    grad = _colour_gradient(model, value_slopes(model, pts, opts, seed, period, device, texton_options))
    # per pixel: ∂/∂j = ∇g · step_x, ∂/∂i = ∇g · step_y
    return np.ascontiguousarray((grad @ step).reshape(h, w, -1, 2), dtype=np.float32)


def _height_weights(model, channel) -> np.ndarray:
    c = model.channels
    if channel is None:
        return np.full(c, 1.0 / c)
    if isinstance(channel, bool) or not isinstance(channel, (int, np.integer)) or not 0 <= int(channel) < c:
        raise TextonError(f"channel must be None (the luminance) or an integer in [0, {c}), got {channel!r}",
                          param="channel")
    wts = np.zeros(c)
    wts[int(channel)] = 1.0
    return wts


def _height_std(model, wts: np.ndarray) -> float:
    cov = np.atleast_2d(model.covariance())
    return float(np.sqrt(max(float(wts @ cov @ wts), 1e-30)))


def normal_map(model: Texton | TilingModel, shape=(512, 512), *, strength: float = 1.0, convention: str = "opengl",
               channel=None, **options) -> np.ndarray:
    """A tangent-space normal map of the noise's relief: (H, W, 3) float32 in [0, 1].

    The height is the luminance (the channel mean) or ``channel``, standardised by its
    model standard deviation and scaled by ``strength``: ``strength`` is the height, in
    pixels, of one standard deviation. The normal is (−∂h/∂column, ±∂h/∂row, 1)
    normalised, stored as (n + 1) / 2; ``convention`` "opengl" (as glTF and Blender read
    normal maps: green points up the image) or "directx" (green points down: the y
    component negated). Its derivatives are :func:`gradient`'s, exact.

    Parameters
    ----------
    model : Texton or TilingModel
    shape : (H, W)
    strength : float
        > 0; about 1–4 for visible relief.
    convention : {"opengl", "directx"}
    channel : None or int
        None: the luminance; an integer: that channel.
    **options
        :func:`synthesize`'s placement and noise options (``seed``, ``scale``, ``rotation``,
        ``offset``, ``period``, ``mni``, ``device``, ``pixel_offset``, ...), ``filter`` "none" only.

    Returns
    -------
    float32 array (H, W, 3)

    Raises
    ------
    TextonError
        For a ``strength`` that is not a finite number > 0, an unknown ``convention``, a
        ``channel`` that is not a channel of the model, a texton of order 0 (piecewise
        constant: flat normals), and the errors of :func:`gradient`.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, normal_map
    >>> t = Texton(np.random.default_rng(0).normal(0, 0.1, (8, 8, 1)), mean=[0.5], order=3)
    >>> n = normal_map(t, (32, 32), strength=2.0, seed=1, device="cpu")
    >>> n.shape, bool(n.min() >= 0.0 and n.max() <= 1.0)
    ((32, 32, 3), True)
    """
    strength = check_positive(strength, "strength")
    if convention not in CONVENTIONS:
        raise TextonError(f"convention must be one of {', '.join(CONVENTIONS)}, got {convention!r}",
                          param="convention")
    if isinstance(model, Texton) and model.order == 0:
        raise TextonError("a texton of order 0 is piecewise constant: its gradient is 0 almost everywhere and its "
                          "normals flat; analyse with order 1 or 3 for relief", param="model")
    if not isinstance(model, (Texton, TilingModel)):
        raise TextonError(f"model must be a Texton or a TilingModel, got {type(model).__name__}", param="model")
    wts = _height_weights(model, channel)
    grad = gradient(model, shape=shape, **options)  # (H, W, C, 2)
    dh = np.einsum("hwck,c->hwk", grad.astype(np.float64), wts) * (strength / _height_std(model, wts))
    n = np.stack([-dh[..., 0], CONVENTIONS[convention] * dh[..., 1], np.ones(dh.shape[:2])], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.clip(0.5 * (n + 1.0), 0.0, 1.0).astype(np.float32)


def height_map(model: Texton | TilingModel, shape=(512, 512), *, channel=None, **options) -> np.ndarray:
    """The height the normal maps use, for displacement: (H, W, 1) float32 in [0, 1].

    The luminance (the channel mean) or ``channel`` of :func:`synthesize`'s raster,
    standardised by its model mean and standard deviation and mapped ±3 σ to [0, 1]
    (0.5 the mean; beyond ±3 σ clipped). ``options`` are :func:`synthesize`'s.
    """
    if not isinstance(model, (Texton, TilingModel)):
        raise TextonError(f"model must be a Texton or a TilingModel, got {type(model).__name__}", param="model")
    wts = _height_weights(model, channel)
    values = np.asarray(synthesize(model, shape, **options), np.float64)
    z = (values @ wts - float(np.asarray(model.mean, np.float64) @ wts)) / _height_std(model, wts)
    return np.clip(0.5 + z / 6.0, 0.0, 1.0).astype(np.float32)[..., None]
