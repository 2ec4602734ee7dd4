"""Texton noise inside your own Warp kernels: the device API.

Texton noise is procedural: it is evaluated where it is used. This module
hands a user's ``@wp.kernel`` what it needs, in the manner of ``wp.noise``: a
host function packs a texton and its noise settings into a ``@wp.struct``
once, and ``@wp.func`` functions evaluate the noise at a point inside the
kernel.

| host packer | struct | device functions |
| --- | --- | --- |
| :func:`pack_plane` | ``PlaneNoise`` | ``plane_value(noise, x: wp.vec2d) -> wp.vec3`` |
| :func:`pack_plane` (``channels=1``) | ``PlaneNoise1`` | ``plane_value(noise, x: wp.vec2d) -> float`` |
| :func:`pack_filtered` (``channels=1``) | ``FilteredNoise1`` | ``filtered_value(noise, x, J) -> float`` |
| :func:`pack_filtered` | ``FilteredNoise`` | ``filtered_value(noise, x: wp.vec2d, J: wp.mat22) -> wp.vec3`` |
| :func:`pack_surface` | ``SurfaceNoise`` | ``surface_value(noise, x: wp.vec3d, normal: wp.vec3d) -> wp.vec3``, ``surface_frame_value(noise, y: wp.vec3d, n: wp.vec3, u1: wp.vec3) -> wp.vec3`` |
| :func:`pack_surface` (``channels=1``) | ``SurfaceNoise1`` | ``surface_value(noise, x, normal) -> float``, ``surface_frame_value(noise, y, n, u1) -> float`` |
| :func:`pack_tiling` | ``Tiling`` | ``tiling_value(t, x: wp.vec2d) -> wp.vec3`` (a tiling model's blend, docs/tiling.md; its colours: ``colour_value`` of :func:`pack_colours`) |
| :func:`pack_colours` | ``ColourMap`` | ``colour_value(cmap, v: wp.vec3) -> wp.vec3``, ``filtered_colour(fnoise, cmap, x: wp.vec2d, J: wp.mat22) -> wp.vec3``, ``colour_share``, ``filtered_share``, ``footprint_share`` |

The structs and functions are those of the package's own kernels
(``warp_texton.kernels``, re-exported here): :func:`~warp_texton.evaluate`,
the filtered :func:`~warp_texton.synthesize` and
:func:`~warp_texton.surface_noise` launch kernels that call the same
functions, so a user's kernel gives their values bit for bit on the same
device, from the same inputs:

* ``plane_value(noise, x)`` is ``evaluate(texton, [x], ...)``: ``x`` is a
  float64 point in texel units, x to the right, y down. ``evaluate`` applies
  no placement; :func:`~warp_texton.synthesize` places pixel (i, j) at
  ``offset + R(rotation) · ((j + ½) / scale, (i + ½) / scale)``, so a kernel
  that wants a window of ``synthesize`` computes that point itself (its
  raster paths round differently: values agree with ``evaluate`` at those
  points to float32 rounding, not bit for bit).
* ``filtered_value(noise, x, J)`` is the pixel of ``synthesize(...,
  filter=..., jacobian=J)`` whose centre is ``x``: ``J`` (float32) has the
  texel-space steps of one pixel to the right and one pixel down as its
  columns. That holds wherever ``synthesize`` filters the raster (some
  pixel's footprint needs more than one lookup of level 0); a raster none of
  whose pixels needs filtering is the unfiltered raster, and there
  ``filtered_value`` is ``plane_value`` (``evaluate``) bit for bit, which
  the raster matches to float32 rounding (docs/renderers.md gives the bound).
* ``surface_value(noise, x, normal)`` is ``surface_noise(texton, [x],
  [normal], texel_size, ...)`` without tangents: ``x`` in world units,
  ``normal`` of any non-zero length, both float64.
  ``surface_frame_value(noise, y, n, u1)`` takes the point in texels, a unit
  normal and a unit tangent orthogonal to it (``surface_noise`` with
  ``tangents``).

The values are ``wp.vec3``; the first ``texton.channels`` components are the
noise, the others zero. A grey texton packed with ``channels=1``
(``PlaneNoise1``, ``FilteredNoise1``, ``SurfaceNoise1``) gives floats, bit for
bit the first component, reading one float a texel. They are the Gaussian noise: for a texton analysed with
``histogram="preserve"``, whose outputs are mapped to the example's colours,
a kernel maps them with :func:`pack_colours`'s struct (``colour_value``,
``filtered_colour``) as the package does. A struct's arrays live on the device it was packed
for: launch the kernels that take it there. A kernel cannot raise, so the
packers check everything they can (the ``TextonError`` of the functions they
mirror); a point beyond the noise's cell range (±2³⁰ cells, the range
``evaluate`` accepts) gives meaningless values, and a zero normal NaN.

Warp compiles the functions into the module of the kernel that calls them,
so a user's kernel in their own file needs nothing more than an import;
Warp's module hash includes the functions it calls, so a new version of this
package recompiles it. The example ``docs/examples/warp_heightfield.py``
displaces a heightfield this way; docs/renderers.md says what is guaranteed.

References
----------
CGF eq. (1)-(2), §5, §6, §8.

Kernels driven here: ``warp_texton.kernels.noise_colours``, ``warp_texton.kernels.noise_filter``,
``warp_texton.kernels.noise_raster``, ``warp_texton.kernels.noise_tiling``,
``warp_texton.kernels.surface_points``.
"""

