"""The one exception type that user-facing errors raise."""

from __future__ import annotations


class TextonError(ValueError):
    """Bad input to a warp-texton function.

    The message names the offending argument (or file) and says what would be
    accepted. The command line prints it on one line and exits with status 2.

    Parameters
    ----------
    message : str
        The whole message, in the API's words ("mni must be a finite number > 0").
    param : str, optional
        The name of the argument the error is about, as the message spells it
        (``"mni"``, ``"shape[1] (width)"``, ``"u"``); the message starts with it.
        None when no single argument is at fault.
    mentions : tuple of str
        Argument names the message speaks of elsewhere, usually in its advice
        ("use a lower mni"). With ``param``, they let a front end such as the
        command line put its own names (``--mni``, a file name) in their place.

    Examples
    --------
    >>> e = TextonError("mni must be a finite number > 0, got 0.0", param="mni")
    >>> e.param, str(e)
    ('mni', 'mni must be a finite number > 0, got 0.0')
    >>> isinstance(e, ValueError)
    True
    """

    def __init__(self, message: str, param: str | None = None, *, mentions: tuple[str, ...] = ()):
        super().__init__(message)
        self.param = param
        self.mentions = tuple(mentions)


class OverBudget(TextonError):
    """A :class:`TextonError` refusing a request whose estimated memory or work
    exceeds its budget (:mod:`warp_texton.limits`): the request itself is fine,
    only too large (a server answers 413 rather than 400)."""
