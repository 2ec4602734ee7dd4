"""Texton noise for other runtimes: shader exports that draw the same impacts as the kernels.

:func:`export_shader` writes a folder with the noise (or a tiling model) as shader
code for a language (``"glsl"``: WebGL2 and desktop OpenGL; ``"osl"``: Open Shading
Language, for Cycles, Arnold, RenderMan, V-Ray) plus the model as textures;
:func:`write_shader_preview` writes one self-contained HTML page that draws a
window with WebGL2. The languages are the registry's
(:mod:`warp_texton.runtimes.languages`): each language's port makes the files of
either model kind, whose constants come from the same host code as the Warp
kernels' parameters (and a tiling model's vertex draw from ``kernels/tiling_draw.py``).
"""

from __future__ import annotations

import json
from pathlib import Path

from ..files.folders import atomic_files, check_replaceable
from ..surface.frames import UP
from ..files.images import atomic_path, check_output_name
from ..noise.noise_options import CELL_FACTOR, NoiseOptions
from ..model.texton import Texton
from ..model.tiling import TilingModel
from .languages import LANGUAGES, WEBGL, language

_PORTS = [lang.port() for lang in LANGUAGES.values()]
#: The file every export holds, whose "warp_texton" key marks a folder --overwrite may replace.
META_FILES = tuple(port.META_FILE for port in _PORTS)
#: Every file an export of any language may write: what ``overwrite`` replaces or, when
#: this export does not write it, removes. Other files in the folder are the user's and stay.
EXPORT_FILES = frozenset().union(*(port.FILES for port in _PORTS))


def _is_export(path: Path) -> bool:
    """Whether ``path`` holds a marker of an export: a JSON object with a "warp_texton" key.
    A marker that cannot be read or parsed, or is anything else, is not one."""
    for name in META_FILES:
        meta = path / name
        if meta.is_file() and meta.stat().st_size < (1 << 20):
            try:
                marker = json.loads(meta.read_text(encoding="utf-8"))
            except (OSError, ValueError, RecursionError):  # unreadable, not UTF-8, not JSON, nested too deep
                return False
            return isinstance(marker, dict) and "warp_texton" in marker
    return False


def export_shader(texton: Texton | TilingModel, lang: str, out_dir, *, mni: float = 30.0, seed: int = 0, period=None,
                  poisson: str = "exact", cell_factor: float = CELL_FACTOR, filter=None, texel_size=None,
                  up=UP, side=None, overwrite: bool = False, noise: NoiseOptions | None = None) -> Path:
    """Write texton noise as shader code for ``lang`` into the folder ``out_dir``.

    The shader evaluates the noise where it is used, with no stored image: the
    same impacts as :func:`~warp_texton.evaluate` (plane),
    :func:`~warp_texton.synthesize` (rasters) and
    :func:`~warp_texton.surface_noise` (surfaces), because the cell hash, the
    random stream and the Poisson sampler are reproduced in 32-bit integer
    arithmetic and the constants are the kernels' own values. Float steps may
    differ by rounding (docs/renderers.md gives the measured agreement).

    Parameters
    ----------
    texton : Texton or TilingModel
        A tiling model (``analyze(..., method="tiling")``) exports its own files:
        ``tiling_noise.glsl`` with ``tiling_example.f32`` (GLSL) or
        ``tiling_plane.osl`` (OSL), the unfiltered plane tiling with ``seed``;
        the texton-noise options, ``filter`` (other than "none"), ``up`` and
        ``side`` are refused for it (docs/tiling.md, "Runtimes").
    lang : {"glsl", "osl"}
        ``"glsl"``: a library valid as GLSL ES 3.00 (WebGL2) and, with its
        version line changed, GLSL 3.30+, with ``texton_noise(x)``, a
        filtered variant taking the footprint, and ``texton_surface_noise(y,
        n)``; the files are listed in Notes. ``"osl"``: Open Shading
        Language shaders (Cycles, Arnold, RenderMan, V-Ray) with a colour
        output: surface noise on ``P`` and ``N`` (no UVs) and plane noise on
        object coordinates or UVs, the texton embedded in the source. Both
        carry the exact gradient of the plane noise (GLSL: ``texton_noise_grad``,
        ``tiling_noise_grad``; OSL: the plane shaders' ``GradientX``,
        ``GradientY``, ``Height``, ``NormalMap`` and ``BumpNormal`` outputs;
        docs/relief.md, "Shaders").
    out_dir : str or Path
        The folder to create; its parent must exist.
    mni, seed, period, poisson, cell_factor
        The noise, as in :func:`~warp_texton.synthesize`. The surface variant
        uses the same ``mni`` (:func:`~warp_texton.surface_noise` defaults
        to 60).
    noise : NoiseOptions, optional
        Those five as one value (:class:`~warp_texton.NoiseOptions`), in
        place of the keywords, which must then keep their defaults.
    filter : str or FilterOptions, optional
        GLSL only: the filter of the filtered variant, "none", "mip" or
        "anisotropic" (the default) with their settings
        (:class:`~warp_texton.FilterOptions`); "supersample" is not offered.
        The OSL shaders have no filtered variant (a renderer antialiases by
        its own samples).
    texel_size : float, optional
        OSL only: the default of the shaders' ``texel_size`` parameter,
        shading-space units per texel (default 0.01). GLSL's functions take
        positions in texels.
    up, side
        The surface frame rule's directions
        (:func:`~warp_texton.tangent_frames`), as in
        :func:`~warp_texton.surface_noise`.
    overwrite : bool
        Write into ``out_dir`` if it is a folder an earlier export wrote (its
        ``texton_noise.json`` or ``texton_noise_osl.json`` is a JSON object
        with a ``"warp_texton"`` key): the export's files are replaced (those
        of the earlier export that this one does not write are removed) and
        any other file there is kept. Any other existing path is refused.

    Returns
    -------
    Path
        ``out_dir``, complete: the files are written into a temporary folder
        beside it, which is renamed into place when all are written (into an
        existing export, each file is renamed over its namesake).

    Raises
    ------
    TextonError
        For a ``lang`` other than "glsl" or "osl" (the registry's languages,
        :data:`~warp_texton.runtimes.languages.LANGUAGES`); a texton too large for the target (GLSL: a
        texture side over 2048 texels, the size WebGL2 guarantees); an order
        or a filter the target does not offer; an ``out_dir`` that exists
        without ``overwrite``, or that no export wrote; a missing parent
        folder; and the noise errors of :func:`~warp_texton.synthesize`.

    Notes
    -----
    A GLSL export holds ``texton_noise.glsl`` (the library),
    ``texton_noise.js`` (builds programs and uploads the textures in
    WebGL2), ``texton_coeffs.f32`` and ``texton_pyramid.f32`` (RGBA32F
    textures, raw little-endian float32, top row first),
    ``texton_noise.json`` (their sizes and the settings) and
    ``preview.html`` (a 512 × 512 window at scale 1). An OSL export holds
    ``texton_surface.osl``, ``texton_plane.osl`` and
    ``texton_noise_osl.json`` (the settings).

    A texton with a histogram transform (``analyze(...,
    histogram="preserve")``) is exported with it, so the shaders return the
    example's colours as the package's outputs do: GLSL adds
    ``texton_colours.f32`` (the inverse-CDF tables, one row per variance
    share) and ``texton_shares.f32`` (the footprint shares of the filtered
    variant), and keeps the Gaussian values as ``texton_gaussian_noise`` and
    its variants; OSL embeds the unfiltered table in both shaders
    (docs/renderers.md).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from warp_texton import analyze, read_image, export_shader
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=32, seed=0)
    >>> out = export_shader(texton, "glsl", pathlib.Path(tempfile.mkdtemp()) / "wood", mni=30, seed=1)
    >>> sorted(p.name for p in out.iterdir())  # doctest: +NORMALIZE_WHITESPACE
    ['preview.html', 'texton_coeffs.f32', 'texton_noise.glsl', 'texton_noise.js', 'texton_noise.json',
     'texton_pyramid.f32']
    """
    port = language(lang).port()
    path = check_output_name(out_dir, "out_dir")
    check_replaceable(path, overwrite, _is_export, "a shader export")  # before any work
    noise = NoiseOptions.given(noise, mni=mni, seed=seed, period=period, poisson=poisson, cell_factor=cell_factor)
    files = port.files(texton, noise=noise, filter=filter, texel_size=texel_size, up=up, side=side)
    replaceable = lambda p: check_replaceable(p, overwrite, _is_export, "a shader export")  # noqa: E731
    with atomic_files(path, replaceable, EXPORT_FILES) as tmp:
        for name, content in files.items():
            (tmp / name).write_bytes(content)
    return path


