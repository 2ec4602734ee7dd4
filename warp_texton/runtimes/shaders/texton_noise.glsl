#version 300 es
// Texton noise (Galerne, Leclaire, Moisan, "Texton Noise", CGF 2017), exported by warp-texton.
//
// One source for GLSL ES 3.00 (WebGL2) and, with the first line replaced by "#version 330",
// desktop GLSL 3.30+. It draws the same impacts as the package's Warp kernels: the cell hash
// (avalanche), Warp's PCG stream (rand_pcg, randf, randn) and wp.poisson's two samplers are
// reproduced in 32-bit unsigned arithmetic, in the kernels' order. The settings (cells, MNI,
// seed, period, normalisation, filter) are the constants below, written by the exporter from
// the host code the kernels take theirs from.
//
// Entry points (x in texel units, y down as in the package's rasters); they return the example's
// colours for a texton with a histogram transform, and texton_gaussian_noise, ..._at,
// ..._filtered(_at), texton_gaussian_surface_noise(_at) the Gaussian values:
//   vec3 texton_noise(vec2 x)
//   vec3 texton_noise_at(ivec2 cell, vec2 rel)                 x = cell * TN_CELL + rel, far from the origin
//   vec3 texton_noise_filtered(vec2 x, vec2 dx, vec2 dy)       footprint columns: x's steps per pixel
//   vec3 texton_noise_filtered_at(ivec2 cell, vec2 rel, vec2 dx, vec2 dy)
//   vec3 texton_surface_noise(vec3 y, vec3 n)                  y in texels (world / texel size), n unit
//   vec3 texton_surface_noise_at(ivec3 cube, vec3 rel, vec3 n) y = cube * TN_CUBE + rel
//   vec3 texton_impacts_at(ivec2 cell, vec2 rel)               (impact count, Σ d.x, Σ d.y): diagnostics
// and, beside the value, its exact gradient (docs/relief.md): the value returned, its derivatives
// per channel along x and y (texel units) in dx and dy; texton_gaussian_noise_grad(_at) for the
// Gaussian values. Unfiltered plane noise only: the filtered and surface variants have none.
//   vec3 texton_noise_grad(vec2 x, out vec3 dx, out vec3 dy)
//   vec3 texton_noise_grad_at(ivec2 cell, vec2 rel, out vec3 dx, out vec3 dy)
// Textures (RGBA32F, read with texelFetch, no filtering): texton_coeffs, the padded
// coefficients; texton_pyramid, the MIP levels stacked in rows (the filtered variant).
precision highp float;
precision highp int;

uniform highp sampler2D texton_coeffs;
uniform highp sampler2D texton_pyramid;
uniform highp sampler2D texton_colours;  // histogram transform: inverse-CDF rows per variance share
uniform highp sampler2D texton_shares;   // histogram transform: variance shares of footprints

//@CONSTANTS@

// ---------------------------------------------------------------- the impact stream
uint tn_avalanche(uint x) {
    x = x ^ (x >> 16u);
    x = x * 0x7FEB352Du;
    x = x ^ (x >> 15u);
    x = x * 0x846CA68Bu;
    x = x ^ (x >> 16u);
    return x;
}

int tn_wrap(int i, int n) {
    // i modulo n with a non-negative result (GLSL leaves % of negative operands undefined)
    if (n <= 0) return i;
    if (i >= 0) return i % n;
    return n - 1 - (-(i + 1)) % n;
}

uint tn_cell_state(int cx, int cy) {
    uint h = tn_avalanche(TN_SEED + 0x9E3779B9u);
    h = tn_avalanche(h ^ uint(tn_wrap(cx, TN_PERIOD_X)));
    h = tn_avalanche(h ^ uint(tn_wrap(cy, TN_PERIOD_Y)));
    return h;
}

uint tn_cell_state3(int cx, int cy, int cz) {
    uint h = tn_avalanche((TN_SEED ^ 0x5BD1E995u) + 0x9E3779B9u);
    h = tn_avalanche(h ^ uint(cx));
    h = tn_avalanche(h ^ uint(cy));
    h = tn_avalanche(h ^ uint(cz));
    return h;
}

uint tn_pcg(uint state) {
    uint b = state * 747796405u + 2891336453u;
    uint c = ((b >> ((b >> 28u) + 4u)) ^ b) * 277803737u;
    return (c >> 22u) ^ c;
}

float tn_randf(inout uint s) {
    s = tn_pcg(s);
    return float(s >> 8u) * 5.9604644775390625e-8;  // 2^-24: exact
}

float tn_randn(inout uint s) {
    float u1 = tn_randf(s);
    float u2 = tn_randf(s);
    return sqrt(-2.0 * log(u1 + 5.96e-8)) * cos(6.28318548 * u2);
}

