"""Native C++ inner loops of the surface block path (kernels/surface_points.py).

Two loops dominate the block path of surface noise on the CPU: listing the
impacts of a cube that may reach a cluster of points (``scan_cube``), and
summing a cluster's list at each of its points (``cluster_sums``). Warp's
kernel language has no SIMD types, and its CPU code for these loops is
scalar, so they are written here as ``wp.func_native`` snippets, each in two
forms:

* a vector form in Clang's vector extensions (``ext_vector_type``,
  ``__builtin_shufflevector``, ``__builtin_convertvector``, element-wise
  compares that give lane masks), compiled where Warp's CPU compiler (its
  bundled Clang, for the host CPU) targets AVX2, AVX-512 or NEON: LLVM lowers
  a 16-lane vector to one AVX-512 register, two AVX2 or four NEON ones. 16
  impacts are tested at once and the passing ones are kept in order (Clang's
  generic compressing store, or a scalar compaction of the lane mask's bits
  on AMD Zen 4 and 5 and with Clang before 21); a cluster's 16 points are the
  16 lanes of the gather's tests, and each passing (impact, point) pair
  reads its four texels as 4-float vectors (the three channels and one unused
  float) and weighs the three channels at once;
* a plain C++ form, the same loops over lanes one at a time, for other CPUs,
  for CUDA (NVRTC is not Clang and has no vector extensions), and where
  ``simd`` = 0.

Both forms compute every term with the same operations, in the same order and
with the same contractions as the Warp functions they stand for
(``impact_offset3``, ``wp.dot``, ``slab_term``'s order-1 branch): a C++
expression is contracted to FMAs exactly where Warp's generated code is (one
``wp.dot`` is one expression; every other operation is its own statement), so
the sums are bit-identical to the per-point walk. The slab term's weighting of
the four texels is written once (``_SLAB_ADD``) and used by both forms, with a
float (one channel), a 4-float vector (three channels, one lookup) or a 16-float
vector (one channel, 16 points' lookups) as its lane type.
``tests/test_surface.py`` checks both forms against the walk, and the recorded
references (``blocks_*`` in tests/test_reference.py) check their values.
"""

import warp as wp

from .native_simd import VECTOR, for_channels, vector_form
from .noise_raster import PAD

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: Vector types (16 lanes; 4-float texel rows); WT_MASKED: whether Clang has its
#: generic masked loads and compressing stores (Clang 21 and later; a compile flag
#: -D WT_MASKED=0 selects the plain tail loads and scalar compaction that older
#: ones use); WT_COMPRESS_STORE: whether to use the compressing store, except on
#: AMD Zen 4 and 5, where LLVM lowers it to the memory form of vcompressps, which
#: is microcoded there (llvm-project issue 133568); a 16-lane compare's lanes as
#: the bits of an integer.
_VECTOR_TYPES = r"""
    typedef float v16f __attribute__((ext_vector_type(16)));
    typedef int v16i __attribute__((ext_vector_type(16)));
    typedef double v16d __attribute__((ext_vector_type(16)));
    typedef bool v16b __attribute__((ext_vector_type(16)));
    typedef float v4f __attribute__((ext_vector_type(4)));
#ifndef WT_MASKED
#if __has_builtin(__builtin_masked_load) && __has_builtin(__builtin_masked_compress_store)
#define WT_MASKED 1
#else
#define WT_MASKED 0
#endif
#endif
#ifndef WT_COMPRESS_STORE
#if WT_MASKED && !defined(__znver4__) && !defined(__znver5__)
#define WT_COMPRESS_STORE 1
#else
#define WT_COMPRESS_STORE 0
#endif
#endif
    const auto lane_bits = [](v16i m) -> unsigned {
        return (unsigned)__builtin_bit_cast(unsigned short, __builtin_convertvector(m, v16b));
    };
"""

