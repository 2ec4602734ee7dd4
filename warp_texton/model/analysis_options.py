"""The options of a texton's analysis, as one frozen value, without Warp.

:class:`AnalysisOptions` holds what a texton is a function of, besides the
example image: ``size``, ``order``, ``iterations``, ``seed``, ``periodic``,
``color_correction``, ``support`` and ``histogram``.
:func:`~warp_texton.analyze` and :func:`~warp_texton.mix_textons` take it as
``options=``; the command line makes one from its analysis options and the
viewer from its controls.

A new analysis setting is a field here (with its check in ``__post_init__``),
read where the analysis uses it; the command line's option group
(``cli_options.add_analysis_options``) and its ``analysis_options(args)`` add
the option.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from ..core.checks import MAX_TEXTON_SIDE, check_bool, check_int, check_seed, options_or_keywords
from .bspline import ORDERS
from ..core.errors import TextonError
from .histogram import check_histogram

#: Bytes per image value (pixel × channel) that the analysis holds at its peak:
#: the periodic component and the kernel in float64, their spectra (complex128
#: and complex64 half-planes), the target and its conjugate, the iterates.
ANALYSIS_BYTES_PER_VALUE = 96

#: The shapes of the support S.
SUPPORTS = ("square", "disk")


def check_support(support) -> str:
    """The name of a support shape."""
    if not isinstance(support, str) or support not in SUPPORTS:
        raise TextonError(f"support must be one of {', '.join(SUPPORTS)}, got {support!r:.60}", param="support")
    return support


@dataclass(frozen=True)
class AnalysisOptions:
    """The settings of an analysis: a texton is a deterministic function of the
    example image and these.

    A frozen dataclass, checked once when made (as
    :class:`~warp_texton.FilterOptions` and :class:`~warp_texton.NoiseOptions`
    are). Why these travel together: each changes the texton computed from an
    image, and together they are all that does; a progress bar does not. They
    are made once by the caller, the command line or the viewer, and passed to
    :func:`~warp_texton.analyze` or :func:`~warp_texton.mix_textons` as
    ``options=``, in place of the keyword arguments, which keep working:
    ``analyze(u, size=32)`` is ``analyze(u, options=AnalysisOptions(size=32))``.
    A keyword set to something other than its default together with
    ``options=`` is refused, so that a setting has one place.

    Parameters
    ----------
    size : int
        Side of the square support, or diameter of the disk support, in
        [2, 4096]; :func:`~warp_texton.analyze` also needs it to fit the image.
    order : {0, 1, 3, 5}
        Interpolation order: 0 the discrete texton of EUSIPCO Algorithm 2, 1
        the bilinear texton of CGF Algorithm 1, 3 and 5 B-spline textons.
    iterations : int
        Number of alternating projections, ≥ 1 (50 suffice, EUSIPCO Fig. 2).
    seed : int
        Seed of the random initial phase, in [0, 2**32).
    periodic : bool
        Analyse the periodic component of the image (CGF §4.2), not the image.
    color_correction : bool
        Apply the colour map that restores the image's lag-0 colour covariance.
    support : {"square", "disk"}
        Shape of the support S.
    histogram : {"gaussian", "preserve"}
        Gaussian values (the papers' model), or the example's colour histogram
        through a transform the texton carries (docs/histogram.md).

    Raises
    ------
    TextonError
        For a ``size`` outside [2, 4096], an ``order`` other than 0, 1, 3, 5,
        ``iterations`` < 1, a ``seed`` outside [0, 2³²), a ``periodic`` or
        ``color_correction`` that is not a bool, an unknown ``support`` or
        ``histogram``. The error's ``param`` names the field.

    Examples
    --------
    >>> from warp_texton import AnalysisOptions, TextonError
    >>> fast = AnalysisOptions(size=32, iterations=20)
    >>> fast.size, fast.order, fast.iterations, fast.support
    (32, 1, 20, 'square')
    >>> fast.replace(order=3) == AnalysisOptions(size=32, iterations=20, order=3)
    True
    >>> try:
    ...     AnalysisOptions(order=2)
    ... except TextonError as exc:
    ...     print(exc, "|", exc.param)
    order must be one of 0, 1, 3, 5, got 2 | order
    """

    size: int = 64
    order: int = 1
    iterations: int = 50
    seed: int = 0
    periodic: bool = True
    color_correction: bool = True
    support: str = "square"
    histogram: str = "gaussian"

    def __post_init__(self):
        # in the order analyze has always checked them, so that its first error stays the same
        object.__setattr__(self, "size", check_int(self.size, "size", minimum=2, maximum=MAX_TEXTON_SIDE))
        object.__setattr__(self, "order", check_int(self.order, "order", choices=ORDERS))
        object.__setattr__(self, "iterations", check_int(self.iterations, "iterations", minimum=1))
        object.__setattr__(self, "seed", check_seed(self.seed))
        object.__setattr__(self, "periodic", check_bool(self.periodic, "periodic"))
        object.__setattr__(self, "color_correction", check_bool(self.color_correction, "color_correction"))
        object.__setattr__(self, "support", check_support(self.support))
        object.__setattr__(self, "histogram", check_histogram(self.histogram))

    def replace(self, **changes) -> "AnalysisOptions":
        """A copy with some fields changed (and checked again)."""
        return AnalysisOptions(**{**{f.name: getattr(self, f.name) for f in fields(self)}, **changes})

    @classmethod
    def given(cls, options, *, defaults: "AnalysisOptions | None" = None, **keywords) -> "AnalysisOptions":
        """The options of a call that takes both ``options=`` and the keywords.

        ``options`` itself when given, provided each keyword still holds its
        default (that of ``defaults``, or of ``AnalysisOptions()``); else
        ``AnalysisOptions`` made of the keywords.

        Raises
        ------
        TextonError
            For an ``options`` that is not an :class:`AnalysisOptions`, a keyword
            set to another value beside it (the error names the keyword), and
            the errors of :class:`AnalysisOptions` for the keywords.
        """
        return options_or_keywords(cls, options, "options", defaults, keywords)