float tn_loggam(float x) {
    // log Γ(x), SPECFUN's series as Warp's random_loggam evaluates it
    if (x == 1.0 || x == 2.0) return 0.0;
    uint n = 0u;
    if (x < 7.0) n = uint(7.0 - x);
    float x0 = x + float(n);
    float x2 = (1.0 / x0) * (1.0 / x0);
    float a[10] = float[10](8.333333333333333e-02, -2.777777777777778e-03, 7.936507936507937e-04,
                            -5.952380952380952e-04, 8.417508417508418e-04, -1.917526917526918e-03,
                            6.410256410256410e-03, -2.955065359477124e-02, 1.796443723688307e-01,
                            -1.39243221690590e+00);
    float gl0 = a[9];
    for (int i = 8; i >= 0; i--) {
        gl0 *= x2;
        gl0 += a[i];
    }
    float gl = gl0 / x0 + 0.5 * 1.8378770664093453 + (x0 - 0.5) * log(x0) - x0;
    if (x < 7.0) {
        for (uint k = 1u; k <= n; k++) {
            gl -= log(x0 - 1.0);
            x0 -= 1.0;
        }
    }
    return gl;
}

uint tn_poisson(inout uint s, float lam, float enlam, vec4 ptrs, vec2 ptrs2) {
    // wp.poisson: multiplication of uniforms below a mean of 10, Hörmann's transformed
    // rejection (PTRS) from 10 on; ptrs = (b, a, log(1 / alpha), v_r), ptrs2 = (log lam, -)
    if (lam == 0.0) return 0u;
    if (lam < 10.0) {
        uint X = 0u;
        float prod = 1.0;
        while (true) {
            prod *= tn_randf(s);
            if (prod > enlam) X += 1u;
            else return X;
        }
    }
    float b = ptrs.x, a = ptrs.y, loginvalpha = ptrs.z, vr = ptrs.w, loglam = ptrs2.x;
    while (true) {
        float U = tn_randf(s) - 0.5;
        float V = tn_randf(s);
        float us = 0.5 - abs(U);
        float k = floor((2.0 * a / us + b) * U + lam + 0.43);
        if (us >= 0.07 && V <= vr) return uint(k);
        if (k < 0.0 || (us < 0.013 && V > us)) continue;
        if ((log(V) + loginvalpha - log(a / (us * us) + b)) <= (-lam + k * loglam - tn_loggam(k + 1.0)))
            return uint(k);
    }
    return 0u;
}

int tn_draw_count(inout uint s, float mean_count, float sqrt_mean, float enlam, vec4 ptrs, vec2 ptrs2) {
    if (TN_EXACT_POISSON) return int(tn_poisson(s, mean_count, enlam, ptrs, ptrs2));
    float g = tn_randn(s);
    return max(int(floor(mean_count + 0.5 + sqrt_mean * g)), 0);
}

// ---------------------------------------------------------------- the texton
float tn_bspline(float t, int order) {
    float a = abs(t);
    if (order == 0) return (t >= -0.5 && t < 0.5) ? 1.0 : 0.0;
    if (order == 1) return max(1.0 - a, 0.0);
    if (order == 3) {
        if (a < 1.0) return (4.0 - 6.0 * a * a + 3.0 * a * a * a) / 6.0;
        if (a < 2.0) {
            float b = 2.0 - a;
            return b * b * b / 6.0;
        }
        return 0.0;
    }
    float s = 0.0;
    vec4 c = vec4(1.0, -6.0, 15.0, -20.0);
    for (int j = 0; j < 4; j++) {
        float u = 3.0 - a - float(j);
        if (u > 0.0) s = s + c[j] * u * u * u * u * u;
    }
    return s / 120.0;
}

vec3 tn_coeff(highp sampler2D tex, int i, int j) {
    return texelFetch(tex, ivec2(j, i), 0).rgb;
}

vec3 tn_texton_value(highp sampler2D tex, int row0, int rows, int cols, vec2 y, int order) {
    // h(y), y inside the support; rows [row0, row0 + rows) of tex hold the padded texton
    if (order == 1) {
        float fx = floor(y.x);
        float fy = floor(y.y);
        float tx = y.x - fx;
        float ty = y.y - fy;
        int j = clamp(int(fx) + TN_PAD, 0, cols - 2);
        int i = row0 + clamp(int(fy) + TN_PAD, 0, rows - 2);
        vec3 top = tn_coeff(tex, i, j) * (1.0 - tx) + tn_coeff(tex, i, j + 1) * tx;
        vec3 bottom = tn_coeff(tex, i + 1, j) * (1.0 - tx) + tn_coeff(tex, i + 1, j + 1) * tx;
        return top * (1.0 - ty) + bottom * ty;
    }
    if (order == 0) {
        int j = clamp(int(floor(y.x + 0.5)) + TN_PAD, 0, cols - 1);
        int i = row0 + clamp(int(floor(y.y + 0.5)) + TN_PAD, 0, rows - 1);
        return tn_coeff(tex, i, j);
    }
    int half_ = (order + 1) / 2;
    int j0 = int(floor(y.x)) - half_ + 1;
    int i0 = int(floor(y.y)) - half_ + 1;
    vec3 acc = vec3(0.0);
    for (int a = 0; a <= order; a++) {
        int i = i0 + a;
        float wy = tn_bspline(y.y - float(i), order);
        int ii = row0 + clamp(i + TN_PAD, 0, rows - 1);
        vec3 row = vec3(0.0);
        for (int b = 0; b <= order; b++) {
            int j = j0 + b;
            float wx = tn_bspline(y.x - float(j), order);
            row = row + tn_coeff(tex, ii, clamp(j + TN_PAD, 0, cols - 1)) * wx;
        }
        acc = acc + row * wy;
    }
    return acc;
}