#: slab_term's order-1 term (kernels/surface_points.py) for one lookup: the texel rows
#: c00, c01 (j, j + 1 of row i) and c10, c11 (row i + 1) weighed by the bilinear
#: weights and the slab weight w, added to acc. One channel with float lanes, the
#: three at once with 4-float vectors: the same operations in the same order, each
#: its own statement (no contraction), as Warp's code for slab_term. Warp kernels
#: keep their own copy (slab_term is a @wp.func): Warp code can call C++ only as a
#: whole func_native function, and the walk written in Warp is the independent
#: implementation that tests/test_surface.py checks these loops against.
_SLAB_ADD = r"""
    const auto slab_add = [](auto acc, auto c00, auto c01, auto c10, auto c11, auto mtx, auto tx, auto mty,
                             auto ty, auto w) {
        const auto a = c00 * mtx;
        const auto b = c01 * tx;
        const auto top = a + b;
        const auto c = c10 * mtx;
        const auto d = c11 * tx;
        const auto bottom = c + d;
        const auto e = top * mty;
        const auto f = bottom * ty;
        const auto g = e + f;
        const auto h = g * w;
        return acc + h;
    };
"""

SCAN_CUBE = VECTOR + _VECTOR_TYPES + r"""
    if (simd != 0) {
        int count = 0;
        const float r0 = rel[0], r1 = rel[1], r2 = rel[2];
        const float n0 = nbar[0], n1 = nbar[1], n2 = nbar[2];
        const float a0 = ubar[0], a1 = ubar[1], a2 = ubar[2];
        const float b0 = vbar[0], b1 = vbar[1], b2 = vbar[2];
        for (int j = j0; j < j1; j += 16) {
            const int left = j1 - j;
            const unsigned valid = left >= 16 ? 0xFFFFu : (1u << left) - 1u;
#if WT_MASKED
            // Clang's generic masked loads (AVX-512's, AVX2's, or plain loads elsewhere)
            const v16b in = __builtin_bit_cast(v16b, (unsigned short)valid);
            const v16f ux_ = __builtin_masked_load(in, ux.data + j);
            const v16f uy_ = __builtin_masked_load(in, uy.data + j);
            const v16f uz_ = __builtin_masked_load(in, uz.data + j);
#else
            v16f ux_ = 0.0f, uy_ = 0.0f, uz_ = 0.0f;
            for (int l = 0; l < 16 && l < left; ++l) {
                ux_[l] = ux.data[j + l];
                uy_[l] = uy.data[j + l];
                uz_[l] = uz.data[j + l];
            }
#endif
            const v16f mx = ux_ * size;
            const v16f my = uy_ * size;
            const v16f mz = uz_ * size;
            const v16f dx = r0 - mx;
            const v16f dy = r1 - my;
            const v16f dz = r2 - mz;
            const v16f t = dx * n0 + dy * n1 + dz * n2;
            const v16f a = dx * a0 + dy * a1 + dz * a2;
            const v16f b = dx * b0 + dy * b1 + dz * b2;
            const v16i keep = (__builtin_elementwise_abs(t) < t_lim) & (a >= a_lo) & (a <= a_hi) & (b >= b_lo)
                              & (b <= b_hi);
            unsigned pass = lane_bits(keep) & valid;
            const int n = __builtin_popcount(pass);
            if (n != 0 && count + n <= room) {
                // the passing lanes, in order
#if WT_COMPRESS_STORE
                const v16b m = __builtin_bit_cast(v16b, (unsigned short)pass);
                __builtin_masked_compress_store(m, ux_, out_x.data + at + count);
                __builtin_masked_compress_store(m, uy_, out_y.data + at + count);
                __builtin_masked_compress_store(m, uz_, out_z.data + at + count);
#else
                // (a scalar compaction of the mask's bits)
                float* ox = out_x.data + at + count;
                float* oy = out_y.data + at + count;
                float* oz = out_z.data + at + count;
                for (int c = 0; pass != 0; ++c) {
                    const int l = __builtin_ctz(pass);
                    pass &= pass - 1u;
                    ox[c] = ux_[l];
                    oy[c] = uy_[l];
                    oz[c] = uz_[l];
                }
#endif
            }
            count += n;
        }
        return count;
    }
#endif
    int count = 0;
    for (int j = j0; j < j1; ++j) {
        const float mx = ux.data[j] * size;
        const float my = uy.data[j] * size;
        const float mz = uz.data[j] * size;
        const float dx = rel[0] - mx;
        const float dy = rel[1] - my;
        const float dz = rel[2] - mz;
        const float t = dx * nbar[0] + dy * nbar[1] + dz * nbar[2];
        if (fabsf(t) < t_lim) {
            const float a = dx * ubar[0] + dy * ubar[1] + dz * ubar[2];
            const float b = dx * vbar[0] + dy * vbar[1] + dz * vbar[2];
            if (a >= a_lo && a <= a_hi && b >= b_lo && b <= b_hi) {
                if (count < room) {
                    out_x.data[at + count] = ux.data[j];
                    out_y.data[at + count] = uy.data[j];
                    out_z.data[at + count] = uz.data[j];
                }
                count += 1;
            }
        }
    }
    return count;
"""


