"""The one exception type that user-facing errors raise."""


class TextonError(ValueError):
    """Bad input to a warp-texton function.

    The message names the offending argument (or file) and says what would be
    accepted. The command line prints it on one line and exits with status 2.
    """
