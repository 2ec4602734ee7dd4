"""Native C++ run loop of the tiling raster (kernels/noise_tiling.py's ``tiling_runs``).

A tiling pixel is a few dozen float operations (the triangle in float64, the
barycentric weights, their sharpening, the cutoff and the normalisation, one
to three bilinear lookups) that Warp's kernel language can only write one
pixel at a time. Here a run of pixels along a row is one ``wp.func_native``
snippet, in two forms:

* a vector form in Clang's vector extensions (16 lanes: 16 pixels of the run at
  once; element-wise compares give lane masks, ``?:`` selects), compiled where
  Warp's CPU compiler (its bundled Clang, for the host CPU) targets AVX2,
  AVX-512 or NEON. The patches' vertices are resolved once per distinct vertex
  of a block (pixels of a triangle share them) through a small cache of the
  run's vertices; the lookups are gathers (AVX-512's masked gathers, a loop
  over the lanes elsewhere), only for the lanes whose weight is kept, and only
  the texel itself where every such lane lies on a texel centre (scale 1);
* a plain C++ form, the same steps one pixel at a time, for other CPUs, for
  CUDA (NVRTC is not Clang; the CUDA raster runs the Warp kernel) and where
  ``simd`` = 0.

Both forms compute each value with the operations of ``tiling_runs`` (and so of
``tiling_value``, the specification), in the same order, one rounding each: the
snippets turn off floating-point contraction (Warp's generated code makes every
operation its own statement, so it never contracts them), compute the float64
position, skewed coordinates and patch offsets in float64 and round them to
float32 where the reference does. The vertex draw (the hash, the PCG
uniforms, the centre texel, the rounded vertex position, the periodic
lattice's reduction, the example's addressing and the draw's constants) is
not written here: it is ``kernels/tiling_draw.py``'s definition, rendered as
C++ lambdas (``draw_code("cpp")``) into the snippet. A row coordinate that does not change along the row (no rotation) is
computed once per run: the same value in every lane. ``tests/noise/
test_tiling_raster.py`` checks both forms against ``tiling_value``.
"""

import warp as wp

