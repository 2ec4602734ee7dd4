"""Device-side code of warp-texton: Warp kernels and functions.

Shipped as ``warp_texton.kernels``. Host code never holds kernel source, and
kernels never read files or parse options (see docs/architecture.md).
"""


def __getattr__(name: str):
    """0.2's kernel modules as attributes (``warp_texton.kernels.noise2d``: ``warp_texton.MOVED_MODULES``),
    imported, with their DeprecationWarning, the first time they are reached."""
    import importlib

    from .. import MOVED_MODULES

    if f"{__name__}.{name}" in MOVED_MODULES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