float tn_bspline_slope(float t, int order) {
    // dψ/dt of tn_bspline's ψ for order 3 or 5 (kernels/noise_gradient.py bspline_slope), odd in t
    float a = abs(t);
    float s = t < 0.0 ? -1.0 : 1.0;
    if (order == 3) {
        if (a < 1.0) return s * (-2.0 * a + 1.5 * a * a);
        if (a < 2.0) {
            float b = 2.0 - a;
            return -s * 0.5 * b * b;
        }
        return 0.0;
    }
    float acc = 0.0;
    vec4 c = vec4(1.0, -6.0, 15.0, -20.0);
    for (int j = 0; j < 4; j++) {
        float u = 3.0 - a - float(j);
        if (u > 0.0) acc = acc + c[j] * u * u * u * u;
    }
    return -s * acc * (5.0 / 120.0);
}

vec3 tn_texton_slope(highp sampler2D tex, int row0, int rows, int cols, vec2 y, int order, out vec3 dx,
                     out vec3 dy) {
    // h(y) as tn_texton_value computes it, and its derivatives ∂h/∂x, ∂h/∂y in dx, dy
    // (kernels/noise_gradient.py texton_slope): order 1 one-sided on its kinks (the slope of the
    // cell its floor reads), order 0 zero
    dx = vec3(0.0);
    dy = vec3(0.0);
    if (order == 1) {
        float fx = floor(y.x);
        float fy = floor(y.y);
        float tx = y.x - fx;
        float ty = y.y - fy;
        int j = clamp(int(fx) + TN_PAD, 0, cols - 2);
        int i = row0 + clamp(int(fy) + TN_PAD, 0, rows - 2);
        vec3 a = tn_coeff(tex, i, j);
        vec3 b = tn_coeff(tex, i, j + 1);
        vec3 c = tn_coeff(tex, i + 1, j);
        vec3 d = tn_coeff(tex, i + 1, j + 1);
        vec3 top = a * (1.0 - tx) + b * tx;
        vec3 bottom = c * (1.0 - tx) + d * tx;
        dx = (b - a) * (1.0 - ty) + (d - c) * ty;
        dy = bottom - top;
        return top * (1.0 - ty) + bottom * ty;
    }
    if (order == 0) return tn_texton_value(tex, row0, rows, cols, y, order);
    int half_ = (order + 1) / 2;
    int j0 = int(floor(y.x)) - half_ + 1;
    int i0 = int(floor(y.y)) - half_ + 1;
    vec3 acc = vec3(0.0);
    for (int a = 0; a <= order; a++) {
        int i = i0 + a;
        float wy = tn_bspline(y.y - float(i), order);
        float sy = tn_bspline_slope(y.y - float(i), order);
        int ii = row0 + clamp(i + TN_PAD, 0, rows - 1);
        vec3 row = vec3(0.0);
        vec3 drow = vec3(0.0);
        for (int b = 0; b <= order; b++) {
            int j = j0 + b;
            vec3 c = tn_coeff(tex, ii, clamp(j + TN_PAD, 0, cols - 1));
            row = row + c * tn_bspline(y.x - float(j), order);
            drow = drow + c * tn_bspline_slope(y.x - float(j), order);
        }
        acc = acc + row * wy;
        dx = dx + drow * wy;
        dy = dy + row * sy;
    }
    return acc;
}

// ---------------------------------------------------------------- the plane's walk
// What a walk adds at each impact: the texton (kind 0), the filtered lookups (kind 1),
// (1, d) for the diagnostics (kind 2), or the texton with its gradient (kind 3, into gx, gy).
struct TnLevel {
    int row0;
    int rows;
    float inv_step;
    float origin;
    vec2 lo;
    vec2 hi;
};

struct TnLook {
    int kind;
    TnLevel a;
    TnLevel b;
    float w0;
    float w1;
    vec2 first;
    vec2 stride;
    int n;
    vec2 box_lo;
    vec2 box_hi;
};