@wp.func_native(SCAN_CUBE)
def scan_cube(ux: wp.array(dtype=float), uy: wp.array(dtype=float), uz: wp.array(dtype=float), j0: int, j1: int,
              rel: wp.vec3, nbar: wp.vec3, ubar: wp.vec3, vbar: wp.vec3, size: float, t_lim: float, a_lo: float,
              a_hi: float, b_lo: float, b_hi: float, out_x: wp.array(dtype=float), out_y: wp.array(dtype=float),
              out_z: wp.array(dtype=float), at: int, room: int, simd: int) -> int:
    """Of the impacts j0 .. j1 − 1 (positions in cell units) of the cube whose corner
    is at y − rel, those with |⟨d, n̄⟩| < t_lim, ⟨d, ū⟩ ∈ [a_lo, a_hi] and
    ⟨d, v̄⟩ ∈ [b_lo, b_hi] (d = rel − u·size, as ``impact_offset3``), in order:
    written at out[at:], as long as they fit in ``room``; returns how many passed."""
    ...


#: Lane l takes point k's frame (n, u1, u2) and the span of its walk (both forms).
_LOAD_LANE = r"""
        const wp::vec3 n = normals.data[k];
        const wp::vec3 a = u1s.data[k];
        const wp::vec3 b = u2s.data[k];
        nx[l] = n[0]; ny[l] = n[1]; nz[l] = n[2];
        ax[l] = a[0]; ay[l] = a[1]; az[l] = a[2];
        bx[l] = b[0]; by[l] = b[1]; bz[l] = b[2];
        const wp::vec3i lo3 = span_lo.data[k];
        const wp::vec3i hi3 = span_hi.data[k];
        xl[l] = lo3[0]; yl[l] = lo3[1]; zl[l] = lo3[2];
        xh[l] = hi3[0]; yh[l] = hi3[1]; zh[l] = hi3[2];"""

