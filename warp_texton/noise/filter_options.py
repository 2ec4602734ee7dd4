"""The filter kinds and the options of a filter (CGF §5), without Warp.

:data:`~warp_texton.noise.filtering.FILTERS` is the one registry of the filter kinds: each
:class:`FilterKind` says what the code that uses a filter needs to know (does
it need each pixel's footprint, does it supersample, what it costs, how it is
described). :mod:`warp_texton.noise.filtering` dispatches on these facts, the ground
plane computes footprints only for the kinds that need them, and the command
line and the viewer list the kinds from here. A new kind is a record here and a
branch in :func:`warp_texton.noise.filtering.filter_pixels`.

This module imports no Warp, so that ``warp-texton --help`` lists the filters
without starting it.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

from ..core.checks import check_int
from ..core.errors import TextonError


@dataclass(frozen=True)
class FilterKind:
    """One filter kind: the facts its callers ask about.

    Attributes
    ----------
    name : str
        The ``filter`` value that selects it.
    description : str
        One line for ``--help`` and the viewer.
    footprint : bool
        It looks the texton up in its MIP pyramid at each pixel's footprint,
        so the caller computes footprints.
    axis_lookups : bool
        It averages up to ``max_aniso`` lookups along the footprint's major axis.
    supersamples : bool
        It averages ``supersample``² jittered evaluations per pixel.
    lod_bias : float or None
        The default level bias of a footprint kind (measured optima,
        docs/benchmarks.md).
    interactive : bool
        Quick enough for the viewer's tiles.
    cost_hint : str
        What to change when its work is over the budget.
    """

    name: str
    description: str
    footprint: bool = False
    axis_lookups: bool = False
    supersamples: bool = False
    lod_bias: float | None = None
    interactive: bool = True
    cost_hint: str = "use a smaller image or a lower mni"


FILTERS: dict[str, FilterKind] = {k.name: k for k in (
    FilterKind("none", "the unfiltered noise (aliases when zoomed out)"),
    FilterKind("mip", "one lookup of the texton's MIP pyramid at each pixel's footprint",
               footprint=True, lod_bias=-1.3),
    FilterKind("anisotropic", "up to max_aniso MIP lookups along each footprint's major axis",
               footprint=True, axis_lookups=True, lod_bias=-0.6,
               cost_hint="use a smaller max_aniso, a larger fade_energy, a smaller image or a lower mni"),
    FilterKind("supersample", "the average of supersample x supersample jittered samples per pixel (the "
               "reference; slow)", supersamples=True, interactive=False,
               cost_hint="use a smaller supersample, a smaller image or a lower mni"),
)}
"""The filter kinds, by name: the accepted ``filter`` values are its keys,
``"none"``, ``"mip"``, ``"anisotropic"`` and ``"supersample"``, and each
value is the :class:`FilterKind` that says what the kind needs.