from __future__ import annotations

import warp as wp

from ..core.checks import check_mni, check_positive
from ..core.runtime import resolve_device
from ..core.errors import TextonError
from ..noise.filter_options import FilterOptions
from ..noise.colours import make_colour_map
from ..noise.filtering import filter_struct, pyramid_struct
from ..surface.frames import UP
from ..kernels.noise_colours import (ColourMap, colour_share, colour_value, filtered_colour, filtered_share,
                              footprint_share)
from ..kernels.noise_filter import FilteredNoise, FilteredNoise1, filtered_value
from ..kernels.noise_raster import PlaneNoise, PlaneNoise1, plane_value
from ..kernels.noise_tiling import Tiling, tiling_value
from ..kernels.surface_points import SurfaceNoise, SurfaceNoise1, surface_frame_value, surface_value
from ..noise.engine import CELL_FACTOR, noise_params, noise_setup
from ..noise.noise_options import NoiseOptions
from ..surface.points import CELL_FACTOR as SURFACE_CELL_FACTOR
from ..surface.points import surface_options, surface_params, surface_setup
from ..model.noise_tables import at_mni
from ..model.texton import Texton
from ..model.tiling import TilingModel

__all__ = ["pack_plane", "pack_filtered", "pack_surface", "pack_colours", "pack_tiling", "Tiling", "tiling_value",
           "PlaneNoise", "PlaneNoise1", "FilteredNoise",
           "FilteredNoise1",
           "SurfaceNoise", "SurfaceNoise1", "ColourMap", "plane_value", "filtered_value", "surface_value", "surface_frame_value",
           "colour_value", "colour_share", "filtered_colour", "filtered_share", "footprint_share"]


def _check_channels(texton, channels) -> None:
    """1 (a grey texton's one lane) or 3."""
    if channels not in (1, 3) or isinstance(channels, bool):
        raise TextonError(f"channels must be 1 or 3, got {channels!r:.60}", param="channels")
    if channels == 1 and isinstance(texton, Texton) and texton.channels != 1:
        raise TextonError(f"channels=1 packs a grey texton; this texton has {texton.channels} channels "
                          "(use channels=3)", param="channels")


def _with_coeffs(three, one, coeffs, channels: int, device):
    """A device-API struct holding a texton's padded coefficients on ``device``: ``one()`` with one float a
    texel for ``channels=1`` (a grey texton), ``three()`` with a ``wp.vec3`` a texel otherwise. (Warp structs
    cannot be generic over their arrays' element type: each struct has its ``…1`` twin.)"""
    if channels == 1:
        struct = one()
        struct.coeffs = wp.array(coeffs[..., 0].copy(), dtype=wp.float32, device=device)
    else:
        struct = three()
        struct.coeffs = wp.array(coeffs, dtype=wp.vec3, device=device)
    return struct


def _plane_settings(texton, channels, noise: NoiseOptions | None, **options):
    """(setup, NoiseParams) of the plane noise, its keywords (``options``: mni, seed, period, poisson,
    cell_factor) and ``channels`` checked as ``evaluate`` checks them: the packers' one check."""
    noise = NoiseOptions.given(noise, **options)
    _check_channels(texton, channels)
    setup = noise_setup(texton, noise.mni, noise.period, noise.cell_factor)
    return setup, noise_params(texton, setup, noise.seed, noise.poisson)