#: One cluster's gather, for WT_CH = 3 or 1 channels (``for_channels`` keeps a channel count's lines,
#: kernels/native_simd.py). Points k0 .. k1 − 1 (at most 16) with frames u1s, u2s, normals and cube
#: spans [span_lo, span_hi]; the list: runs r0 .. r0 + runs − 1, run r being cube cubes[run_cube[r]]
#: with impacts u[u0 + run_end[r − 1] .. u0 + run_end[r] − 1]. Writes the raw sums (before
#: normalisation) to out[dest[k]]. Three channels: each passing (impact, point) pair reads its four
#: texels as 4-float vectors and weighs the channels at once. One channel (a grey texton: float
#: coefficients, float sums): the vector form weighs the 16 lanes at once: each passing lane's four
#: texels are copied into 16-float rows (their slots of lanes that do not pass keep old, finite
#: values), the slab term is computed in every lane with slab_add's operations, and only the passing
#: lanes keep it (a select, so the other lanes' sums are untouched): each lane's sum takes the plain
#: loop's terms in its order, bit for bit.
CLUSTER_SUMS_TEMPLATE = r"""
    if (simd != 0) {
        const int np = k1 - k0;
        v16f nx, ny, nz, ax, ay, az, bx, by, bz;
        v16i xl, xh, yl, yh, zl, zh, live;
        v16d px, py, pz;
//@ 3
        v4f acc[16] = {};
//@ 1
        v16f acc = 0.0f;
//@ end
        for (int l = 0; l < 16; ++l) {
            const int k = k0 + (l < np ? l : 0);
            live[l] = l < np ? -1 : 0;
LOAD_LANE
            const wp::vec3d y = points.data[k];
            px[l] = y[0]; py[l] = y[1]; pz[l] = y[2];
        }
        const float* cf = (const float*)coeffs.data;
        const int row = WT_CH * coeffs.shape[1];
        const double cd = (double)size;
//@ 3
        alignas(64) float l_mtx[16], l_tx[16], l_mty[16], l_ty[16], l_w[16];
//@ end
        alignas(64) int l_i00[16];
//@ 1
        alignas(64) float g00[16] = {}, g01[16] = {}, g10[16] = {}, g11[16] = {};
//@ end
        int start = 0;
        for (int r = 0; r < runs; ++r) {
            const int end = run_end.data[r0 + r];
            const wp::vec3i cc = cubes.data[run_cube.data[r0 + r]];
            // the points whose own walk visits this cube (gather_clustered's test)
            const v16i inside = live & (cc[0] >= xl) & (cc[0] <= xh) & (cc[1] >= yl) & (cc[1] <= yh)
                                & (cc[2] >= zl) & (cc[2] <= zh);
            if (lane_bits(inside) != 0) {
                // cube_offset: float64 differences, rounded to float32
                const double mx = (double)cc[0] * cd;
                const double my = (double)cc[1] * cd;
                const double mz = (double)cc[2] * cd;
                const v16f rx = __builtin_convertvector(px - mx, v16f);
                const v16f ry = __builtin_convertvector(py - my, v16f);
                const v16f rz = __builtin_convertvector(pz - mz, v16f);
                for (int e = u0 + start; e < u0 + end; ++e) {
                    const float qx = ux.data[e] * size;
                    const float qy = uy.data[e] * size;
                    const float qz = uz.data[e] * size;
                    const v16f dx = rx - qx;
                    const v16f dy = ry - qy;
                    const v16f dz = rz - qz;
                    const v16f t = dx * nx + dy * ny + dz * nz;
                    const v16f da = dx * ax + dy * ay + dz * az;
                    const v16f db = dx * bx + dy * by + dz * bz;
                    const v16f za = da + cen0;
                    const v16f zb = db + cen1;
                    const v16f at = __builtin_elementwise_abs(t);
                    const v16i ok = inside & (at < half) & (za >= lo0) & (za <= hi0) & (zb >= lo1) & (zb <= hi1);
                    unsigned bits = lane_bits(ok);
                    if (bits == 0)
                        continue;
                    const v16f q = at / half;
                    const v16f w = 1.0f - q;
                    const v16f fx = __builtin_elementwise_floor(za);
                    const v16f fy = __builtin_elementwise_floor(zb);
                    const v16f tx = za - fx;
                    const v16f ty = zb - fy;
//@ 3
                    // lane values, stored once for the pairs below
                    *(v16f*)l_mtx = 1.0f - tx;
                    *(v16f*)l_tx = tx;
                    *(v16f*)l_mty = 1.0f - ty;
                    *(v16f*)l_ty = ty;
                    *(v16f*)l_w = w;
                    *(v16i*)l_i00 = (__builtin_convertvector(fy, v16i) + PADV) * row
                                    + (__builtin_convertvector(fx, v16i) + PADV) * 3;
//@ 1
                    const v16i i00 = (__builtin_convertvector(fy, v16i) + PADV) * row
                                     + (__builtin_convertvector(fx, v16i) + PADV);
#if defined(__AVX512F__)
                    // AVX-512's masked gathers: the passing lanes' four texels (the others read nothing)
                    typedef float gv16f __attribute__((__vector_size__(64)));
                    typedef int gv16i __attribute__((__vector_size__(64)));
                    const gv16i gi = __builtin_bit_cast(gv16i, i00);
                    const gv16f none = {};
                    const unsigned short k = (unsigned short)bits;
                    const v16f c00 = __builtin_bit_cast(v16f, __builtin_ia32_gathersiv16sf(none, cf, gi, k, 4));
                    const v16f c01 = __builtin_bit_cast(v16f, __builtin_ia32_gathersiv16sf(none, cf + 1, gi, k, 4));
                    const v16f c10 = __builtin_bit_cast(v16f, __builtin_ia32_gathersiv16sf(none, cf + row, gi, k, 4));
                    const v16f c11 = __builtin_bit_cast(v16f, __builtin_ia32_gathersiv16sf(none, cf + row + 1, gi, k,
                                                                                          4));
#else
                    *(v16i*)l_i00 = i00;
//@ end
                    while (bits != 0) {
                        const int l = __builtin_ctz(bits);
                        bits &= bits - 1u;
                        // the four texels as 4-float loads: channels 0-2 and one float of the
                        // next texel (the texton's zero margin holds the last one's)
                        const float* p0 = cf + l_i00[l];
//@ 3
                        v4f c00, c01, c10, c11;
                        __builtin_memcpy(&c00, p0, sizeof(v4f));
                        __builtin_memcpy(&c01, p0 + 3, sizeof(v4f));
                        __builtin_memcpy(&c10, p0 + row, sizeof(v4f));
                        __builtin_memcpy(&c11, p0 + row + 3, sizeof(v4f));
                        acc[l] = slab_add(acc[l], c00, c01, c10, c11, l_mtx[l], l_tx[l], l_mty[l], l_ty[l], l_w[l]);
//@ 1
                        g00[l] = p0[0];
                        g01[l] = p0[1];
                        g10[l] = p0[row];
                        g11[l] = p0[row + 1];
//@ end
                    }
//@ 1
                    const v16f c00 = *(const v16f*)g00, c01 = *(const v16f*)g01, c10 = *(const v16f*)g10,
                               c11 = *(const v16f*)g11;
#endif
                    const v16f sum = slab_add(acc, c00, c01, c10, c11, 1.0f - tx, tx, 1.0f - ty, ty, w);
                    // the passing lanes take the new sum, the others keep theirs
                    acc = __builtin_bit_cast(v16f, (__builtin_bit_cast(v16i, sum) & ok)
                                                   | (__builtin_bit_cast(v16i, acc) & ~ok));
//@ end
                }
            }
            start = end;
        }
        for (int l = 0; l < np; ++l)
//@ 3
            out.data[dest.data[k0 + l]] = wp::vec3(acc[l][0], acc[l][1], acc[l][2]);
//@ 1
            out.data[dest.data[k0 + l]] = acc[l];
//@ end
        return;
    }
#endif
    // the same loop over lanes in plain C++ (up to 16 points, impact by impact)
    const int np = k1 - k0;
    float nx[16], ny[16], nz[16], ax[16], ay[16], az[16], bx[16], by[16], bz[16];
//@ 3
    float rx[16], ry[16], rz[16], s0[16], s1[16], s2[16];
//@ 1
    float rx[16], ry[16], rz[16], s0[16];
//@ end
    int xl[16], xh[16], yl[16], yh[16], zl[16], zh[16];
    bool inside[16];
    for (int l = 0; l < np; ++l) {
        const int k = k0 + l;
LOAD_LANE
//@ 3
        s0[l] = 0.0f; s1[l] = 0.0f; s2[l] = 0.0f;
//@ 1
        s0[l] = 0.0f;
//@ end
    }
    const float* cf = (const float*)coeffs.data;
    const int row = WT_CH * coeffs.shape[1];
    const double cd = (double)size;
    int start = 0;
    for (int r = 0; r < runs; ++r) {
        const int end = run_end.data[r0 + r];
        const wp::vec3i cc = cubes.data[run_cube.data[r0 + r]];
        const double mx = (double)cc[0] * cd;
        const double my = (double)cc[1] * cd;
        const double mz = (double)cc[2] * cd;
        bool any = false;
        for (int l = 0; l < np; ++l) {
            inside[l] = cc[0] >= xl[l] && cc[0] <= xh[l] && cc[1] >= yl[l] && cc[1] <= yh[l] && cc[2] >= zl[l]
                        && cc[2] <= zh[l];
            any = any || inside[l];
            const wp::vec3d y = points.data[k0 + l];
            const double ex = y[0] - mx;
            const double ey = y[1] - my;
            const double ez = y[2] - mz;
            rx[l] = (float)ex;
            ry[l] = (float)ey;
            rz[l] = (float)ez;
        }
        if (any) {
            for (int e = u0 + start; e < u0 + end; ++e) {
                const float qx = ux.data[e] * size;
                const float qy = uy.data[e] * size;
                const float qz = uz.data[e] * size;
                for (int l = 0; l < np; ++l) {
                    const float dx = rx[l] - qx;
                    const float dy = ry[l] - qy;
                    const float dz = rz[l] - qz;
                    const float t = dx * nx[l] + dy * ny[l] + dz * nz[l];
                    const float at = fabsf(t);
                    if (!inside[l] || !(at < half))
                        continue;
                    const float da = dx * ax[l] + dy * ay[l] + dz * az[l];
                    const float db = dx * bx[l] + dy * by[l] + dz * bz[l];
                    const float za = da + cen0;
                    const float zb = db + cen1;
                    if (!(za >= lo0 && za <= hi0 && zb >= lo1 && zb <= hi1))
                        continue;
                    const float q = at / half;
                    const float w = 1.0f - q;
                    const float fx = floorf(za);
                    const float fy = floorf(zb);
                    const float tx = za - fx;
                    const float ty = zb - fy;
                    const float mtx = 1.0f - tx;
                    const float mty = 1.0f - ty;
                    const float* p00 = cf + ((int)fy + PADV) * row + ((int)fx + PADV) * WT_CH;
                    const float* p10 = p00 + row;
//@ 3
                    s0[l] = slab_add(s0[l], p00[0], p00[3], p10[0], p10[3], mtx, tx, mty, ty, w);
                    s1[l] = slab_add(s1[l], p00[1], p00[4], p10[1], p10[4], mtx, tx, mty, ty, w);
                    s2[l] = slab_add(s2[l], p00[2], p00[5], p10[2], p10[5], mtx, tx, mty, ty, w);
//@ 1
                    s0[l] = slab_add(s0[l], p00[0], p00[1], p10[0], p10[1], mtx, tx, mty, ty, w);
//@ end
                }
            }
        }
        start = end;
    }
    for (int l = 0; l < np; ++l)
//@ 3
        out.data[dest.data[k0 + l]] = wp::vec3(s0[l], s1[l], s2[l]);
//@ 1
        out.data[dest.data[k0 + l]] = s0[l];
//@ end
"""


