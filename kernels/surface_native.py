"""Native C++ inner loops of the surface block path (kernels/surface.py).

Two loops dominate the block path of surface noise on the CPU: listing the
impacts of a cube that may reach a cluster of points (``scan_cube``), and
summing a cluster's list at each of its points (``cluster_sums``). Warp's
kernel language has no SIMD types, and its CPU code for these loops is
scalar, so they are written here as ``wp.func_native`` snippets:

* with AVX-512 (F and DQ; Warp compiles CPU modules for the host CPU), 16
  impacts are tested at once and the passing ones are kept in order
  (compressed in registers, then stored); a cluster's 16 points are the 16
  lanes of the gather's tests, and each passing (impact, point) pair reads its
  two texton rows with two 8-float loads and combines them with 256-bit
  operations (512-bit shuffles cost twice as much on AMD Zen 4: measured 12 %
  slower);
* elsewhere (other CPUs, CUDA through NVRTC, or ``simd`` = 0) the same loops
  run as plain scalar C++.

Both paths compute every term with the same operations, in the same order and
with the same contractions as the Warp functions they stand for
(``impact_offset3``, ``wp.dot``, ``slab_term``'s order-1 branch): a C++
expression is contracted to FMAs exactly where Warp's generated code is (one
``wp.dot`` is one expression; every other operation is its own statement), so
the sums are bit-identical to the per-point walk. ``tests/test_surface.py``
checks both paths against it.
"""

import warp as wp

from .noise2d import PAD

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: The AVX-512 path is compiled where the CPU module targets it and never for CUDA.
_AVX512 = "#if defined(__AVX512F__) && defined(__AVX512DQ__) && !defined(__CUDACC__)"

_VECTOR_TYPES = r"""
    typedef float v16f __attribute__((vector_size(64)));
    typedef int v16i __attribute__((vector_size(64)));
    typedef double v8d __attribute__((vector_size(64)));
    typedef float v8f __attribute__((vector_size(32)));
"""

