"""The one exception type that user-facing errors raise, and the warning about examples."""

from __future__ import annotations

from collections.abc import Mapping


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

    def in_words(self, names: Mapping[str, str]) -> str:
        """The message with a front end's ``names`` for the library's: the argument it
        is about where the message starts with it (``"mni must be..."``), and every
        argument it mentions wherever it stands (``"use a lower mni"``). The command
        line passes its options (``{"mni": "--mni"}``) and the files it was given.

        >>> e = TextonError("mni must be at least 0.001; use a lower mni", param="mni", mentions=("scale",))
        >>> e.in_words({"mni": "--mni"})
        '--mni must be at least 0.001; use a lower mni'
        >>> TextonError("use a lower mni", mentions=("mni",)).in_words({"mni": "--mni"})
        'use a lower --mni'
        """
        return _in_words(str(self), self.param, self.mentions, names)


class OverBudget(TextonError):
    """A :class:`TextonError` refusing a request whose estimated memory or work
    exceeds its budget (:mod:`warp_texton.core.limits`): the request itself is fine,
    only too large (a server answers 413 rather than 400)."""


class ExampleWarning(UserWarning):
    """An example that a texton may learn badly: too large, too smooth, not stationary
    (:mod:`warp_texton.model.example_checks`; docs/photographs.md). The analysis goes on.

    Like :class:`TextonError` it names the argument it is about (``param``) and
    those its advice speaks of (``mentions``), so that the command line prints it
    in its own words (``--size``, the file given).

    >>> w = ExampleWarning("u: not stationary; use a smaller size", param="u", mentions=("size",))
    >>> w.in_words({"u": "photo.jpg", "size": "--size"})
    'photo.jpg: not stationary; use a smaller --size'
    """

    def __init__(self, message: str, param: str | None = None, *, mentions: tuple[str, ...] = ()):
        super().__init__(message)
        self.param = param
        self.mentions = tuple(mentions)

    def in_words(self, names: Mapping[str, str]) -> str:
        """The message with a front end's ``names`` for the library's (:meth:`TextonError.in_words`)."""
        return _in_words(str(self), self.param, self.mentions, names)


def _in_words(message: str, param: str | None, mentions: tuple[str, ...], names: Mapping[str, str]) -> str:
    if param is not None and param in names and message.startswith(param) and _stands_alone(message, 0, len(param)):
        message = names[param] + message[len(param):]
    for name in mentions:
        if name in names:
            message = _replace_name(message, name, names[name])
    return message


def _stands_alone(text: str, start: int, end: int) -> bool:
    """Whether text[start:end] is a whole name, not part of a longer one ("mni" in
    "omni" or "--mni", "offset" in "offset[0]", "size" in "size_x")."""
    before = text[start - 1] if start else " "
    after = text[end] if end < len(text) else " "
    return not (before.isalnum() or before in "_-.'") and not (after.isalnum() or after in "_[")


def _replace_name(text: str, name: str, by: str) -> str:
    parts, start = [], 0
    while (k := text.find(name, start)) >= 0:
        end = k + len(name)
        parts.append(text[start:k] + (by if _stands_alone(text, k, end) else name))
        start = end
    return "".join(parts) + text[start:]
