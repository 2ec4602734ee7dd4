"""Names imported on first use (PEP 562): the one mechanism behind the package's and each room's face.

A face lists its public names with the module that holds each (``_LAZY``);
:func:`lazy_names` makes the module-level ``__getattr__`` and ``__dir__`` that import
a name's module only when the name is first reached, so that importing a room (or
``warp_texton`` itself, for ``--help``) starts no Warp and loads no SciPy.
"""

from __future__ import annotations

import importlib
import sys
import warnings
from collections.abc import Callable, Mapping


def lazy_names(package: str, names: Mapping[str, str],
               moved: str | None = None) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """(``__getattr__``, ``__dir__``) for ``package``, whose ``names`` map each name to
    the module (relative to ``package``) that defines it.

    ``moved``: the module (relative to ``package``) that 0.2's module at this path became
    (``warp_texton.noise`` was the engine, ``warp_texton.MOVED_MODULES``): its public names that
    are not on the face are still reached through it, with a DeprecationWarning naming where
    they live now (and listed by neither ``__dir__`` nor ``__all__``).

    >>> getattr_, dir_ = lazy_names("warp_texton.core", {"TextonError": "errors"})
    >>> getattr_("TextonError").__name__
    'TextonError'
    >>> getattr_("nothing")
    Traceback (most recent call last):
    ...
    AttributeError: module 'warp_texton.core' has no attribute 'nothing'
    """

    def __getattr__(name: str):
        module = names.get(name)
        if module is None and moved is not None and not name.startswith("_"):
            old = importlib.import_module(f".{moved}", package)
            if hasattr(old, name):
                warnings.warn(f"{package}.{name} moved to {old.__name__}.{name}; the old path goes in the next "
                              "release", DeprecationWarning, stacklevel=2)
                return getattr(old, name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{module}", package), name)
        vars(sys.modules[package])[name] = value  # once: later lookups do not come here
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return __getattr__, __dir__


def moved_names(package: str, names: Mapping[str, str]) -> Callable[[str], object]:
    """A ``__getattr__`` for ``package``'s names that moved into its modules (``names``: each name's
    module, relative to ``package``): each still resolves, for one release, with a DeprecationWarning
    that names its new path (the names of a module that became a package of the same path)."""

    def __getattr__(name: str):
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        new = f"{package}.{module}"
        warnings.warn(f"{package}.{name} moved to {new}.{name}; the old path goes in the next release",
                      DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module(new), name)

    return __getattr__
