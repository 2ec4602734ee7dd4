"""Device-side code of warp-texton: Warp kernels and functions.

Shipped as ``warp_texton.kernels``. Host code never holds kernel source, and
kernels never read files or parse options (see docs/architecture.md).
"""
