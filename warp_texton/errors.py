"""The one exception type that user-facing errors raise."""


class TextonError(ValueError):
    """Bad input to a warp-texton function.

    A ``ValueError`` subclass raised for every user mistake (bad argument,
    missing or malformed file, a request over the memory or work budget). The
    message names the offending argument (or file) and says what would be
    accepted; numbers must be numbers (``"30"`` is refused, not converted).
    The command line prints it on one line and exits with status 2.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import analyze, TextonError
    >>> try:
    ...     analyze(np.random.default_rng(0).random((50, 50)), size=64)
    ... except TextonError as exc:
    ...     print(str(exc).split(";")[0])
    u: the image (50x50) is too small for size 64
    """