TnLevel tn_level(int l) {
    TnLevel lv;
    lv.row0 = TN_LEVEL_ROW0[l];
    lv.rows = TN_LEVEL_ROWS[l];
    lv.inv_step = 1.0 / TN_LEVEL_STEP[l];
    lv.origin = TN_LEVEL_ORIGIN[l];
    lv.lo = TN_LEVEL_LO[l];
    lv.hi = TN_LEVEL_HI[l];
    return lv;
}

vec3 tn_lookup(TnLevel lv, vec2 d) {
    if (d.x < lv.lo.x || d.x > lv.hi.x || d.y < lv.lo.y || d.y > lv.hi.y) return vec3(0.0);
    vec2 y = vec2((d.x - lv.origin) * lv.inv_step, (d.y - lv.origin) * lv.inv_step);
    return tn_texton_value(texton_pyramid, lv.row0, lv.rows, TN_PYRAMID_COLS, y, TN_ORDER);
}

vec3 tn_add_lookups(TnLook c, vec2 d, vec3 acc) {
    vec2 d0 = d + c.first;
    // the lookups q in [0, n) whose offsets fall in the union of the two levels' boxes
    float qa = 0.0;
    float qb = float(c.n - 1);
    for (int axis = 0; axis < 2; axis++) {
        float s = c.stride[axis];
        if (s > 0.0) {
            qa = max(qa, (c.box_lo[axis] - d0[axis]) / s);
            qb = min(qb, (c.box_hi[axis] - d0[axis]) / s);
        } else if (s < 0.0) {
            qa = max(qa, (c.box_hi[axis] - d0[axis]) / s);
            qb = min(qb, (c.box_lo[axis] - d0[axis]) / s);
        }
    }
    int q0 = int(ceil(qa - 1.0e-5));
    int q1 = int(floor(qb + 1.0e-5));
    vec2 dk = d0 + c.stride * float(q0);
    for (int q = q0; q <= q1; q++) {
        vec3 v = tn_lookup(c.a, dk) * c.w0;
        if (c.w1 > 0.0) v = v + tn_lookup(c.b, dk) * c.w1;
        acc = acc + v;
        dk = dk + c.stride;
    }
    return acc;
}

vec3 tn_walk_slopes(ivec2 base, vec2 rel, vec2 lo, vec2 hi, TnLook look, inout vec3 gx, inout vec3 gy) {
    // Σ over the impacts q with x − q in [lo, hi], x = base · cell + rel (kind 3 also adds the
    // texton's gradient to gx, gy). The kernels find the cells in float64; here the cell index is
    // split off as an integer, so only rel (small) is rounded. The span is widened by 1e-4 of a
    // cell against that rounding: an extra cell is harmless, the per-impact test below decides.
    vec2 cs = vec2(TN_CELL_W, TN_CELL_H);
    ivec2 c0 = base + ivec2(floor((rel - hi) / cs - 1.0e-4));
    ivec2 c1 = base + ivec2(floor((rel - lo) / cs + 1.0e-4));
    vec3 acc = vec3(0.0);
    for (int cy = c0.y; cy <= c1.y; cy++) {
        for (int cx = c0.x; cx <= c1.x; cx++) {
            vec2 r = rel - vec2(float(cx - base.x) * cs.x, float(cy - base.y) * cs.y);
            uint s = tn_cell_state(cx, cy);
            int n = tn_draw_count(s, TN_MEAN_COUNT, TN_SQRT_MEAN_COUNT, TN_EXP_NEG_MEAN, TN_PTRS, TN_PTRS2);
            for (int k = 0; k < n; k++) {
                float ux = tn_randf(s);
                float uy = tn_randf(s);
                vec2 d = r - vec2(ux * cs.x, uy * cs.y);
                if (d.x >= lo.x && d.x <= hi.x && d.y >= lo.y && d.y <= hi.y) {
                    if (look.kind == 0) acc = acc + tn_texton_value(texton_coeffs, 0, TN_COEFF_ROWS,
                                                                    TN_COEFF_COLS, d, TN_ORDER);
                    else if (look.kind == 1) acc = tn_add_lookups(look, d, acc);
                    else if (look.kind == 3) {
                        vec3 sx, sy;
                        acc = acc + tn_texton_slope(texton_coeffs, 0, TN_COEFF_ROWS, TN_COEFF_COLS, d, TN_ORDER,
                                                    sx, sy);
                        gx = gx + sx;
                        gy = gy + sy;
                    }
                    else acc = acc + vec3(1.0, d);
                }
            }
        }
    }
    return acc;
}

vec3 tn_walk(ivec2 base, vec2 rel, vec2 lo, vec2 hi, TnLook look) {
    vec3 gx = vec3(0.0);
    vec3 gy = vec3(0.0);
    return tn_walk_slopes(base, rel, lo, hi, look, gx, gy);
}

