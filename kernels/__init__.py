"""Device-side code of warp-texton: Warp kernels and functions.

Shipped as ``warp_texton.kernels``. Host code never holds kernel source, and
kernels never read files or parse options (see docs/architecture.md).

Generic over channels where Warp allows it: ``@wp.func``s take ``Any`` texel types, and a native
snippet's C++ is written once for one and three channels (``native_simd.for_channels``). A
``wp.struct`` cannot be generic over its arrays' element type, so each struct of three-channel arrays
has a one-channel twin (``TextonLookup1``, ``SlabLookup1``, ``PyramidLookup1``, ``PlaneNoise1``,
``FilteredNoise1``, ``SurfaceNoise1``) and the functions that take them are overloads of one name.
"""


def __getattr__(name: str):
    """0.2's kernel modules as attributes (``warp_texton.kernels.noise2d``: ``warp_texton.MOVED_MODULES``),
    imported, with their DeprecationWarning, the first time they are reached."""
    import importlib

    from .. import MOVED_MODULES

    if f"{__name__}.{name}" in MOVED_MODULES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