from .surface_native import _VECTOR
from .tiling_draw import draw_code

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: The run loop for CH channels (CHN is replaced by 1 or 3; MEAN_C by the mean's channel c).
_RUN = _VECTOR + r"""
#define WT_VECTOR_FORM 1
#else
#define WT_VECTOR_FORM 0
#endif
    {
#if defined(__clang__)
#pragma clang fp contract(off)
#endif
    const int CH = CHN;
    const float* ex = (const float*)example.data;
    const int erow = (int)(example.strides[0] / 4);
    const int ecol = (int)(example.strides[1] / 4);
    const int rows = example.shape[0];
    const int cols = example.shape[1];
    float* orow = (float*)((char*)out.data + (size_t)i * (size_t)out.strides[0]);
    const int ocol = (int)(out.strides[1] / 4);
    float mu[CH];
    for (int c = 0; c < CH; ++c)
        mu[c] = MEAN_C;
@TILING_DRAW@
    // x = origin + step_x * J + step_y * I, as tiling_runs: step_y * I is the same for the whole run
    const double I = (double)(first_i + i) + 0.5;
    const double yx = step_y[0] * I;
    const double yy = step_y[1] * I;
    const double s = periodic != 0 ? dx : (double)side;
    // the seed's part of the vertex hash, once per run; the centres' range (noise_tiling.vertex_centre)
    const unsigned h_seed = tl_seed_state((unsigned)seed);
    const int nx = cols - 2 * margin;
    const int ny = rows - 2 * margin;
    int ca[8], cb[8], ccx[8], ccy[8];
    double cpx[8], cpy[8];
    for (int k = 0; k < 8; ++k) {
        ca[k] = -2147483647;
        cb[k] = -2147483647;
        ccx[k] = 0;
        ccy[k] = 0;
        cpx[k] = 0.0;
        cpy[k] = 0.0;
    }
    int nxt = 0;
    // the centre texel and rounded position of vertex (a, b): lattice_vertex, through the cache
    const auto vertex = [&](int a, int b, int& cx, int& cy, double& px, double& py) {
        for (int k = 0; k < 8; ++k) {
            if (ca[k] == a && cb[k] == b) {
                cx = ccx[k];
                cy = ccy[k];
                px = cpx[k];
                py = cpy[k];
                return;
            }
        }
        if (periodic != 0) {
            int va, vb, ka, kb;
            tl_period_vertex(a, b, lcols, lrows, va, vb, ka, kb);
            tl_vertex_centre(h_seed, va, vb, margin, nx, margin, ny, cx, cy);
            tl_period_position(dx, dy, lpx, lpy, va, vb, ka, kb, px, py);
        } else {
            tl_vertex_centre(h_seed, a, b, margin, nx, margin, ny, cx, cy);
            tl_vertex_position(0.0, 0.0, (double)side, a, b, px, py);
        }
        ca[nxt] = a;
        cb[nxt] = b;
        ccx[nxt] = cx;
        ccy[nxt] = cy;
        cpx[nxt] = px;
        cpy[nxt] = py;
        nxt = (nxt + 1) & 7;
    };
    // the skewed row coordinate (lattice_triangle)
    const auto row_of = [&](double x1) -> double {
        if (periodic != 0)
            return x1 / dy;
        return (x1 / s) / TL_SQRT3_2;
    };
    const bool flat = step_x[1] == 0.0;  // no rotation: x's y is the same along the row
#if WT_VECTOR_FORM
    if (simd != 0) {
        typedef float v16f __attribute__((ext_vector_type(16)));
        typedef int v16i __attribute__((ext_vector_type(16)));
        typedef double v16d __attribute__((ext_vector_type(16)));
        typedef bool v16b __attribute__((ext_vector_type(16)));
        const auto lane_bits = [](v16i m) -> unsigned {
            return (unsigned)__builtin_bit_cast(unsigned short, __builtin_convertvector(m, v16b));
        };
        const v16i iota = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
        const v16f zero = 0.0f;
        const v16f onev = 1.0f;
        const v16i izero = 0;
        const v16i cmax = cols - 1;
        const v16i rmax = rows - 1;
        // a lookup of 16 lanes (those in bits; the others 0) at float offsets idx of base
        const auto gather = [](const float* base, v16i idx, unsigned bits) -> v16f {
#if defined(__AVX512F__)
            typedef float gv16f __attribute__((__vector_size__(64)));
            typedef int gv16i __attribute__((__vector_size__(64)));
            const gv16f none = {};
            return __builtin_bit_cast(v16f, __builtin_ia32_gathersiv16sf(none, base, __builtin_bit_cast(gv16i, idx),
                                                                         (unsigned short)bits, 4));
#else
            alignas(64) int li[16];
            alignas(64) float lv[16] = {};
            *(v16i*)li = idx;
            while (bits != 0) {
                const int l = __builtin_ctz(bits);
                bits &= bits - 1u;
                lv[l] = base[li[l]];
            }
            return *(const v16f*)lv;
#endif
        };
        v16d SYrow = 0.0;
        if (flat) {
            const double x1 = (origin[1] + step_x[1] * ((double)(first_j + j0) + 0.5)) + yy;
            SYrow = row_of(x1);
        }
        alignas(64) int la[16], lb[16];
        for (int j = j0; j < j1; j += 16) {
            const int n = j1 - j < 16 ? j1 - j : 16;
            const unsigned valid = n >= 16 ? 0xFFFFu : (1u << n) - 1u;
            const v16d J = __builtin_convertvector((first_j + j) + iota, v16d) + 0.5;
            const v16d X0 = (origin[0] + step_x[0] * J) + yx;
            const v16d X1 = (origin[1] + step_x[1] * J) + yy;
            v16d SY = SYrow;
            if (!flat)
                SY = periodic != 0 ? X1 / dy : (X1 / s) / TL_SQRT3_2;
            const v16d FB = __builtin_elementwise_floor(SY);
            const v16d SX = X0 / s - SY * 0.5;
            const v16d FA = __builtin_elementwise_floor(SX);
            const v16i A = __builtin_convertvector(FA, v16i);
            const v16i B = __builtin_convertvector(FB, v16i);
            const v16f U = __builtin_convertvector(SX - FA, v16f);
            const v16f V = __builtin_convertvector(SY - FB, v16f);
            const v16f UV = U + V;
            const v16i up = UV > 1.0f;
            const v16f W0 = up ? UV - 1.0f : (1.0f - U) - V;
            const v16f W1 = up ? 1.0f - V : U;
            const v16f W2 = up ? 1.0f - U : V;
            // quick_weight: 0 below skip, else squared `squarings` times
            v16f K0 = ((W0 <= 0.0f) | (W0 < skip)) ? zero : W0;
            v16f K1 = ((W1 <= 0.0f) | (W1 < skip)) ? zero : W1;
            v16f K2 = ((W2 <= 0.0f) | (W2 < skip)) ? zero : W2;
            for (int q = 0; q < squarings; ++q) {
                K0 = K0 * K0;
                K1 = K1 * K1;
                K2 = K2 * K2;
            }
            // kept_weights: the cutoff, then 1 for a vertex kept alone, else k / Σ k
            const v16f KM = __builtin_elementwise_max(K0, __builtin_elementwise_max(K1, K2)) * TL_CUTOFF;
            K0 = K0 < KM ? zero : K0;
            K1 = K1 < KM ? zero : K1;
            K2 = K2 < KM ? zero : K2;
            const v16i P0 = K0 > 0.0f;
            const v16i P1 = K1 > 0.0f;
            const v16i P2 = K2 > 0.0f;
            const v16i one = (P0 + P1 + P2) == -1;
            const v16f total = (K0 + K1) + K2;
            K0 = one ? (P0 ? onev : zero) : K0 / total;
            K1 = one ? (P1 ? onev : zero) : K1 / total;
            K2 = one ? (P2 ? onev : zero) : K2 / total;
            v16f acc[CH];
            for (int c = 0; c < CH; ++c)
                acc[c] = mu[c] - mu[c];
            for (int r = 0; r < 3; ++r) {
                const v16i act = r == 0 ? P0 : r == 1 ? P1 : P2;
                unsigned bits = lane_bits(act) & valid;
                if (bits == 0)
                    continue;
                const v16i AR = r == 0 ? A - up : r == 1 ? A + 1 : A;
                const v16i BR = r == 0 ? B - up : r == 1 ? B : B + 1;
                const v16f K = r == 0 ? K0 : r == 1 ? K1 : K2;
                // each distinct vertex of the kept lanes: its patch point c + (x − round(p))
                *(v16i*)la = AR;
                *(v16i*)lb = BR;
                v16f QX = zero, QY = zero;
                unsigned todo = bits;
                while (todo != 0) {
                    const int l = __builtin_ctz(todo);
                    int cx, cy;
                    double px, py;
                    vertex(la[l], lb[l], cx, cy, px, py);
                    const v16i same = (AR == la[l]) & (BR == lb[l]);
                    const v16f qx = (float)cx + __builtin_convertvector(X0 - px, v16f);
                    const v16f qy = (float)cy + __builtin_convertvector(X1 - py, v16f);
                    QX = same ? qx : QX;
                    QY = same ? qy : QY;
                    todo &= ~lane_bits(same);
                }
                // bilinear: the texel itself on a texel centre, else the four texels weighed
                const v16f FX = QX - 0.5f;
                const v16f FY = QY - 0.5f;
                const v16f FXf = __builtin_elementwise_floor(FX);
                const v16f FYf = __builtin_elementwise_floor(FY);
                const v16f TX = FX - FXf;
                const v16f TY = FY - FYf;
                const v16i IX = __builtin_convertvector(FXf, v16i);
                const v16i IY = __builtin_convertvector(FYf, v16i);
                // tl_texel_index of 16 lanes: the example's addressing (clamp to edge)
                const v16i J0 = __builtin_elementwise_min(__builtin_elementwise_max(IX, izero), cmax);
                const v16i I0 = __builtin_elementwise_min(__builtin_elementwise_max(IY, izero), rmax);
                const v16i exact = (TX == 0.0f) & (TY == 0.0f);
                const v16i i00 = I0 * erow + J0 * ecol;
                v16f val[CH];
                for (int c = 0; c < CH; ++c)
                    val[c] = gather(ex + c, i00, bits);
                if ((lane_bits(exact) & bits) != bits) {
                    const v16i J1 = __builtin_elementwise_min(__builtin_elementwise_max(IX + 1, izero), cmax);
                    const v16i I1 = __builtin_elementwise_min(__builtin_elementwise_max(IY + 1, izero), rmax);
                    const v16i i01 = I0 * erow + J1 * ecol;
                    const v16i i10 = I1 * erow + J0 * ecol;
                    const v16i i11 = I1 * erow + J1 * ecol;
                    const v16f MTX = 1.0f - TX;
                    const v16f MTY = 1.0f - TY;
                    for (int c = 0; c < CH; ++c) {
                        const v16f c00 = val[c];
                        const v16f c01 = gather(ex + c, i01, bits);
                        const v16f c10 = gather(ex + c, i10, bits);
                        const v16f c11 = gather(ex + c, i11, bits);
                        const v16f top = c00 * MTX + c01 * TX;
                        const v16f bottom = c10 * MTX + c11 * TX;
                        const v16f mixed = top * MTY + bottom * TY;
                        val[c] = exact ? c00 : mixed;
                    }
                }
                for (int c = 0; c < CH; ++c) {
                    const v16f added = acc[c] + (val[c] - mu[c]) * K;
                    acc[c] = act ? added : acc[c];
                }
            }
            if (vp != 0) {
                const v16f root = __builtin_elementwise_sqrt((K0 * K0 + K1 * K1) + K2 * K2);
                for (int c = 0; c < CH; ++c)
                    acc[c] = acc[c] / root;
            }
            float* o = orow + (size_t)j * (size_t)ocol;
            for (int c = 0; c < CH; ++c) {
                const v16f res = mu[c] + acc[c];
                for (int l = 0; l < n; ++l)
                    o[l * ocol + c] = res[l];
            }
        }
        return;
    }
#endif
    // the plain form: tiling_runs' steps, one pixel at a time
    double sy_row = 0.0;
    if (flat)
        sy_row = row_of((origin[1] + step_x[1] * ((double)(first_j + j0) + 0.5)) + yy);
    for (int j = j0; j < j1; ++j) {
        const double J = (double)(first_j + j) + 0.5;
        const double x0 = (origin[0] + step_x[0] * J) + yx;
        const double x1 = (origin[1] + step_x[1] * J) + yy;
        const double sy = flat ? sy_row : row_of(x1);
        const double fb = floor(sy);
        const double sx = x0 / s - sy * 0.5;
        const double fa = floor(sx);
        const int a = (int)fa;
        const int b = (int)fb;
        const float u = (float)(sx - fa);
        const float v = (float)(sy - fb);
        int a0 = a, b0 = b;
        float w[3] = {(1.0f - u) - v, u, v};
        if (u + v > 1.0f) {
            a0 = a + 1;
            b0 = b + 1;
            w[0] = (u + v) - 1.0f;
            w[1] = 1.0f - v;
            w[2] = 1.0f - u;
        }
        float k[3];
        for (int r = 0; r < 3; ++r) {
            float kr = 0.0f;
            if (!(w[r] <= 0.0f || w[r] < skip)) {
                kr = w[r];
                for (int q = 0; q < squarings; ++q)
                    kr = kr * kr;
            }
            k[r] = kr;
        }
        const float km = (k[0] > (k[1] > k[2] ? k[1] : k[2]) ? k[0] : (k[1] > k[2] ? k[1] : k[2])) * TL_CUTOFF;
        int kept = 0;
        for (int r = 0; r < 3; ++r) {
            if (k[r] < km)
                k[r] = 0.0f;
            kept += k[r] > 0.0f ? 1 : 0;
        }
        if (kept == 1) {
            for (int r = 0; r < 3; ++r)
                k[r] = k[r] > 0.0f ? 1.0f : 0.0f;
        } else {
            const float total = (k[0] + k[1]) + k[2];
            for (int r = 0; r < 3; ++r)
                k[r] = k[r] / total;
        }
        const int va[3] = {a0, a + 1, a};
        const int vb[3] = {b0, b, b + 1};
        float acc[CH];
        for (int c = 0; c < CH; ++c)
            acc[c] = mu[c] - mu[c];
        for (int r = 0; r < 3; ++r) {
            if (!(k[r] > 0.0f))
                continue;
            int cx, cy;
            double px, py;
            vertex(va[r], vb[r], cx, cy, px, py);
            const float qx = (float)cx + (float)(x0 - px);
            const float qy = (float)cy + (float)(x1 - py);
            const float fx = qx - 0.5f;
            const float fy = qy - 0.5f;
            int ix = (int)fx;
            if ((float)ix > fx)
                ix = ix - 1;
            int iy = (int)fy;
            if ((float)iy > fy)
                iy = iy - 1;
            const float tx = fx - (float)ix;
            const float ty = fy - (float)iy;
            const int j0c = tl_texel_index(ix, cols);
            const int i0c = tl_texel_index(iy, rows);
            const float* t00 = ex + i0c * erow + j0c * ecol;
            float val[CH];
            if (tx == 0.0f && ty == 0.0f) {
                for (int c = 0; c < CH; ++c)
                    val[c] = t00[c];
            } else {
                const int j1c = tl_texel_index(ix + 1, cols);
                const int i1c = tl_texel_index(iy + 1, rows);
                const float* t01 = ex + i0c * erow + j1c * ecol;
                const float* t10 = ex + i1c * erow + j0c * ecol;
                const float* t11 = ex + i1c * erow + j1c * ecol;
                for (int c = 0; c < CH; ++c) {
                    const float top = t00[c] * (1.0f - tx) + t01[c] * tx;
                    const float bottom = t10[c] * (1.0f - tx) + t11[c] * tx;
                    val[c] = top * (1.0f - ty) + bottom * ty;
                }
            }
            for (int c = 0; c < CH; ++c)
                acc[c] = acc[c] + (val[c] - mu[c]) * k[r];
        }
        if (vp != 0 && kept != 1) {
            const float root = sqrtf((k[0] * k[0] + k[1] * k[1]) + k[2] * k[2]);
            for (int c = 0; c < CH; ++c)
                acc[c] = acc[c] / root;
        }
        float* o = orow + (size_t)j * (size_t)ocol;
        for (int c = 0; c < CH; ++c)
            o[c] = mu[c] + acc[c];
    }
    }
#undef WT_VECTOR_FORM
"""


#: The run loop with the tiling's vertex draw (kernels/tiling_draw.py) as C++ lambdas.
_RUN_DRAWN = _RUN.replace("@TILING_DRAW@", draw_code("cpp", periodic=True))


@wp.func_native(_RUN_DRAWN.replace("CHN", "1").replace("MEAN_C", "mean"))
def tiling_run1(example: wp.array2d(dtype=float), mean: float, out: wp.array2d(dtype=float), i: int, j0: int,
                j1: int, first_i: int, first_j: int, origin: wp.vec2d, step_x: wp.vec2d, step_y: wp.vec2d,
                side: float, margin: int, squarings: int, skip: float, vp: int, seed: wp.uint32, periodic: int,
                lcols: int, lrows: int, dx: wp.float64, dy: wp.float64, lpx: wp.float64, lpy: wp.float64,
                simd: int):
    """Pixels (i, j0 … j1 − 1) of a grey tiling raster (one float a texel), as ``tiling_runs``."""
    ...


@wp.func_native(_RUN_DRAWN.replace("CHN", "3").replace("MEAN_C", "mean[c]"))
def tiling_run3(example: wp.array2d(dtype=wp.vec3), mean: wp.vec3, out: wp.array2d(dtype=wp.vec3), i: int, j0: int,
                j1: int, first_i: int, first_j: int, origin: wp.vec2d, step_x: wp.vec2d, step_y: wp.vec2d,
                side: float, margin: int, squarings: int, skip: float, vp: int, seed: wp.uint32, periodic: int,
                lcols: int, lrows: int, dx: wp.float64, dy: wp.float64, lpx: wp.float64, lpy: wp.float64,
                simd: int):
    """Pixels (i, j0 … j1 − 1) of a three-channel tiling raster, as ``tiling_runs``."""
    ...


@wp.func_native(_VECTOR + """
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
def tiling_vector_form() -> int:
    """Which form of the run loop this module's CPU code holds: 3 the vector form built
    for AVX-512, 2 for AVX2, 1 for NEON; 0 the plain form (CUDA, other CPUs)."""
    ...
