"""The ``warp-texton`` command: the parser and ``main`` (``parser``), shared option groups
(``options``) and one module per group of subcommands.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.lazy import lazy_names

if TYPE_CHECKING:
    from .parser import main, build_parser

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "main": "parser",
    "build_parser": "parser",
}

__all__ = ["build_parser", "main"]


#: 0.2's warp_texton.cli was a module, warp_texton.cli.parser now: its other names are reached here
#: with a DeprecationWarning (warp_texton.MOVED_MODULES).
__getattr__, __dir__ = lazy_names(__name__, _LAZY, moved="parser")