def pack_plane(
    texton: Texton,
    *,
    mni: float = 30.0,
    seed: int = 0,
    period=None,
    device=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    noise: NoiseOptions | None = None,
    channels: int = 3,
) -> PlaneNoise | PlaneNoise1:
    """The plane noise of ``texton`` packed for ``plane_value`` in a user's kernel.

    Parameters
    ----------
    texton : Texton
    mni, seed, period, poisson, cell_factor
        The noise, as in :func:`~warp_texton.evaluate`: the same values give
        the same noise.
    noise : NoiseOptions, optional
        Those five as one value (:class:`~warp_texton.NoiseOptions`), in
        place of the keywords, which must then keep their defaults.
    device : str, optional
        Where the struct's coefficient array lives and its kernels run: "cpu",
        "cuda", "cuda:N"; default CUDA when available, else the CPU.
    channels : {3, 1}
        3: a ``PlaneNoise`` (vec3 coefficients, ``plane_value`` returns a
        ``wp.vec3``). 1, for a grey texton: a ``PlaneNoise1`` (float
        coefficients, ``plane_value`` returns a float and reads one float a
        texel, a third of the memory traffic), equal to the first component
        of the three-channel form.

    Returns
    -------
    PlaneNoise or PlaneNoise1
        A ``@wp.struct`` to pass to a kernel: ``plane_value(noise, x)`` is
        ``evaluate(texton, [x], ...)[0]`` (padded to three components, or its
        one component) bit for bit on ``device``.

    Raises
    ------
    TextonError
        For the ``texton``, ``mni``, ``seed``, ``period``, ``device``,
        ``poisson`` and ``cell_factor`` errors of :func:`~warp_texton.evaluate`;
        for ``channels`` other than 1 or 3, or 1 with a texton of three channels.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton
    >>> texton = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> noise = pack_plane(texton, mni=30, seed=1, period=(64, 64), device="cpu")
    >>> int(noise.params.cells.seed), noise.coeffs.shape
    (1, (18, 18))
    >>> pack_plane(texton, device="cpu", channels=1).coeffs.dtype.__name__
    'float32'
    """
    setup, params = _plane_settings(texton, channels, noise, mni=mni, seed=seed, period=period, poisson=poisson,
                                    cell_factor=cell_factor)
    device = resolve_device(device)
    struct: PlaneNoise | PlaneNoise1 = _with_coeffs(PlaneNoise, PlaneNoise1, setup.coeffs, channels, device)
    struct.params = params
    return struct


def pack_filtered(
    texton: Texton,
    *,
    mni: float = 30.0,
    seed: int = 0,
    period=None,
    device=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    filter="anisotropic",
    noise: NoiseOptions | None = None,
    channels: int = 3,
) -> FilteredNoise | FilteredNoise1:
    """The noise of ``texton`` and a footprint filter, packed for ``filtered_value`` in a user's kernel.

    Parameters
    ----------
    texton : Texton
    mni, seed, period, device, poisson, cell_factor, noise
        As in :func:`pack_plane`.
    filter : {"mip", "anisotropic"} or FilterOptions
        A filter that looks the texton up in its MIP pyramid at each
        footprint (CGF §5), with its settings (``max_aniso``, ``lod_bias``,
        ``fade_energy``), as :func:`~warp_texton.synthesize` takes it.
    channels : {3, 1}
        As in :func:`pack_plane`: 1, for a grey texton, packs a
        ``FilteredNoise1`` whose ``filtered_value`` returns a float.

    Returns
    -------
    FilteredNoise or FilteredNoise1
        A ``@wp.struct``: ``filtered_value(noise, x, J)`` is the pixel of
        ``synthesize(..., filter=filter, jacobian=J)`` centred on ``x``, bit
        for bit on ``device``, wherever ``synthesize`` filters that raster;
        where no pixel needs filtering (one lookup at level 0), it is
        ``evaluate`` at ``x`` bit for bit, and the unfiltered raster agrees
        to float32 rounding.

    Raises
    ------
    TextonError
        As :func:`pack_plane`, and for a ``filter`` that is not a footprint
        filter: "none" (use :func:`pack_plane`) and "supersample" (an average
        of many evaluations on the host, not one lookup).

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, FilterOptions
    >>> texton = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> noise = pack_filtered(texton, seed=1, filter=FilterOptions("anisotropic", max_aniso=4), device="cpu")
    >>> from warp_texton.noise.filtering import kept_levels
    >>> int(noise.filter.max_aniso), noise.pyramid.levels == kept_levels(texton)
    (4, True)
    """
    options = FilterOptions.of(filter)
    if not options.spec.footprint:
        raise TextonError(f"filter must be a footprint filter, mip or anisotropic, for filtered_value; got "
                          f"{options.kind!r} (use pack_plane and plane_value for the unfiltered noise)",
                          param="filter")
    _, params = _plane_settings(texton, channels, noise, mni=mni, seed=seed, period=period, poisson=poisson,
                                cell_factor=cell_factor)
    device = resolve_device(device)
    struct: FilteredNoise | FilteredNoise1 = FilteredNoise1() if channels == 1 else FilteredNoise()
    struct.params = params
    with wp.ScopedDevice(device):
        struct.pyramid = pyramid_struct(texton, options.fade_energy, channels)
    struct.filter = filter_struct(options)
    return struct