SCAN_CUBE = _AVX512 + _VECTOR_TYPES + r"""
    if (simd != 0) {
        int count = 0;
        const float r0 = rel[0], r1 = rel[1], r2 = rel[2];
        const float n0 = nbar[0], n1 = nbar[1], n2 = nbar[2];
        const float a0 = ubar[0], a1 = ubar[1], a2 = ubar[2];
        const float b0 = vbar[0], b1 = vbar[1], b2 = vbar[2];
        for (int j = j0; j < j1; j += 16) {
            const int left = j1 - j;
            const unsigned short valid = left >= 16 ? (unsigned short)0xFFFF : (unsigned short)((1u << left) - 1u);
            const v16f zero = {};
            const v16f ux_ = __builtin_ia32_loadups512_mask(ux.data + j, zero, valid);
            const v16f uy_ = __builtin_ia32_loadups512_mask(uy.data + j, zero, valid);
            const v16f uz_ = __builtin_ia32_loadups512_mask(uz.data + j, zero, valid);
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
            const unsigned short pass = (unsigned short)(__builtin_ia32_cvtd2mask512(keep) & valid);
            const int n = __builtin_popcount((unsigned int)pass);
            if (n != 0 && count + n <= room) {
                // compress in registers, then one masked store each (a compressing store
                // to memory is microcoded and slow on some CPUs)
                const unsigned short head = (unsigned short)((1u << n) - 1u);
                __builtin_ia32_storeups512_mask(out_x.data + at + count,
                                                __builtin_ia32_compresssf512_mask(ux_, zero, pass), head);
                __builtin_ia32_storeups512_mask(out_y.data + at + count,
                                                __builtin_ia32_compresssf512_mask(uy_, zero, pass), head);
                __builtin_ia32_storeups512_mask(out_z.data + at + count,
                                                __builtin_ia32_compresssf512_mask(uz_, zero, pass), head);
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

#: One cluster's gather. Points k0 .. k1 − 1 (at most 16) with frames u1s, u2s,
#: normals and cube spans [span_lo, span_hi]; the list: runs r0 .. r0 + runs − 1,
#: run r being cube cubes[run_cube[r]] with impacts u[u0 + run_end[r − 1] .. u0 +
#: run_end[r] − 1]. Writes the raw sums (before normalisation) to out[dest[k]].
CLUSTER_SUMS = (_AVX512 + _VECTOR_TYPES + r"""
    if (simd != 0) {
        const int np = k1 - k0;
        v16f nx, ny, nz, ax, ay, az, bx, by, bz;
        v16i xl, xh, yl, yh, zl, zh, live;
        v8d pxa, pya, pza, pxb, pyb, pzb;
        v8f acc[16] = {};
        for (int l = 0; l < 16; ++l) {
            const int k = k0 + (l < np ? l : 0);
            live[l] = l < np ? -1 : 0;
LOAD_LANE
            const wp::vec3d y = points.data[k];
            if (l < 8) {
                pxa[l] = y[0]; pya[l] = y[1]; pza[l] = y[2];
            } else {
                pxb[l - 8] = y[0]; pyb[l - 8] = y[1]; pzb[l - 8] = y[2];
            }
        }
        const float* cf = (const float*)coeffs.data;
        const int row = 3 * coeffs.shape[1];
        const double cd = (double)size;
        const v8f zero8 = {};
        alignas(64) float l_mtx[16], l_tx[16], l_mty[16], l_ty[16], l_w[16];
        alignas(64) int l_i00[16];
        int start = 0;
        for (int r = 0; r < runs; ++r) {
            const int end = run_end.data[r0 + r];
            const wp::vec3i cc = cubes.data[run_cube.data[r0 + r]];
            // the points whose own walk visits this cube (gather_clustered's test)
            const v16i inside = live & (cc[0] >= xl) & (cc[0] <= xh) & (cc[1] >= yl) & (cc[1] <= yh)
                                & (cc[2] >= zl) & (cc[2] <= zh);
            if (__builtin_ia32_cvtd2mask512(inside) != 0) {
                // cube_offset: float64 differences, rounded to float32
                const double mx = (double)cc[0] * cd;
                const double my = (double)cc[1] * cd;
                const double mz = (double)cc[2] * cd;
                const v8d exa = pxa - mx;
                const v8d exb = pxb - mx;
                const v8d eya = pya - my;
                const v8d eyb = pyb - my;
                const v8d eza = pza - mz;
                const v8d ezb = pzb - mz;
                const v8f fxa = __builtin_convertvector(exa, v8f);
                const v8f fxb = __builtin_convertvector(exb, v8f);
                const v8f fya = __builtin_convertvector(eya, v8f);
                const v8f fyb = __builtin_convertvector(eyb, v8f);
                const v8f fza = __builtin_convertvector(eza, v8f);
                const v8f fzb = __builtin_convertvector(ezb, v8f);
                const v16f rx = __builtin_shufflevector(fxa, fxb, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
                const v16f ry = __builtin_shufflevector(fya, fyb, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
                const v16f rz = __builtin_shufflevector(fza, fzb, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
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
                    unsigned int bits = (unsigned int)(unsigned short)__builtin_ia32_cvtd2mask512(ok);
                    if (bits == 0)
                        continue;
                    const v16f q = at / half;
                    const v16f w = 1.0f - q;
                    const v16f fx = __builtin_elementwise_floor(za);
                    const v16f fy = __builtin_elementwise_floor(zb);
                    const v16f tx = za - fx;
                    const v16f ty = zb - fy;
                    // lane values, stored once for the pairs below
                    *(v16f*)l_mtx = 1.0f - tx;
                    *(v16f*)l_tx = tx;
                    *(v16f*)l_mty = 1.0f - ty;
                    *(v16f*)l_ty = ty;
                    *(v16f*)l_w = w;
                    *(v16i*)l_i00 = (__builtin_convertvector(fy, v16i) + PADV) * row
                                    + (__builtin_convertvector(fx, v16i) + PADV) * 3;
                    while (bits != 0) {
                        const int l = __builtin_ctz(bits);
                        bits &= bits - 1;
                        // the lookup's two rows: corners (i, j), (i, j + 1) in floats 0-5 of
                        // one 8-float load, (i + 1, j), (i + 1, j + 1) of another (the texton's
                        // zero margin holds the two extra floats); 256-bit operations only
                        // (512-bit shuffles cost twice as much on some CPUs)
                        const float* p0 = cf + l_i00[l];
                        v8f top_row, bottom_row;
                        __builtin_memcpy(&top_row, p0, sizeof(v8f));
                        __builtin_memcpy(&bottom_row, p0 + row, sizeof(v8f));
                        const v8f bm = l_mtx[l] - zero8;
                        const v8f bt = l_tx[l] - zero8;
                        const v8f wx = __builtin_shufflevector(bm, bt, 0, 1, 2, 11, 12, 13, 6, 7);
                        const v8f p = top_row * wx;
                        const v8f q2 = bottom_row * wx;
                        const v8f ps = __builtin_shufflevector(p, p, 3, 4, 5, 6, 7, 0, 1, 2);
                        const v8f qs = __builtin_shufflevector(q2, q2, 3, 4, 5, 6, 7, 0, 1, 2);
                        // top = c(i, j)(1 − tx) + c(i, j + 1) tx in floats 0-2, and bottom
                        const v8f top = p + ps;
                        const v8f bottom = q2 + qs;
                        const v8f e1 = top * l_mty[l];
                        const v8f e2 = bottom * l_ty[l];
                        const v8f g = e1 + e2;
                        const v8f h = g * l_w[l];
                        acc[l] = acc[l] + h;
                    }
                }
            }
            start = end;
        }
        for (int l = 0; l < np; ++l)
            out.data[dest.data[k0 + l]] = wp::vec3(acc[l][0], acc[l][1], acc[l][2]);
        return;
    }
#endif
    // the same loop over lanes in plain C++ (up to 16 points, impact by impact)
    const int np = k1 - k0;
    float nx[16], ny[16], nz[16], ax[16], ay[16], az[16], bx[16], by[16], bz[16];
    float rx[16], ry[16], rz[16], s0[16], s1[16], s2[16];
    int xl[16], xh[16], yl[16], yh[16], zl[16], zh[16];
    bool inside[16];
    for (int l = 0; l < np; ++l) {
        const int k = k0 + l;
LOAD_LANE
        s0[l] = 0.0f; s1[l] = 0.0f; s2[l] = 0.0f;
    }
    const float* cf = (const float*)coeffs.data;
    const int row = 3 * coeffs.shape[1];
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
                    const float* p00 = cf + ((int)fy + PADV) * row + ((int)fx + PADV) * 3;
                    const float* p10 = p00 + row;
#define WT_CHANNEL(ch, s) { \
                    const float a_ = p00[ch] * mtx; const float b_ = p00[3 + ch] * tx; const float top_ = a_ + b_; \
                    const float c_ = p10[ch] * mtx; const float d_ = p10[3 + ch] * tx; const float bot_ = c_ + d_; \
                    const float e_ = top_ * mty; const float f_ = bot_ * ty; const float g_ = e_ + f_; \
                    const float h_ = g_ * w; s[l] = s[l] + h_; }
                    WT_CHANNEL(0, s0)
                    WT_CHANNEL(1, s1)
                    WT_CHANNEL(2, s2)
#undef WT_CHANNEL
                }
            }
        }
        start = end;
    }
    for (int l = 0; l < np; ++l)
        out.data[dest.data[k0 + l]] = wp::vec3(s0[l], s1[l], s2[l]);
""").replace("PADV", str(PAD)).replace("LOAD_LANE", _LOAD_LANE)


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
    written to out[dest[k]] for point k."""
    ...


@wp.func_native(_AVX512 + """
    return 1;
#else
    return 0;
#endif
""")
def avx512_loops() -> int:
    """1 where this module's CPU code holds the AVX-512 loops, else 0."""
    ...
