"""The ``warp-texton`` command: the parser and ``main`` (``parser``), shared option groups
(``options``) and one module per group of subcommands.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .parser import main, build_parser

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "main": "parser",
    "build_parser": "parser",
}

__all__ = ["build_parser", "main"]


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