def write_shader_preview(texton: Texton | TilingModel, path, shape=(512, 512), *, mni: float = 30.0, seed: int = 0,
                         scale: float = 1.0, rotation: float = 0.0, offset=(0.0, 0.0), period=None,
                         poisson: str = "exact", cell_factor: float = CELL_FACTOR,
                         noise: NoiseOptions | None = None) -> Path:
    """Write one self-contained HTML page that draws a window of the noise with WebGL2.

    The page (no network: the GLSL, its JavaScript and the texton are inlined)
    draws on a canvas with id ``noise`` the window that
    ``synthesize(texton, shape, ...)`` gives with the same arguments, and
    offers ``window.textonNoise.readFloat()`` (the float32 values, RGBA per
    pixel, top row first) and ``readImpacts()`` (per pixel: the impacts in
    the texton's support and the sum of their offsets).

    Parameters
    ----------
    texton : Texton or TilingModel
        A tiling model's page draws ``synthesize(model, shape, seed=seed, scale=...,
        rotation=..., offset=...)``; its other noise options are refused.
    path : str or Path
        The HTML file, written atomically.
    shape : (height, width)
        At most 2048 pixels a side.
    mni, seed, scale, rotation, offset, period, poisson, cell_factor, noise
        As in :func:`~warp_texton.synthesize`.

    Returns
    -------
    Path

    Raises
    ------
    TextonError
        For a side over 2048 pixels, a texton too large for WebGL2, and the
        errors of :func:`~warp_texton.synthesize` for these arguments.
    """
    noise = NoiseOptions.given(noise, mni=mni, seed=seed, period=period, poisson=poisson, cell_factor=cell_factor)
    html = preview_page(texton, shape, scale=scale, rotation=rotation, offset=offset, noise=noise)
    with atomic_path(path) as tmp:
        Path(tmp).write_text(html, encoding="utf-8")
    return Path(path)


def preview_page(texton: Texton | TilingModel, shape, *, scale: float = 1.0, rotation: float = 0.0,
                 offset=(0.0, 0.0), noise: NoiseOptions | None = None) -> str:
    """The HTML of :func:`write_shader_preview` (``noise`` default: ``NoiseOptions()``), by the
    registry's WebGL2 language (:func:`warp_texton.runtimes.glsl.preview`): a texton's page or a
    tiling model's (of ``noise`` only the seed applies, the other options are refused)."""
    return language(WEBGL).port().preview(texton, shape, scale=scale, rotation=rotation, offset=offset, noise=noise)
