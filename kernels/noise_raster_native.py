"""The CPU's native inner loops of texton rasters (kernels/noise_raster.py): the grid splat's rows and the
normalisation of a row, as ``wp.func_native`` C++ snippets.

Warp's kernel language has no SIMD types; these loops are written in C++, the splat in two forms
(kernels/native_simd.py: Clang's vector extensions where the CPU has vector units, plain C++ elsewhere),
each with the operations, and the order, of the per-pixel Warp code they stand for.
"""

import warp as wp

from .native_simd import VECTOR

wp.set_module_options({"enable_backward": False, "optimization_level": 3})


# The footprint rows of a grid splat, each the C·count floats of the row (C channels a
# texel), each dst[t] += gx · left + fx · right with left = gy · top[t] + fy · bot[t]
# the texton's vertical blend at float t and right the same at t + C. Rows of `acc`
# and `coeffs` must be contiguous (the host allocates them so). One source for every
# channel count: a float takes the same operations whatever C is, so a grey texton's
# raster equals the first channel of its three-channel form.
#
# Where Warp's CPU compiler is Clang for a CPU with vector units (AVX2, AVX-512,
# NEON; never CUDA), WIDTH floats at a time in Clang's vector extensions: each chunk's
# blend is computed once and serves as `left` of its own floats and, shifted by C
# lanes (a shuffle with the next chunk's blend), as `right` of the floats C before,
# which the plain loop computes twice: 7 operations a float instead of 10, the same
# values (each lane's operations and their order are the plain loop's; neither form
# contracts to FMAs). The last floats (fewer than WIDTH) take the plain loop. The row
# loop is native too, so an impact's rows are one call; the vector form takes its rows
# in groups of GROUP_ROWS, then two, then one (``_rows_group``): the texton rows that
# neighbouring output rows share are loaded once and the group's rows are independent
# chains of chunks (the splat's CPU time, 1080p at MNI 30: 0.82 of one row at a time
# for grey textons, 0.79 for RGB; docs/benchmarks.md).
_SPLAT_ROWS = """
VECTOR
typedef float vNf __attribute__((ext_vector_type(WIDTH)));
#endif
const int n = LANES * count;
int i = i0;
VECTOR
GROUPS
#endif
for (; i <= i1; ++i) {
    const int a = a0 + i;
    float* __restrict dst = (float*)((char*)acc.data + (size_t)i * acc.strides[0]) + LANES * j;
    const float* __restrict top = (const float*)((const char*)coeffs.data + (size_t)a * coeffs.strides[0]) + LANES * b;
    const float* __restrict bot = (const float*)((const char*)coeffs.data + (size_t)(a + 1) * coeffs.strides[0])
                                  + LANES * b;
    int t = 0;
VECTOR
    if (n >= WIDTH) {
        vNf ct, cb;
        __builtin_memcpy(&ct, top, sizeof(vNf));
        __builtin_memcpy(&cb, bot, sizeof(vNf));
        vNf cur = gy * ct + fy * cb;
        // chunks whose next chunk lies within the row's n + LANES floats
        for (; t + 2 * WIDTH <= n + LANES; t += WIDTH) {
            vNf nt, nb;
            __builtin_memcpy(&nt, top + t + WIDTH, sizeof(vNf));
            __builtin_memcpy(&nb, bot + t + WIDTH, sizeof(vNf));
            const vNf next = gy * nt + fy * nb;
            const vNf right = __builtin_shufflevector(cur, next, SHIFT);
            vNf d;
            __builtin_memcpy(&d, dst + t, sizeof(vNf));
            d += gx * cur + fx * right;
            __builtin_memcpy(dst + t, &d, sizeof(vNf));
            cur = next;
        }
        if (t + WIDTH <= n) {
            // the last whole chunk: the row ends within LANES floats of it, so only
            // the next chunk's first LANES lanes are used
            vNf nt = 0.0f, nb = 0.0f;
            for (int l = 0; l < LANES; ++l) {
                nt[l] = top[t + WIDTH + l];
                nb[l] = bot[t + WIDTH + l];
            }
            const vNf next = gy * nt + fy * nb;
            const vNf right = __builtin_shufflevector(cur, next, SHIFT);
            vNf d;
            __builtin_memcpy(&d, dst + t, sizeof(vNf));
            d += gx * cur + fx * right;
            __builtin_memcpy(dst + t, &d, sizeof(vNf));
            t += WIDTH;
        }
    }
#endif
    for (; t < n; ++t) {
        const float left = gy * top[t] + fy * bot[t];
        const float right = gy * top[t + LANES] + fy * bot[t + LANES];
        dst[t] += gx * left + fx * right;
    }
}
"""
#: Floats a vector of the splat's rows holds: 8, one 256-bit register (AVX2, and
#: AVX-512 where Clang prefers 256-bit vectors), two NEON ones.
WIDTH = 8


