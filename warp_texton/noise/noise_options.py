"""The options that make a texton noise what it is, as one frozen value, without Warp.

:class:`NoiseOptions` holds the settings on which the noise's value at a
position depends, besides the texton: ``mni``, ``seed``, ``period``,
``poisson`` and ``cell_factor``. The front ends (:func:`~warp_texton.synthesize`,
:func:`~warp_texton.evaluate`, :func:`~warp_texton.surface_noise`, the
Dask arrays, the device API's packers, the shader exports), the command line
and the viewer pass this one value on instead of five keyword arguments; the
public functions keep their keywords (``synthesize(t, mni=40)``) and take the
value as ``noise=``.

This module imports no Warp, so that ``warp-texton --help`` stays quick.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from ..core.checks import check_mni, check_positive, check_seed, options_or_keywords
from ..core.errors import TextonError

#: Default cell side as a fraction of the texton support side (CGF §8).
CELL_FACTOR = 0.6
#: The ``poisson`` values: cell counts exactly Poisson, or the rounded Gaussian of the authors' viewer.
POISSON_MODES = ("exact", "gaussian")


def unpack_pair(value, name: str, what: str):
    """``value`` as two items, or a :class:`~warp_texton.TextonError` naming ``name``
    that says it must be a pair ``what``."""
    if isinstance(value, (str, bytes)):
        raise TextonError(f"{name} must be a pair {what}, got {value!r:.60}", param=name)
    try:
        a, b = value
    except Exception:  # not iterable, wrong length
        raise TextonError(f"{name} must be a pair {what}, got {value!r:.60}", param=name) from None
    return a, b


def check_period(period) -> tuple[float, float]:
    """A pair (Px, Py) of positive numbers."""
    px, py = unpack_pair(period, "period", "(Px, Py) of positive numbers")
    return check_positive(px, "period[0]"), check_positive(py, "period[1]")


def check_poisson(poisson) -> str:
    """One of :data:`POISSON_MODES`."""
    if not isinstance(poisson, str) or poisson not in POISSON_MODES:
        raise TextonError(f"poisson must be one of {', '.join(POISSON_MODES)}, got {poisson!r:.60}", param="poisson")
    return poisson


@dataclass(frozen=True)
class NoiseOptions:
    """The settings that, with the texton, decide the noise: the same texton and
    equal ``NoiseOptions`` give the same value at the same position, on every
    device and through every front end.

    A frozen dataclass, checked once when made (as
    :class:`~warp_texton.FilterOptions` is). Why these five travel together:
    each changes the noise itself (its impacts or its normalisation), and
    nothing else does. A raster's ``shape``, ``scale``, ``rotation``,
    ``offset``, the ``device``, the ``method`` and the ``output`` only choose
    where and how the same noise is sampled; a ``filter`` averages it over
    footprints. So the options of *what* noise are one value, made once by the
    caller, the command line or the viewer, and passed through the front ends,
    the Dask arrays and the shader exports to the kernels' parameters; the
    options of *where* and *how* stay keywords of each call.

    :func:`~warp_texton.synthesize`, :func:`~warp_texton.evaluate`,
    :func:`~warp_texton.surface_noise`,
    :func:`~warp_texton.noise.dask_arrays.synthesize_dask` (and ``write_zarr``),
    :func:`~warp_texton.export_shader` (and ``write_shader_preview``) and the
    packers of :mod:`warp_texton.runtimes.warp_api` take one as ``noise=``, beside their keyword
    arguments, which keep working: ``synthesize(t, mni=40, seed=2)`` is
    ``synthesize(t, noise=NoiseOptions(mni=40, seed=2))``. A keyword set to
    something other than its default together with ``noise=`` is refused, so
    that a setting has one place.

    Parameters
    ----------
    mni : float
        Mean number of impacts per point (CGF §3.3), at least 10⁻³; λ = mni /
        texton.support_area. Higher is more Gaussian and slower; about 30 is
        enough in the plane (the surface functions default to 60).
    seed : int
        In [0, 2**32); the same seed gives the same noise on every device.
    period : (Px, Py), optional
        ``None``: the plane noise never repeats; a pair of positive numbers
        makes it periodic with these periods (texel units). Surface noise has
        no period: its functions refuse one.
    poisson : {"exact", "gaussian"}
        Cell counts exactly Poisson, or the rounded Gaussian approximation of
        the authors' viewer.
    cell_factor : float
        Side of the random cells relative to the side of the texton's support
        (> 0; CGF §8 uses ~0.6). A different value gives a different, equally
        valid, noise.

    Raises
    ------
    TextonError
        For an ``mni`` that is not a finite number of at least 10⁻³, a
        ``seed`` outside [0, 2³²), a ``period`` that is not a pair of finite
        positive numbers, an unknown ``poisson``, a ``cell_factor`` that is not
        a finite number > 0. The error's ``param`` names the field
        (``"period[0]"`` for a period component). Limits that depend on the
        texton (cells per point, impacts per cell, a period's cell count) are
        checked where the texton is known.

    Examples
    --------
    >>> from warp_texton import NoiseOptions, TextonError
    >>> noise = NoiseOptions(mni=40, seed=3, period=(256, 256))
    >>> noise.mni, noise.seed, noise.period, noise.poisson, noise.cell_factor
    (40.0, 3, (256.0, 256.0), 'exact', 0.6)
    >>> NoiseOptions(seed=3) == NoiseOptions(seed=3, mni=30.0)
    True
    >>> noise.replace(seed=4).seed
    4
    >>> try:
    ...     NoiseOptions(poisson="fast")
    ... except TextonError as exc:
    ...     print(exc, "|", exc.param)
    poisson must be one of exact, gaussian, got 'fast' | poisson
    """

    mni: float = 30.0
    seed: int = 0
    period: tuple[float, float] | None = None
    poisson: str = "exact"
    cell_factor: float = CELL_FACTOR

    def __post_init__(self):
        object.__setattr__(self, "mni", check_mni(self.mni))
        object.__setattr__(self, "seed", check_seed(self.seed))
        if self.period is not None:
            object.__setattr__(self, "period", check_period(self.period))
        object.__setattr__(self, "poisson", check_poisson(self.poisson))
        object.__setattr__(self, "cell_factor", check_positive(self.cell_factor, "cell_factor"))

    def replace(self, **changes) -> "NoiseOptions":
        """A copy with some fields changed (and checked again)."""
        return NoiseOptions(**{**{f.name: getattr(self, f.name) for f in fields(self)}, **changes})

    @classmethod
    def given(cls, noise, *, defaults: "NoiseOptions | None" = None, **keywords) -> "NoiseOptions":
        """The options of a call that takes both ``noise=`` and the keywords.

        ``noise`` itself when given, provided each keyword still holds its
        default (that of ``defaults``, the calling function's, or of
        ``NoiseOptions()``); else ``NoiseOptions`` made of the keywords.

        Raises
        ------
        TextonError
            For a ``noise`` that is not a :class:`NoiseOptions`, a keyword set
            to another value beside ``noise`` (the error names the keyword), and
            the errors of :class:`NoiseOptions` for the keywords.
        """
        return options_or_keywords(cls, noise, "noise", defaults, keywords)