ivec2 tn_cell_of(vec2 x) {
    return ivec2(floor(x / vec2(TN_CELL_W, TN_CELL_H)));
}

vec3 texton_gaussian_noise_at(ivec2 cell, vec2 rel) {
    TnLook look;
    look.kind = 0;
    vec3 acc = tn_walk(cell, rel, TN_LO, TN_HI, look);
    return TN_MEAN + (acc - TN_INTEGRAL * TN_LAM) / TN_SQRT_LAM;
}

vec3 texton_gaussian_noise(vec2 x) {
    ivec2 cell = tn_cell_of(x);
    return texton_gaussian_noise_at(cell, x - vec2(cell) * vec2(TN_CELL_W, TN_CELL_H));
}

vec3 texton_gaussian_noise_grad_at(ivec2 cell, vec2 rel, out vec3 dx, out vec3 dy) {
    // texton_gaussian_noise_at and its gradient Σ ∇h(x − q) / √λ over the same impacts
    TnLook look;
    look.kind = 3;
    vec3 gx = vec3(0.0);
    vec3 gy = vec3(0.0);
    vec3 acc = tn_walk_slopes(cell, rel, TN_LO, TN_HI, look, gx, gy);
    dx = gx / TN_SQRT_LAM;
    dy = gy / TN_SQRT_LAM;
    return TN_MEAN + (acc - TN_INTEGRAL * TN_LAM) / TN_SQRT_LAM;
}

vec3 texton_gaussian_noise_grad(vec2 x, out vec3 dx, out vec3 dy) {
    ivec2 cell = tn_cell_of(x);
    return texton_gaussian_noise_grad_at(cell, x - vec2(cell) * vec2(TN_CELL_W, TN_CELL_H), dx, dy);
}

vec3 texton_impacts_at(ivec2 cell, vec2 rel) {
    TnLook look;
    look.kind = 2;
    return tn_walk(cell, rel, TN_LO, TN_HI, look);
}

// ---------------------------------------------------------------- filtered noise (CGF §5)
vec3 tn_footprint_axes(mat2 J, out vec2 u) {
    // (major length, minor length, -) of the footprint J [-½, ½]² and its unit major axis u
    u = vec2(1.0, 0.0);
    float s = max(max(abs(J[0][0]), abs(J[1][0])), max(abs(J[0][1]), abs(J[1][1])));
    if (s == 0.0) return vec3(0.0);
    mat2 K = J / s;
    // K[col][row]: entry (r, c) of the kernels' matrix is K[c][r]
    float m00 = K[0][0] * K[0][0] + K[1][0] * K[1][0];
    float m01 = K[0][0] * K[0][1] + K[1][0] * K[1][1];
    float m11 = K[0][1] * K[0][1] + K[1][1] * K[1][1];
    float half_ = 0.5 * (m00 + m11);
    float disc = sqrt(max(0.25 * (m00 - m11) * (m00 - m11) + m01 * m01, 0.0));
    float l1 = half_ + disc;
    float l2 = max(half_ - disc, 0.0);
    vec2 a = vec2(m01, l1 - m00);
    vec2 b = vec2(l1 - m11, m01);
    float na = length(a);
    float nb = length(b);
    if (na >= nb && na > 0.0) u = a / na;
    else if (nb > 0.0) u = b / nb;
    return vec3(s * sqrt(l1), s * sqrt(l2), 0.0);
}

float tn_footprint_lod(mat2 J, out vec2 axis, out float major, out int n) {
    // the filter's MIP level (≥ 0, before the fade) for the footprint J, its major length and
    // axis and the lookups along it (kernels/filter2d.py footprint_lookups)
    vec3 ax = tn_footprint_axes(J, axis);
    major = ax.x;
    float minor = ax.y;
    n = 1;
    float width = major;
    if (TN_FILTER_MODE == 2) {
        if (major > minor * float(TN_MAX_ANISO)) n = TN_MAX_ANISO;
        else if (minor > 0.0) n = int(ceil(major / minor - 1.0e-4));
        n = max(n, 1);
        width = max(minor, major / float(n));
    }
    float lod = 0.0;
    if (width > 0.0) lod = max(log2(width) + TN_LOD_BIAS, 0.0);
    return lod;
}