def pack_surface(
    texton: Texton,
    texel_size: float,
    *,
    mni: float = 60.0,
    seed: int = 0,
    device=None,
    up=UP,
    side=None,
    poisson: str = "exact",
    cell_factor: float = SURFACE_CELL_FACTOR,
    noise: NoiseOptions | None = None,
    channels: int = 3,
) -> SurfaceNoise | SurfaceNoise1:
    """The surface noise of ``texton`` (CGF §6) packed for ``surface_value`` in a user's kernel.

    Parameters
    ----------
    texton : Texton
    texel_size : float
        World units per texel, > 0, as in :func:`~warp_texton.surface_noise`.
    mni, seed, up, side, poisson, cell_factor, noise
        As in :func:`~warp_texton.surface_noise`: ``up`` and ``side`` set the
        frame rule ``surface_value`` applies.
    device : str, optional
        As in :func:`pack_plane`.
    channels : {3, 1}
        3: a ``SurfaceNoise`` (vec3 coefficients, the functions return a
        ``wp.vec3``). 1, for a grey texton: a ``SurfaceNoise1`` (float
        coefficients, the functions return a float and read one float a
        texel), equal to the first component of the three-channel form.

    Returns
    -------
    SurfaceNoise or SurfaceNoise1
        A ``@wp.struct``: ``surface_value(noise, x, normal)`` is
        ``surface_noise(texton, [x], [normal], texel_size, ...)[0]`` (padded
        to three components, or its one component) bit for bit on ``device``.

    Raises
    ------
    TextonError
        For the ``texton``, ``texel_size``, ``mni``, ``seed``, ``device``,
        ``up``, ``side``, ``poisson`` and ``cell_factor`` errors of
        :func:`~warp_texton.surface_noise`; for ``channels`` other than 1 or
        3, or 1 with a texton of three channels.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton
    >>> texton = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> noise = pack_surface(texton, 0.01, seed=1, up="y", device="cpu")
    >>> noise.texel_size, [float(v) for v in noise.params.up]
    (0.01, [0.0, 1.0, 0.0])
    >>> pack_surface(texton, 0.01, device="cpu", channels=1).coeffs.dtype.__name__
    'float32'
    """
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}", param="texton")
    _check_channels(texton, channels)
    texel = check_positive(texel_size, "texel_size")
    noise = surface_options(noise, mni=mni, seed=seed, poisson=poisson, cell_factor=cell_factor)
    setup = surface_setup(texton, noise.mni, noise.cell_factor)
    params = surface_params(texton, setup, noise.seed, noise.poisson, up, side)
    device = resolve_device(device)
    struct: SurfaceNoise | SurfaceNoise1 = _with_coeffs(SurfaceNoise, SurfaceNoise1, setup.coeffs, channels, device)
    struct.params = params
    struct.texel_size = texel
    return struct