def cluster_sums_source(channels: int) -> str:
    """The C++ of ``cluster_sums`` for ``channels`` (3 or 1): the template for that channel count."""
    body = for_channels(CLUSTER_SUMS_TEMPLATE, channels).replace("WT_CH", str(channels))
    return (_SLAB_ADD + VECTOR + _VECTOR_TYPES + body).replace("PADV", str(PAD)).replace("LOAD_LANE", _LOAD_LANE)


CLUSTER_SUMS = cluster_sums_source(3)
CLUSTER_SUMS1 = cluster_sums_source(1)


# cluster_sums for three channels and one: Warp overloads a func_native on its argument types
@wp.func_native(CLUSTER_SUMS)
def cluster_sums(coeffs: wp.array2d(dtype=wp.vec3), points: wp.array(dtype=wp.vec3d),
                 normals: wp.array(dtype=wp.vec3), u1s: wp.array(dtype=wp.vec3), u2s: wp.array(dtype=wp.vec3),
                 span_lo: wp.array(dtype=wp.vec3i), span_hi: wp.array(dtype=wp.vec3i), k0: int, k1: int,
                 cubes: wp.array(dtype=wp.vec3i), run_cube: wp.array(dtype=wp.int32),
                 run_end: wp.array(dtype=wp.int32), r0: int, runs: int, ux: wp.array(dtype=float),
                 uy: wp.array(dtype=float), uz: wp.array(dtype=float), u0: int, size: float, half: float,
                 cen0: float, cen1: float, lo0: float, lo1: float, hi0: float, hi1: float,
                 out: wp.array(dtype=wp.vec3), dest: wp.array(dtype=wp.int64), simd: int):
    """The raw slab sums (order-1 texton) of a cluster's points over its list,
    written to out[dest[k]] for point k (vec3 coefficients and sums)."""
    ...


@wp.func_native(CLUSTER_SUMS1)
def cluster_sums(coeffs: wp.array2d(dtype=float), points: wp.array(dtype=wp.vec3d),  # noqa: F811 (an overload)
                 normals: wp.array(dtype=wp.vec3), u1s: wp.array(dtype=wp.vec3), u2s: wp.array(dtype=wp.vec3),
                 span_lo: wp.array(dtype=wp.vec3i), span_hi: wp.array(dtype=wp.vec3i), k0: int, k1: int,
                 cubes: wp.array(dtype=wp.vec3i), run_cube: wp.array(dtype=wp.int32),
                 run_end: wp.array(dtype=wp.int32), r0: int, runs: int, ux: wp.array(dtype=float),
                 uy: wp.array(dtype=float), uz: wp.array(dtype=float), u0: int, size: float, half: float,
                 cen0: float, cen1: float, lo0: float, lo1: float, hi0: float, hi1: float,
                 out: wp.array(dtype=float), dest: wp.array(dtype=wp.int64), simd: int):
    """``cluster_sums`` for a one-channel texton: float coefficients and sums."""
    ...


#: 0.2's name of the build's form (kernels/native_simd.py).
vector_loops = vector_form