vec3 texton_gaussian_noise_filtered_at(ivec2 cell, vec2 rel, vec2 dx, vec2 dy) {
    if (TN_FILTER_MODE == 0) return texton_gaussian_noise_at(cell, rel);
    vec2 axis;
    float major;
    int n;
    float lod = tn_footprint_lod(mat2(dx, dy), axis, major, n);
    if (lod >= float(TN_LEVELS) || isnan(lod)) return TN_MEAN;
    int l0 = int(floor(lod));
    float frac = lod - float(l0);
    int l1 = min(l0 + 1, TN_LEVELS - 1);
    float w0 = 1.0 - frac;
    float w1 = frac;
    float real = 1.0;
    if (l0 + 1 >= TN_LEVELS) {
        w1 = 0.0;
        real = w0;
    }
    if (frac == 0.0) w1 = 0.0;
    if (w1 == 0.0) l1 = l0;
    vec2 spread = axis * (major * (0.5 - 0.5 / float(n)));
    TnLook look;
    look.kind = 1;
    look.first = -spread;
    look.stride = vec2(0.0);
    if (n > 1) look.stride = spread * (2.0 / float(n - 1));
    look.box_lo = min(TN_LEVEL_LO[l0], TN_LEVEL_LO[l1]);
    look.box_hi = max(TN_LEVEL_HI[l0], TN_LEVEL_HI[l1]);
    vec2 ext = abs(spread);
    look.a = tn_level(l0);
    look.b = tn_level(l1);
    look.w0 = w0;
    look.w1 = w1;
    look.n = n;
    vec3 acc = tn_walk(cell, rel, look.box_lo - ext, look.box_hi + ext, look);
    acc = acc / float(n);
    return TN_MEAN + (acc - TN_INTEGRAL * (TN_LAM * real)) / TN_SQRT_LAM;
}

vec3 texton_gaussian_noise_filtered(vec2 x, vec2 dx, vec2 dy) {
    ivec2 cell = tn_cell_of(x);
    return texton_gaussian_noise_filtered_at(cell, x - vec2(cell) * vec2(TN_CELL_W, TN_CELL_H), dx, dy);
}

// ---------------------------------------------------------------- surface noise (CGF §6)
void tn_tangent_frame(vec3 n, out vec3 u1, out vec3 u2) {
    // u1 from v = P_n(a) + <a, n>^4 P_n(b), the package's frame rule (frames.py)
    vec3 a = TN_FRAME_UP;
    vec3 b = TN_FRAME_SIDE;
    float ca = dot(a, n);
    float c4 = ca * ca * ca * ca;
    vec3 v = (a - n * ca) + (b - n * dot(b, n)) * c4;
    float len = length(v);
    if (len < 1.0e-6) {
        v = b - n * dot(b, n);
        len = length(v);
        if (len < 1.0e-6) {
            v = cross(n, a);
            len = length(v);
        }
    }
    u1 = v / len;
    u2 = cross(n, u1);
}

vec3 texton_gaussian_surface_noise_at(ivec3 cube, vec3 rel, vec3 n) {
    vec3 u1, u2;
    tn_tangent_frame(n, u1, u2);
    float c = TN_CUBE;
    float half_ = TN_SLAB_HALF;
    vec3 ext = vec3(half_ * (abs(u1.x) + abs(u2.x) + abs(n.x)), half_ * (abs(u1.y) + abs(u2.y) + abs(n.y)),
                    half_ * (abs(u1.z) + abs(u2.z) + abs(n.z)));
    ivec3 k0 = cube + ivec3(floor((rel - ext) / c - 1.0e-4));
    ivec3 k1 = cube + ivec3(floor((rel + ext) / c + 1.0e-4));
    vec3 acc = vec3(0.0);
    for (int cz = k0.z; cz <= k1.z; cz++) {
        for (int cy = k0.y; cy <= k1.y; cy++) {
            for (int cx = k0.x; cx <= k1.x; cx++) {
                uint s = tn_cell_state3(cx, cy, cz);
                int count = tn_draw_count(s, TN_MEAN_COUNT3, TN_SQRT_MEAN_COUNT3, TN_EXP_NEG_MEAN3, TN_PTRS3,
                                          TN_PTRS3B);
                vec3 r = rel - vec3(ivec3(cx, cy, cz) - cube) * c;
                for (int k = 0; k < count; k++) {
                    float ux = tn_randf(s);
                    float uy = tn_randf(s);
                    float uz = tn_randf(s);
                    vec3 d = r - vec3(ux, uy, uz) * c;
                    float t = dot(d, n);
                    if (abs(t) < half_) {
                        vec2 z = vec2(dot(d, u1), dot(d, u2)) + TN_SLAB_CENTRE;
                        if (z.x >= TN_LO.x && z.x <= TN_HI.x && z.y >= TN_LO.y && z.y <= TN_HI.y) {
                            float w = 1.0 - abs(t) / half_;
                            acc = acc + tn_texton_value(texton_coeffs, 0, TN_COEFF_ROWS, TN_COEFF_COLS, z,
                                                        TN_ORDER) * w;
                        }
                    }
                }
            }
        }
    }
    return TN_MEAN + (acc - TN_SURFACE_SHIFT) * TN_SURFACE_INV_SCALE;
}