def _rows_group(rows: int) -> str:
    """The vector form's loop over groups of ``rows`` output rows (C++), each float with
    the one-row form's operations; texton rows shared by neighbouring output rows are
    loaded once."""
    r, rr = range(rows), range(rows + 1)
    pre = "    "
    lines = ["if (n >= WIDTH) {", f"for (; i + {rows - 1} <= i1; i += {rows}) {{", pre + "const int a = a0 + i;"]
    lines += [pre + f"float* __restrict d{k} = (float*)((char*)acc.data + (size_t)(i + {k}) * acc.strides[0]) + LANES * j;"
              for k in r]
    lines += [pre + f"const float* __restrict c{k} = (const float*)((const char*)coeffs.data + (size_t)(a + {k}) * "
              f"coeffs.strides[0]) + LANES * b;" for k in rr]
    lines += [pre + f"vNf l{k}; __builtin_memcpy(&l{k}, c{k}, sizeof(vNf));" for k in rr]
    lines += [pre + f"vNf cur{k} = gy * l{k} + fy * l{k + 1};" for k in r]
    lines += [pre + "int t = 0;", pre + "for (; t + 2 * WIDTH <= n + LANES; t += WIDTH) {"]
    lines += [pre * 2 + f"vNf m{k}; __builtin_memcpy(&m{k}, c{k} + t + WIDTH, sizeof(vNf));" for k in rr]
    body = []
    body += [pre * 2 + f"const vNf next{k} = gy * m{k} + fy * m{k + 1};" for k in r]
    body += [pre * 2 + f"const vNf right{k} = __builtin_shufflevector(cur{k}, next{k}, SHIFT);" for k in r]
    body += [pre * 2 + f"vNf e{k}; __builtin_memcpy(&e{k}, d{k} + t, sizeof(vNf));" for k in r]
    body += [pre * 2 + f"e{k} += gx * cur{k} + fx * right{k};" for k in r]
    body += [pre * 2 + f"__builtin_memcpy(d{k} + t, &e{k}, sizeof(vNf));" for k in r]
    lines += body + [pre * 2 + f"cur{k} = next{k};" for k in r] + [pre + "}"]
    lines += [pre + "if (t + WIDTH <= n) {"]
    lines += [pre * 2 + f"vNf m{k} = 0.0f;" for k in rr]
    lines += [pre * 2 + "for (int l = 0; l < LANES; ++l) {"] + \
             [pre * 3 + f"m{k}[l] = c{k}[t + WIDTH + l];" for k in rr] + [pre * 2 + "}"]
    lines += body + [pre * 2 + "t += WIDTH;", pre + "}"]
    lines += [pre + "for (; t < n; ++t) {"]
    for k in r:
        lines += [pre * 2 + f"const float left{k} = gy * c{k}[t] + fy * c{k + 1}[t];",
                  pre * 2 + f"const float right{k} = gy * c{k}[t + LANES] + fy * c{k + 1}[t + LANES];",
                  pre * 2 + f"d{k}[t] += gx * left{k} + fx * right{k};"]
    lines += [pre + "}", "}", "}"]
    return "\n".join(lines) + "\n"


#: Output rows a group of the vector form holds (then pairs, then single rows).
GROUP_ROWS = 4


def _splat_row_source(lanes: int) -> str:
    shift = ", ".join(str(lanes + k) for k in range(WIDTH))
    groups = "".join(_rows_group(k) for k in (GROUP_ROWS, 2) if k > 1)
    return _SPLAT_ROWS.replace("GROUPS", groups).replace("VECTOR", VECTOR).replace("SHIFT", shift).replace("LANES", str(lanes)).replace("WIDTH", str(WIDTH))


@wp.func_native(_splat_row_source(3))
def splat_rows3(acc: wp.array2d(dtype=wp.vec3), i0: int, i1: int, j: int, coeffs: wp.array2d(dtype=wp.vec3),
                a0: int, b: int, count: int, gy: float, fy: float, gx: float, fx: float): ...


@wp.func_native(_splat_row_source(1))
def splat_rows1(acc: wp.array2d(dtype=float), i0: int, i1: int, j: int, coeffs: wp.array2d(dtype=float),
                a0: int, b: int, count: int, gy: float, fy: float, gx: float, fx: float): ...


# normalize over a row, as a unit-stride loop the compiler vectorises: per channel
# c, m_c + (a − s_c) / r with s_c = ∫h_c λ and r = √λ computed once (the values
# the per-pixel form computes; a division is exact in every lane).
_NORMALIZE_ROW = """
float* __restrict dst = (float*)((char*)acc.data + (size_t)i * acc.strides[0]);
const int n = acc.shape[1];
const float r = sqrtf(lam);
CHANNELS
"""
_NORMALIZE_ONE = """
const float m = mean[0], s = integral[0] * lam;
for (int t = 0; t < n; ++t)
    dst[t] = m + (dst[t] - s) / r;
"""
_NORMALIZE_THREE = """
const float m0 = mean[0], m1 = mean[1], m2 = mean[2];
const float s0 = integral[0] * lam, s1 = integral[1] * lam, s2 = integral[2] * lam;
for (int t = 0; t < n; ++t) {
    dst[3 * t] = m0 + (dst[3 * t] - s0) / r;
    dst[3 * t + 1] = m1 + (dst[3 * t + 1] - s1) / r;
    dst[3 * t + 2] = m2 + (dst[3 * t + 2] - s2) / r;
}
"""


@wp.func_native(_NORMALIZE_ROW.replace("CHANNELS", _NORMALIZE_ONE))
def normalize_row1(acc: wp.array2d(dtype=float), i: int, mean: wp.vec3, integral: wp.vec3, lam: float): ...


@wp.func_native(_NORMALIZE_ROW.replace("CHANNELS", _NORMALIZE_THREE))
def normalize_row3(acc: wp.array2d(dtype=wp.vec3), i: int, mean: wp.vec3, integral: wp.vec3, lam: float): ...


__all__ = ["WIDTH", "GROUP_ROWS", "splat_rows1", "splat_rows3", "normalize_row1", "normalize_row3"]