The level biases (:data:`~warp_texton.noise.filtering.LOD_BIAS`) are added to log2 of a lookup's width to
pick its level. A level-ℓ lookup blurs like a box of width √3 · 2^ℓ (block
mean, then the bilinear tent), so −log2 √3 ≈ −0.79 would match the pixel
box's second moment. The values are the optima measured on the plane
benchmark with two textures (docs/benchmarks.md): "mip" sits lower because its
single lookup takes the major axis as its width and so over-blurs along the
minor one.
"""
LOD_BIAS = {k.name: k.lod_bias for k in FILTERS.values() if k.lod_bias is not None}
"""The default level bias of each footprint kind, ``{"mip": -1.3, "anisotropic": -0.6}``:
added to log2 of a lookup's width to choose its MIP level. These are the optima
measured on the plane benchmark; the second-moment match, −½ log2 3 ≈ −0.79, lies
in between (docs/model.md §13, "Choosing the level"). ``FilterOptions(lod_bias=...)``
overrides it."""
MAX_ANISO = 8
"""The default ``max_aniso``: most lookups along a footprint's major axis
(``"anisotropic"``); past this anisotropy the level rises instead, as GPU
anisotropic filtering does. At most :data:`~warp_texton.noise.filtering.MAX_MAX_ANISO`."""
FADE_ENERGY = 0.1
"""The default ``fade_energy``: the pyramid ends at the first level whose noise
keeps less than this fraction of the texton noise's variance (∫h_ℓ² / ∫h²,
:func:`~warp_texton.noise.filtering.kept_levels`); past that level the filtered noise
fades to its mean. The coarse levels of a textured texton carry little variance
but cost the most (the widest supports, the most lookups). On the plane
benchmark, 0.1 instead of keeping every level costs 0.002 in error for about a
fifth of the time; 0.25 saves more but flattens a band of the far field that
still has visible grain (docs/model.md §13). Smooth textures keep all their
levels."""
SUPERSAMPLE = 20
"""The default ``supersample``: samples per pixel side for ``filter="supersample"``
(400 per pixel, as in CGF Fig. 3). At most :data:`~warp_texton.noise.filtering.MAX_SUPERSAMPLE`."""
MAX_SUPERSAMPLE = 64
"""The largest ``supersample`` (a pixel's work grows with its square)."""
MAX_MAX_ANISO = 64
"""The largest ``max_aniso`` (a pixel's work grows with it)."""
MAX_LOD_BIAS = 64
"""Bound on ``lod_bias`` (in MIP levels): a texton of 4096 texels has 13 levels,
so a larger bias only selects the first or the last one."""


@dataclass(frozen=True)
class FilterOptions:
    """A filter and its settings: how noise is anti-aliased for each pixel's footprint (CGF §5).

    A frozen dataclass, checked once when made. :func:`~warp_texton.synthesize`,
    :func:`~warp_texton.render_plane` and :func:`~warp_texton.noise.ground_plane.plane_pixels`
    take one as ``filter``, where a plain name such as ``"mip"`` means
    ``FilterOptions("mip")``.

    Parameters
    ----------
    kind : {"none", "mip", "anisotropic", "supersample"}
        "mip" looks the texton up in a MIP pyramid at the footprint's major
        length; "anisotropic" also averages up to ``max_aniso`` lookups along
        its major axis; "supersample" averages ``supersample``² jittered
        evaluations over the footprint (the reference). Where every footprint
        needs a single lookup of the unfiltered texton (up to about 2.5 texels
        for "mip", 1.5 for round footprints with "anisotropic"), "mip" and
        "anisotropic" are exactly "none". :data:`~warp_texton.noise.filtering.FILTERS` lists them.
    max_aniso : int in [1, 64]
        Most lookups along a footprint's major axis for "anisotropic"
        (default :data:`~warp_texton.noise.filtering.MAX_ANISO` = 8); past that anisotropy the level rises
        instead. At most :data:`~warp_texton.noise.filtering.MAX_MAX_ANISO`.
    supersample : int in [1, 64]
        Samples per pixel side for "supersample" (default :data:`~warp_texton.noise.filtering.SUPERSAMPLE`
        = 20, i.e. 400 samples per pixel). At most :data:`~warp_texton.noise.filtering.MAX_SUPERSAMPLE`.
    fade_energy : float in [0, 1]
        The MIP pyramid ends at the first level whose noise keeps less than
        this share of the variance, and larger footprints fade to the mean
        (default :data:`~warp_texton.noise.filtering.FADE_ENERGY` = 0.1); 0 keeps every level (slower at a
        distance, slightly more accurate).
    lod_bias : float, optional
        Added to log2 of a lookup's width to choose its MIP level; ``None``
        (the default) takes ``LOD_BIAS[kind]`` (:data:`~warp_texton.noise.filtering.LOD_BIAS`, the optima
        measured on the plane benchmark, docs/benchmarks.md). For measuring
        other choices. In [-64, 64].

    Raises
    ------
    TextonError
        For an unknown ``kind``; a ``max_aniso`` or ``supersample`` that is not
        an integer (``True`` is not an integer here) or is out of range; a
        ``fade_energy`` outside [0, 1] or not a number (a string such as
        ``"0.1"`` is refused); a ``lod_bias`` that is not a finite number in
        [-64, 64]. The error's ``param`` names the field (``"filter"`` for
        ``kind``).

    Notes
    -----
    Averaging the noise over a pixel's footprint is the noise of a filtered
    texton with the same impacts, so "mip" and "anisotropic" look the texton
    up in a MIP pyramid of block means (:func:`~warp_texton.noise.filtering.texton_pyramid`)
    instead of supersampling. :func:`~warp_texton.render_plane` shows them
    where they matter, on an infinite ground plane seen in perspective (CGF
    Fig. 3). The derivations (the pyramid, the level choice, the exact mean,
    the anisotropic lookups and the plane's footprints) are in docs/model.md
    §13; measured speed and error in docs/benchmarks.md.

    References
    ----------
    CGF §5 (filtering the noise by filtering the texton), Fig. 3.

    Examples
    --------
    >>> from warp_texton import FilterOptions, TextonError
    >>> fast = FilterOptions("anisotropic", max_aniso=4)   # cheaper: at most 4 lookups per pixel
    >>> fast.max_aniso, fast.bias
    (4, -0.6)
    >>> ref = FilterOptions("supersample", supersample=8)  # 64 jittered samples per pixel
    >>> FilterOptions.of("mip") == FilterOptions("mip"), FilterOptions.of(ref) is ref
    (True, True)
    >>> FilterOptions("mip").spec.footprint
    True
    >>> try:
    ...     FilterOptions("mip", fade_energy="0.1")
    ... except TextonError as exc:
    ...     print(exc, "|", exc.param)
    fade_energy must be a number in [0, 1], got '0.1' | fade_energy
    """

    kind: str = "none"
    max_aniso: int = MAX_ANISO
    supersample: int = SUPERSAMPLE
    fade_energy: float = FADE_ENERGY
    lod_bias: float | None = None

    def __post_init__(self):
        if not isinstance(self.kind, str) or self.kind not in FILTERS:
            raise TextonError(f"filter must be one of {', '.join(FILTERS)}, got {self.kind!r}", param="filter")
        n = check_int(self.supersample, "supersample", minimum=1)
        a = check_int(self.max_aniso, "max_aniso", minimum=1)
        if n > MAX_SUPERSAMPLE:
            raise TextonError(f"supersample must be at most {MAX_SUPERSAMPLE} (samples per pixel side), got {n}",
                              param="supersample")
        if a > MAX_MAX_ANISO:
            raise TextonError(f"max_aniso must be at most {MAX_MAX_ANISO}, got {a}", param="max_aniso")
        object.__setattr__(self, "supersample", n)
        object.__setattr__(self, "max_aniso", a)
        object.__setattr__(self, "fade_energy", _fraction(self.fade_energy))
        if self.lod_bias is not None:
            if isinstance(self.lod_bias, bool) or not isinstance(self.lod_bias, numbers.Real) \
                    or not -MAX_LOD_BIAS <= self.lod_bias <= MAX_LOD_BIAS:
                raise TextonError(f"lod_bias must be a number in [-{MAX_LOD_BIAS}, {MAX_LOD_BIAS}] (MIP levels), "
                                  f"got {self.lod_bias!r:.60}", param="lod_bias")
            object.__setattr__(self, "lod_bias", float(self.lod_bias))

    @classmethod
    def of(cls, value) -> "FilterOptions":
        """``value`` itself when it is a :class:`FilterOptions`, else ``FilterOptions(value)``:
        the default options of the filter it names.

        Raises
        ------
        TextonError
            As :class:`FilterOptions` does for an unknown name.
        """
        return value if isinstance(value, cls) else cls(value)

    @property
    def spec(self) -> FilterKind:
        """The registry's record of ``kind``."""
        return FILTERS[self.kind]

    @property
    def bias(self) -> float | None:
        """The level bias in use (the footprint kinds: "mip" and "anisotropic"):
        ``lod_bias``, or ``LOD_BIAS[kind]`` when it is ``None``; None for the other kinds."""
        return self.spec.lod_bias if self.lod_bias is None else self.lod_bias


def _fraction(value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TextonError(f"fade_energy must be a number in [0, 1], got {value!r}", param="fade_energy")
    if not 0.0 <= float(value) <= 1.0:
        raise TextonError(f"fade_energy must be in [0, 1] (0 keeps every MIP level), got {value!r}",
                          param="fade_energy")
    return float(value)