vec3 texton_gaussian_surface_noise(vec3 y, vec3 n) {
    ivec3 cube = ivec3(floor(y / TN_CUBE));
    return texton_gaussian_surface_noise_at(cube, y - vec3(cube) * TN_CUBE, n);
}

// ---------------------------------------------------------------- colours (histogram transform)
// A texton analysed with histogram="preserve" maps its Gaussian noise to the example's colours
// (kernels/colours.py): standardised per channel, looked up in the inverse-CDF tables (rows of
// texton_colours, one per variance share, channels in RGB), rotated back by TN_COLOUR_MATRIX.
// Filtered values use the tables prefiltered for the share of the variance they keep, read from
// texton_shares (footprint extents and angle). Without a transform (TN_HISTOGRAM false) the
// values pass through.
float tn_table(int row, int c, float g) {
    float k = float(TN_LUT_SIZE - 1);
    float pos = clamp((g + TN_GAUSS_RANGE) * (k / (2.0 * TN_GAUSS_RANGE)), 0.0, k);
    int i0 = min(int(pos), TN_LUT_SIZE - 2);
    float t = pos - float(i0);
    return texelFetch(texton_colours, ivec2(i0, row), 0)[c] * (1.0 - t) +
           texelFetch(texton_colours, ivec2(i0 + 1, row), 0)[c] * t;
}

vec3 tn_mapped(vec3 v, int j0, float ts) {
    vec3 z = vec3(0.0);
    for (int c = 0; c < TN_CHANNELS; c++) {
        float g = (v[c] - TN_MEAN[c]) / TN_NOISE_STD[c];
        float a = tn_table(j0, c, g);
        if (ts > 0.0) a = a * (1.0 - ts) + tn_table(j0 + 1, c, g) * ts;
        z[c] = a;
    }
    vec3 out_ = v;
    for (int r = 0; r < TN_CHANNELS; r++) {
        float acc = TN_COLOUR_CENTRE[r];
        for (int c = 0; c < TN_CHANNELS; c++) acc += z[c] * TN_COLOUR_MATRIX[r][c];
        out_[r] = acc;
    }
    return out_;
}

vec3 texton_colour(vec3 v) {
    // the colour of an unfiltered noise value
    if (!TN_HISTOGRAM) return v;
    return tn_mapped(v, TN_SHARE_STEPS - 1, 0.0);
}

float tn_table_slope(int row, int c, float g) {
    // the slope of tn_table's linear segment at g; 0 where the table clamps
    float k = float(TN_LUT_SIZE - 1);
    float per = k / (2.0 * TN_GAUSS_RANGE);
    float pos = (g + TN_GAUSS_RANGE) * per;
    if (!(pos >= 0.0 && pos <= k)) return 0.0;
    int i0 = min(int(pos), TN_LUT_SIZE - 2);
    return (texelFetch(texton_colours, ivec2(i0 + 1, row), 0)[c] - texelFetch(texton_colours, ivec2(i0, row), 0)[c])
           * per;
}

vec3 texton_colour_grad(vec3 v, inout vec3 dx, inout vec3 dy) {
    // texton_colour(v), and the gradient (dx, dy) of v mapped through the tables' derivative:
    // ∂colour_r = Σ_c P[r][c] T_c'(g_c) / σ_c ∂v_c (docs/relief.md)
    if (!TN_HISTOGRAM) return v;
    int row = TN_SHARE_STEPS - 1;
    vec3 sx = vec3(0.0);
    vec3 sy = vec3(0.0);
    for (int c = 0; c < TN_CHANNELS; c++) {
        float t = tn_table_slope(row, c, (v[c] - TN_MEAN[c]) / TN_NOISE_STD[c]) / TN_NOISE_STD[c];
        sx[c] = t * dx[c];
        sy[c] = t * dy[c];
    }
    for (int r = 0; r < TN_CHANNELS; r++) {
        float ax = 0.0;
        float ay = 0.0;
        for (int c = 0; c < TN_CHANNELS; c++) {
            ax += sx[c] * TN_COLOUR_MATRIX[r][c];
            ay += sy[c] * TN_COLOUR_MATRIX[r][c];
        }
        dx[r] = ax;
        dy[r] = ay;
    }
    return tn_mapped(v, row, 0.0);
}

vec3 texton_colour_share(vec3 v, float share) {
    // the colour of a value that kept the share `share` of the noise's variance
    if (!TN_HISTOGRAM) return v;
    float s = isnan(share) ? 0.0 : clamp(share, 0.0, 1.0);
    float sp = s * float(TN_SHARE_STEPS - 1);
    int j0 = min(int(sp), TN_SHARE_STEPS - 2);
    return tn_mapped(v, j0, sp - float(j0));
}