def pack_colours(texton: Texton | TilingModel, *, mni: float | None = None, device=None) -> ColourMap:
    """The histogram transform of ``texton`` packed for ``colour_value`` and ``filtered_colour``.

    A texton analysed with ``analyze(..., histogram="preserve")`` evaluates
    Gaussian values; the package maps every output through its transform
    (docs/histogram.md). A user's kernel does the same with the struct this
    returns: ``colour_value(cmap, plane_value(noise, x))`` is ``evaluate``'s
    value, ``colour_value(cmap, surface_value(...))`` that of
    ``surface_noise``, and ``filtered_colour(fnoise, cmap, x, J)`` the pixel of
    the filtered ``synthesize``.

    Parameters
    ----------
    texton : Texton or TilingModel
        Any texton: without a transform the functions return the values as
        they are (``cmap.enabled`` is 0), so one kernel serves both kinds.
        A tiling model's tables (``histogram="preserve"``) map its blend:
        ``colour_value(cmap, tiling_value(t, x))`` is ``evaluate``'s value
        (:func:`pack_tiling`). Its struct holds no footprint shares (the
        package filters such a model by supersampling only), so only
        ``colour_value`` and ``colour_share`` apply to it.
    mni : float, optional
        The MNI of the noise the colours map (that of :func:`pack_plane` or
        :func:`pack_surface`): a texton's tables are those of its noise at
        that MNI (docs/histogram.md, "Tables for the MNI in use"). None: the
        MNI the analysis fitted them for (``texton.metadata["histogram_mni"]``,
        30). Tiling models have no MNI and ignore it.
    device : str, optional
        Where the struct's arrays live, as in :func:`pack_plane`.

    Returns
    -------
    ColourMap
        A ``@wp.struct`` holding the colour axes and centre, the noise's
        mean and standard deviation, the inverse-CDF tables and their versions
        prefiltered per variance share (float32, (33, C, 1024)), and the texton's
        table of footprint shares. The device functions:

        * ``colour_value(cmap, v: wp.vec3) -> wp.vec3``: the colour of an
          unfiltered value;
        * ``colour_share(cmap, v, share: float) -> wp.vec3``: the colour of a
          value that kept ``share`` of the noise's variance;
        * ``footprint_share(cmap, J: wp.mat22) -> float``: the share a footprint
          keeps (before a MIP filter's fade);
        * ``filtered_share(fnoise, cmap, J) -> float``: the share of
          ``filtered_value(fnoise, x, J)``, faded as its filter fades;
        * ``filtered_colour(fnoise, cmap, x, J) -> wp.vec3``: both, the
          colour of the filtered pixel.

        The host maps the package's outputs with these functions on the CPU,
        so on the CPU a user's kernel gives the outputs bit for bit; on CUDA
        to float32 rounding (docs/renderers.md).

    Raises
    ------
    TextonError
        For a ``texton`` that is not a Texton or a TilingModel, a bad ``device``,
        or a texton whose share table exceeds the memory budget.

    Examples
    --------
    >>> from warp_texton import analyze, read_image
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=16, histogram="preserve")
    >>> cmap = pack_colours(texton, device="cpu")
    >>> int(cmap.enabled), cmap.tables.shape
    (1, (33, 1, 1024))
    """
    mni = None if mni is None else check_mni(mni)
    if isinstance(texton, TilingModel):
        return make_colour_map(texton, resolve_device(device), False)
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton or a TilingModel, got {type(texton).__name__}", param="texton")
    if mni is not None:
        texton = at_mni(texton, mni)
    return make_colour_map(texton, resolve_device(device), True)


def pack_tiling(model: TilingModel, *, seed: int = 0, device=None) -> Tiling:
    """A tiling model (``analyze(..., method="tiling")``) packed for ``tiling_value`` in a user's kernel.

    Parameters
    ----------
    model : TilingModel
    seed : int
        The seed, as in :func:`~warp_texton.evaluate` and :func:`~warp_texton.synthesize`,
        in [0, 2**32).
    device : str, optional
        Where the struct's arrays (the example, and its guide when the model has a guide
        weight) live and its kernels run, as in :func:`pack_plane`.

    Returns
    -------
    Tiling
        The ``@wp.struct`` of the package's own tiling kernels (``kernels/noise_tiling.py``):
        ``tiling_value(t, x: wp.vec2d) -> wp.vec3`` is ``evaluate(model, [x], seed=seed)[0]``
        (padded to three components for a grey model) bit for bit on ``device``, ``x``
        a float64 point in noise units (texels of the example at scale 1), x to the right,
        y down; ``synthesize`` places pixel (i, j) at ``offset + R(rotation) · ((j + ½) /
        scale, (i + ½) / scale)``, computed in float64, and gives ``tiling_value`` there
        bit for bit too. Points stay within ±2³⁰ texels (what ``evaluate`` accepts).

        A histogram-preserving model (``analyze(..., method="tiling", histogram="preserve")``)
        blends its Gaussianised example: ``tiling_value`` is the blend, and the package's
        outputs are its colours, ``colour_value(pack_colours(model), tiling_value(t, x))``
        (the texton noise's tables and function; a model without tables passes through it).

    Raises
    ------
    TextonError
        For a ``model`` that is not a TilingModel, a bad ``seed`` or ``device``.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton.model.tiling import TilingModel
    >>> model = TilingModel(np.random.default_rng(0).random((64, 64, 3)), 16.0)
    >>> t = pack_tiling(model, seed=3, device="cpu")
    >>> int(t.seed), t.example.shape, t.margin
    (3, (64, 64), 17)
    """
    from ..core.checks import check_seed
    from ..noise.tiling import tiling_struct

    if not isinstance(model, TilingModel):
        raise TextonError(f"model must be a TilingModel (analyze(..., method='tiling')), got {type(model).__name__}",
                          param="model")
    return tiling_struct(model, check_seed(seed), resolve_device(device))
