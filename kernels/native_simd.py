"""The one test of which form a native C++ snippet compiles to: its vector form or its plain one.

The native loops (kernels/noise_raster_native.py, kernels/noise_tiling_native.py,
kernels/surface_native.py) are each written twice: in Clang's vector extensions, compiled where
Warp's CPU compiler (its bundled Clang, for the host CPU) targets 256-bit (AVX2, AVX-512) or
128-bit (NEON) SIMD, and as plain C++ for other CPUs and for CUDA (NVRTC is not Clang, and Clang's
CUDA mode is not the host). :data:`VECTOR` is the preprocessor test that picks the form, opened by
every snippet and closed by its ``#endif``; :func:`vector_form` says which form a build holds.

Written once for every channel count, declared once per channel count: a snippet's C++ is one template
(:func:`for_channels` keeps the lines of one or three channels), but Warp cannot make a
``wp.func_native`` (nor a ``wp.struct``) generic over its arrays' element type, so each channel count
has its own declaration, overloads of one name that Warp picks by the arguments' types
(``surface_native.cluster_sums``, ``noise_tiling_native.tiling_run_native``); the device API's structs
have their ``…1`` twins (``PlaneNoise1``, ``SurfaceNoise1``) for the same reason.

Driven by: ``warp_texton.core.runtime``.
"""

import re

import warp as wp

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: Opens a snippet's vector form: ``VECTOR + "vector code #else plain code #endif"``.
VECTOR = ("#if defined(__clang__) && !defined(__CUDACC__) && !defined(__CUDA_ARCH__) "
          "&& (defined(__AVX2__) || defined(__AVX512F__) || defined(__ARM_NEON))")

#: What :func:`vector_form` returns, as names: the plain form, then the vector form for each instruction set.
VECTOR_FORMS = ("scalar", "neon", "avx2", "avx512")


#: A line of a channel template (:func:`for_channels`) that opens the lines of one channel count, or closes them.
_CHANNEL_MARK = re.compile(r"\s*//@ (3|1|end)\s*")


def for_channels(template: str, channels: int) -> str:
    """The lines of a C++ snippet written once for one and three channels: between ``//@ 3`` and the next
    mark the three-channel form's, between ``//@ 1`` and the next mark the one-channel form's, up to
    ``//@ end``; the other lines are both forms'."""
    keep, lines = None, []
    for line in template.split("\n"):
        mark = _CHANNEL_MARK.fullmatch(line)
        if mark:
            keep = None if mark.group(1) == "end" else int(mark.group(1))
        elif keep is None or keep == channels:
            lines.append(line)
    return "\n".join(lines)


@wp.func_native(VECTOR + """
#if defined(__AVX512F__)
    return 3;
#elif defined(__AVX2__)
    return 2;
#else
    return 1;
#endif
#else
    return 0;
#endif
""")
def vector_form() -> int:
    """Which form of the native loops the calling module's code holds (an index of :data:`VECTOR_FORMS`):
    3 the vector form built for AVX-512, 2 for AVX2, 1 for NEON; 0 the plain form (CUDA, other CPUs)."""
    ...


@wp.kernel
def vector_form_probe(flag: wp.array(dtype=wp.int32)):
    """``flag[0]``: :func:`vector_form` of this build."""
    flag[0] = vector_form()


__all__ = ["VECTOR", "VECTOR_FORMS", "for_channels", "vector_form", "vector_form_probe"]