vec2 tn_extent_index(float extent) {
    float pos = clamp((log2(extent) - TN_LOG_FIRST) / TN_LOG_STEP, 0.0, float(TN_EXTENTS - 1));
    if (isnan(pos)) pos = 0.0;
    int i = min(int(pos), TN_EXTENTS - 2);
    return vec2(float(i), pos - float(i));
}

float tn_share_at(int i, int j, int k) {
    return texelFetch(texton_shares, ivec2(j * TN_ANGLES + k, i), 0).r;
}

float texton_footprint_share(vec2 dx, vec2 dy) {
    // the share of the noise's variance a footprint of columns dx, dy keeps (before the fade)
    mat2 J = mat2(dx, dy);
    float s = max(max(abs(J[0][0]), abs(J[1][0])), max(abs(J[0][1]), abs(J[1][1])));
    if (s == 0.0) s = 1.0;
    mat2 K = J / s;
    float m00 = K[0][0] * K[0][0] + K[1][0] * K[1][0];
    float m01 = K[0][0] * K[0][1] + K[1][0] * K[1][1];
    float m11 = K[0][1] * K[0][1] + K[1][1] * K[1][1];
    float half_ = 0.5 * (m00 + m11);
    float disc = sqrt(0.25 * (m00 - m11) * (m00 - m11) + m01 * m01);
    vec2 ei = tn_extent_index(s * sqrt(half_ + disc));
    vec2 ej = tn_extent_index(s * sqrt(max(half_ - disc, 0.0)));
    float a = 0.5 * atan(2.0 * m01, m00 - m11) / 3.14159265358979;
    float pk = (a - floor(a)) * float(TN_ANGLES);
    int k = min(int(pk), TN_ANGLES - 1);
    float tk = pk - float(k);
    int k1 = (k + 1) % TN_ANGLES;
    int i = int(ei.x), j = int(ej.x);
    float out_ = 0.0;
    for (int di = 0; di < 2; di++) {
        float wi = di == 1 ? ei.y : 1.0 - ei.y;
        for (int dj = 0; dj < 2; dj++) {
            float wj = dj == 1 ? ej.y : 1.0 - ej.y;
            out_ += wi * wj * (tn_share_at(i + di, j + dj, k) * (1.0 - tk) + tn_share_at(i + di, j + dj, k1) * tk);
        }
    }
    return clamp(out_, 0.0, 1.0);
}

float texton_filtered_share(vec2 dx, vec2 dy) {
    // the share of texton_gaussian_noise_filtered's value: faded with the noise past the kept levels
    if (TN_FILTER_MODE == 0) return 1.0;
    vec2 axis;
    float major;
    int n;
    float lod = tn_footprint_lod(mat2(dx, dy), axis, major, n);
    if (n == 1 && lod == 0.0) return 1.0;  // one lookup of level 0: the unfiltered noise
    float fade = isnan(lod) ? 0.0 : clamp(float(TN_LEVELS) - lod, 0.0, 1.0);
    return texton_footprint_share(dx, dy) * fade * fade;
}

// The entry points: colours (the Gaussian values for a texton without a transform).
vec3 texton_noise_at(ivec2 cell, vec2 rel) {
    return texton_colour(texton_gaussian_noise_at(cell, rel));
}

vec3 texton_noise(vec2 x) {
    return texton_colour(texton_gaussian_noise(x));
}

vec3 texton_noise_grad_at(ivec2 cell, vec2 rel, out vec3 dx, out vec3 dy) {
    // texton_noise_at, and its gradient: the derivatives per channel along x (dx) and y (dy)
    vec3 v = texton_gaussian_noise_grad_at(cell, rel, dx, dy);
    return texton_colour_grad(v, dx, dy);
}

vec3 texton_noise_grad(vec2 x, out vec3 dx, out vec3 dy) {
    ivec2 cell = tn_cell_of(x);
    return texton_noise_grad_at(cell, x - vec2(cell) * vec2(TN_CELL_W, TN_CELL_H), dx, dy);
}

vec3 texton_noise_filtered_at(ivec2 cell, vec2 rel, vec2 dx, vec2 dy) {
    vec3 v = texton_gaussian_noise_filtered_at(cell, rel, dx, dy);
    if (!TN_HISTOGRAM) return v;
    return texton_colour_share(v, texton_filtered_share(dx, dy));
}

vec3 texton_noise_filtered(vec2 x, vec2 dx, vec2 dy) {
    ivec2 cell = tn_cell_of(x);
    return texton_noise_filtered_at(cell, x - vec2(cell) * vec2(TN_CELL_W, TN_CELL_H), dx, dy);
}

vec3 texton_surface_noise_at(ivec3 cube, vec3 rel, vec3 n) {
    return texton_colour(texton_gaussian_surface_noise_at(cube, rel, n));
}

vec3 texton_surface_noise(vec3 y, vec3 n) {
    return texton_colour(texton_gaussian_surface_noise(y, n));
}
