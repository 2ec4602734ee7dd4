#version 300 es
// Tiling and blending by example (Heitz & Neyret 2018; Mikkelsen 2022's sharpened weights),
// exported by warp-texton from a tiling model (docs/tiling.md is the specification).
//
// One source for GLSL ES 3.00 (WebGL2) and, with the first line replaced by "#version 330",
// desktop GLSL 3.30+. It reproduces kernels/noise_tiling.py tiling_value: the vertex draw
// (generated from kernels/tiling_draw.py: the hash and Warp's PCG draws in 32-bit unsigned
// arithmetic, the centre texel, the whole-texel placement, the lattice snap, the clamped or
// wrapped addressing, its constants), the triangle, the bilinear lookups, the weights and the
// blend, in float32. GLSL ES has no float64: positions are taken relative to an anchor vertex of
// the triangle lattice (tiling_noise_at), so only the distance from the anchor is rounded to
// float32; a lattice model's snap takes each vertex's position mod the lattice's modulus N as the
// anchor's (anchor_mod, from the host) plus the vertex's whole-texel offset, in integers.
//
// Entry points (x in noise units: texels of the example at scale 1, y down as in the package's rasters):
//   vec3 tiling_noise(vec2 x)                                 x near the origin (|x| up to ~10^4)
//   vec3 tiling_noise_at(ivec2 anchor, ivec2 anchor_mod, vec2 frac, vec2 rel)
//                                                             x = P(anchor) + rel, anywhere
//   vec3 tiling_noise_at(ivec2 anchor, vec2 frac, vec2 rel)   the same, for a model without a lattice
//   vec3 tiling_blend(vec2 x), tiling_blend_at(...)             the blend before the histogram tables
//   vec3 tiling_colour(vec3 v)                                  the tables applied to a blended value
// and, beside each, its exact gradient (docs/relief.md): the value returned, its derivatives per
// channel along x and y (noise units) in dx and dy (the blend with its weights' derivative, the
// bilinear example one-sided on its texel rows and columns, the tables through their slope):
//   vec3 tiling_noise_grad(vec2 x, out vec3 dx, out vec3 dy)
//   vec3 tiling_noise_grad_at(ivec2 anchor, ivec2 anchor_mod, vec2 frac, vec2 rel, out vec3 dx, out vec3 dy)
//   vec3 tiling_noise_grad_at(ivec2 anchor, vec2 frac, vec2 rel, out vec3 dx, out vec3 dy)
//   vec3 tiling_blend_grad(vec2 x, ...), tiling_blend_grad_at(...)   before the tables
// where anchor = (a, b) is a lattice vertex, p(a, b) = side (a + b/2, b sqrt(3)/2) its position,
// P(a, b) = floor(p(a, b) + 1/2) that position rounded to whole texels (computed in float64 by
// the host: warp_texton.runtimes.glsl.tiling.tiling_anchor), frac = p(a, b) - P(a, b) and
// anchor_mod = P(a, b) mod TL_MODULUS per axis, in [0, TL_MODULUS) (runtimes.glsl.tiling.anchor_mod;
// (0, 0) without a lattice, where TL_MODULUS is 1).
// Texture (RGBA32F, read with texelFetch, no filtering): tiling_example, the example's texels
// in RGB (grey examples in R), the standardised luminance guide in A; row 0 is the example's top row.
// Each axis is read clamped to the edge, or wrapped where the example is seamless (TL_WRAP).
// A lattice model (TL_RANK 1 or 2) adds tiling_mean, its lattice-periodic mean (the same layout, A
// unused): the blend mixes the residuals around it and keeps it (kernels/noise_tiling.py patch_term3).
// A histogram-preserving model (TL_HISTOGRAM) adds tiling_colours: its inverse-CDF tables (one row,
// K texels, channels in RGB), which tiling_noise* apply after the blend as kernels/noise_colours.py
// colour_value does (texton noise's tables: texton_noise.glsl, texton_colour).
precision highp float;
precision highp int;

uniform highp sampler2D tiling_example;
uniform highp sampler2D tiling_colours;
uniform highp sampler2D tiling_mean;

//@CONSTANTS@

//@TILING_DRAW@

ivec2 tl_centre(int a, int b) {
    // the example texel (column, row) that vertex (a, b) draws: centres range over the model's centre
    // box (at least TL_MARGIN from a clamped border, plus a lattice's half cell; anywhere on a wrapped axis)
    int cx, cy;
    tl_vertex_centre(tl_seed_state(TL_SEED), a, b, TL_CENTRE_LO.x, TL_CENTRE_COUNT.x, TL_CENTRE_LO.y,
                     TL_CENTRE_COUNT.y, cx, cy);
    return ivec2(cx, cy);
}

int tl_mod(int v, int n) {
    // v mod n in [0, n) for n > 0 (GLSL ES leaves % of a negative operand undefined)
    return v >= 0 ? v % n : n - 1 - (-1 - v) % n;
}

ivec2 tl_snapped(ivec2 c, ivec2 anchor_mod, float px, float py) {
    // the centre c of the vertex at P(anchor) + (px, py) (whole texels) snapped to the model's lattice
    if (TL_RANK == 0) return c;
    int sx, sy;
    tl_lattice_snap(c.x, c.y, tl_mod(anchor_mod.x + int(px), TL_MODULUS), tl_mod(anchor_mod.y + int(py), TL_MODULUS),
                    TL_RANK, TL_MODULUS, TL_K1.x, TL_K1.y, TL_K2.x, TL_K2.y, sx, sy);
    return ivec2(sx, sy);
}

vec4 tl_texel(int i, int j) {
    return texelFetch(tiling_example, ivec2(tl_texel_address(j, TL_COLS, TL_WRAP.x),
                                            tl_texel_address(i, TL_ROWS, TL_WRAP.y)), 0);
}

vec4 tl_mean_texel(int i, int j) {
    return texelFetch(tiling_mean, ivec2(tl_texel_address(j, TL_COLS, TL_WRAP.x),
                                         tl_texel_address(i, TL_ROWS, TL_WRAP.y)), 0);
}

vec4 tl_bilinear_mean(vec2 q) {
    // the lattice-periodic mean at q, as tl_bilinear reads the example
    float fx = q.x - 0.5;
    float fy = q.y - 0.5;
    float x0 = floor(fx);
    float y0 = floor(fy);
    float tx = fx - x0;
    float ty = fy - y0;
    int j0 = int(x0);
    int i0 = int(y0);
    if (tx == 0.0 && ty == 0.0) return tl_mean_texel(i0, j0);
    vec4 top = tl_mean_texel(i0, j0) * (1.0 - tx) + tl_mean_texel(i0, j0 + 1) * tx;
    vec4 bottom = tl_mean_texel(i0 + 1, j0) * (1.0 - tx) + tl_mean_texel(i0 + 1, j0 + 1) * tx;
    return top * (1.0 - ty) + bottom * ty;
}

vec4 tl_bilinear(vec2 q) {
    // the example (RGB) and guide (A) at q = (x, y) in texel units, clamped to its edge or wrapped
    float fx = q.x - 0.5;
    float fy = q.y - 0.5;
    float x0 = floor(fx);
    float y0 = floor(fy);
    float tx = fx - x0;
    float ty = fy - y0;
    int j0 = int(x0);
    int i0 = int(y0);
    if (tx == 0.0 && ty == 0.0) return tl_texel(i0, j0);
    vec4 top = tl_texel(i0, j0) * (1.0 - tx) + tl_texel(i0, j0 + 1) * tx;
    vec4 bottom = tl_texel(i0 + 1, j0) * (1.0 - tx) + tl_texel(i0 + 1, j0 + 1) * tx;
    return top * (1.0 - ty) + bottom * ty;
}

vec2 tl_patch_point(ivec2 anchor, ivec2 anchor_mod, vec2 frac, vec2 rel, int a, int b) {
    // where vertex (a, b)'s patch reads the example: c + (x - P(a, b)), with
    // P(a, b) - P(anchor) = floor(frac + p(a - anchor.x, b - anchor.y) + 1/2) from the anchor's offsets
    // and c the vertex's centre, snapped to a lattice where the model has one
    float px, py;
    tl_vertex_position(frac.x, frac.y, TL_SIDE, a - anchor.x, b - anchor.y, px, py);
    return vec2(tl_snapped(tl_centre(a, b), anchor_mod, px, py)) + (rel - vec2(px, py));
}

void tl_patch_term(vec2 q, float k, inout vec3 acc, inout vec3 macc) {
    // one kept patch's part of the blend: (e - mean) k without a lattice; with one, the residual around
    // the lattice-periodic mean, (e - m) k, and the mean's part m k (kernels/noise_tiling.py patch_term3)
    vec3 e = tl_bilinear(q).rgb;
    if (TL_RANK == 0) {
        acc = acc + (e - TL_MEAN) * k;
    } else {
        vec3 m = tl_bilinear_mean(q).rgb;
        acc = acc + (e - m) * k;
        macc = macc + m * k;
    }
}

float tl_power(float w) {
    float r = w;
    for (int i = 0; i < TL_SQUARINGS; i++) r = r * r;
    return r;
}

float tl_sharpened(float w, float dg) {
    if (w <= 0.0) return 0.0;
    float k = tl_power(w);
    if (TL_GUIDE_WEIGHT != 0.0) k = k * exp(TL_GUIDE_WEIGHT * dg);
    return k;
}

// The triangle of x - p(anchor): skewed coordinates, its vertices (a0, b0), (a + 1, b), (a, b + 1)
// on Z^2, their barycentric weights w0, w1, w2; true for the upper triangle (u + v > 1)
bool tl_triangle(ivec2 anchor, vec2 frac, vec2 rel, out int a, out int b, out int a0, out int b0,
                 out float w0, out float w1, out float w2) {
    vec2 d = rel - frac;
    float qx = d.x / TL_SIDE;
    float qy = d.y / TL_SIDE;
    float sy = qy / TL_SQRT3_2;
    float sx = qx - sy * 0.5;
    float fa = floor(sx);
    float fb = floor(sy);
    float u = sx - fa;
    float v = sy - fb;
    a = anchor.x + int(fa);
    b = anchor.y + int(fb);
    a0 = a;
    b0 = b;
    w0 = 1.0 - u - v;
    w1 = u;
    w2 = v;
    if (u + v > 1.0) {
        a0 = a + 1;
        b0 = b + 1;
        w0 = u + v - 1.0;
        w1 = 1.0 - v;
        w2 = 1.0 - u;
        return true;
    }
    return false;
}

vec3 tiling_blend_at(ivec2 anchor, ivec2 anchor_mod, vec2 frac, vec2 rel) {
    int a, b, a0, b0;
    float w0, w1, w2;
    tl_triangle(anchor, frac, rel, a, b, a0, b0, w0, w1, w2);
    vec2 q0 = tl_patch_point(anchor, anchor_mod, frac, rel, a0, b0);
    vec2 q1 = tl_patch_point(anchor, anchor_mod, frac, rel, a + 1, b);
    vec2 q2 = tl_patch_point(anchor, anchor_mod, frac, rel, a, b + 1);
    float g0 = 0.0, g1 = 0.0, g2 = 0.0;
    if (TL_GUIDE_WEIGHT != 0.0) {
        g0 = tl_bilinear(q0).a;
        g1 = tl_bilinear(q1).a;
        g2 = tl_bilinear(q2).a;
    }
    float gm = max(g0, max(g1, g2));
    float k0 = tl_sharpened(w0, g0 - gm);
    float k1 = tl_sharpened(w1, g1 - gm);
    float k2 = tl_sharpened(w2, g2 - gm);
    float km = max(k0, max(k1, k2)) * TL_CUTOFF;
    if (k0 < km) k0 = 0.0;
    if (k1 < km) k1 = 0.0;
    if (k2 < km) k2 = 0.0;
    float total = k0 + k1 + k2;
    k0 = k0 / total;
    k1 = k1 / total;
    k2 = k2 / total;
    vec3 acc = vec3(0.0);
    vec3 macc = vec3(0.0);
    if (k0 > 0.0) tl_patch_term(q0, k0, acc, macc);
    if (k1 > 0.0) tl_patch_term(q1, k1, acc, macc);
    if (k2 > 0.0) tl_patch_term(q2, k2, acc, macc);
    if (TL_VARIANCE_PRESERVING) acc = acc / sqrt(k0 * k0 + k1 * k1 + k2 * k2);
    if (TL_RANK != 0) return macc + acc;
    return TL_MEAN + acc;
}

// ---------------------------------------------------------------- colours (histogram tables)
// A histogram-preserving model blends its Gaussianised example; each channel of the blend is
// standardised with the blend's mean and standard deviation, looked up in its inverse-CDF table
// (linear, clamped to the Gaussian grid [-TL_GAUSS_RANGE, TL_GAUSS_RANGE]) and rotated back by
// TL_COLOUR_MATRIX. Without tables (TL_HISTOGRAM false) the values pass through.
float tl_table(int c, float g) {
    float k = float(TL_LUT_SIZE - 1);
    float pos = clamp((g + TL_GAUSS_RANGE) * (k / (2.0 * TL_GAUSS_RANGE)), 0.0, k);
    int i0 = min(int(pos), TL_LUT_SIZE - 2);
    float t = pos - float(i0);
    return texelFetch(tiling_colours, ivec2(i0, 0), 0)[c] * (1.0 - t) +
           texelFetch(tiling_colours, ivec2(i0 + 1, 0), 0)[c] * t;
}

vec3 tiling_colour(vec3 v) {
    if (!TL_HISTOGRAM) return v;
    vec3 z = vec3(0.0);
    for (int c = 0; c < TL_CHANNELS; c++) z[c] = tl_table(c, (v[c] - TL_NOISE_MEAN[c]) / TL_NOISE_STD[c]);
    vec3 out_ = v;
    for (int r = 0; r < TL_CHANNELS; r++) {
        float acc = TL_COLOUR_CENTRE[r];
        for (int c = 0; c < TL_CHANNELS; c++) acc += z[c] * TL_COLOUR_MATRIX[r][c];
        out_[r] = acc;
    }
    return out_;
}

vec3 tiling_blend_at(ivec2 anchor, vec2 frac, vec2 rel) {
    // without a lattice the anchor's position mod N is not read
    return tiling_blend_at(anchor, ivec2(0), frac, rel);
}

vec3 tiling_blend(vec2 x) {
    // the anchor (0, 0): p(0, 0) = P(0, 0) = 0
    return tiling_blend_at(ivec2(0), ivec2(0), vec2(0.0), x);
}

vec3 tiling_noise_at(ivec2 anchor, ivec2 anchor_mod, vec2 frac, vec2 rel) {
    return tiling_colour(tiling_blend_at(anchor, anchor_mod, frac, rel));
}

vec3 tiling_noise_at(ivec2 anchor, vec2 frac, vec2 rel) {
    return tiling_colour(tiling_blend_at(anchor, frac, rel));
}

vec3 tiling_noise(vec2 x) {
    return tiling_colour(tiling_blend(x));
}

// ---------------------------------------------------------------- gradients (kernels/noise_gradient.py)
vec4 tl_fetch(int which, int i, int j) {
    return which == 0 ? tl_texel(i, j) : tl_mean_texel(i, j);
}

vec4 tl_bilinear_slope(int which, vec2 q, out vec4 gx, out vec4 gy) {
    // tl_bilinear (which 0) or tl_bilinear_mean (1) at q, and its derivatives: on a texel row or
    // column the slope of the cell to the right / below (one-sided, where the value's floor puts it);
    // past a clamped edge, where the image is constant, 0
    float fx = q.x - 0.5;
    float fy = q.y - 0.5;
    float x0 = floor(fx);
    float y0 = floor(fy);
    float tx = fx - x0;
    float ty = fy - y0;
    int j0 = int(x0);
    int i0 = int(y0);
    float sx = tl_texel_address(j0, TL_COLS, TL_WRAP.x) == tl_texel_address(j0 + 1, TL_COLS, TL_WRAP.x) ? 0.0 : 1.0;
    float sy = tl_texel_address(i0, TL_ROWS, TL_WRAP.y) == tl_texel_address(i0 + 1, TL_ROWS, TL_WRAP.y) ? 0.0 : 1.0;
    vec4 a = tl_fetch(which, i0, j0);
    vec4 b = tl_fetch(which, i0, j0 + 1);
    vec4 c = tl_fetch(which, i0 + 1, j0);
    vec4 d = tl_fetch(which, i0 + 1, j0 + 1);
    vec4 top = a * (1.0 - tx) + b * tx;
    vec4 bottom = c * (1.0 - tx) + d * tx;
    gx = ((b - a) * (1.0 - ty) + (d - c) * ty) * sx;
    gy = (bottom - top) * sy;
    if (tx == 0.0 && ty == 0.0) return a;
    return top * (1.0 - ty) + bottom * ty;
}

vec2 tl_weight_slope(float k, float w, vec2 dw, vec4 g, vec4 gm) {
    // ∇k of k = w^s exp(β (g − g_max)): k (s ∇w / w + β (∇g − ∇g_max)); 0 for a dropped weight
    if (k <= 0.0) return vec2(0.0);
    float s = float(1 << TL_SQUARINGS);
    return k * (dw * (s / w) + TL_GUIDE_WEIGHT * (g.yz - gm.yz));
}

vec3 tiling_blend_grad_at(ivec2 anchor, ivec2 anchor_mod, vec2 frac, vec2 rel, out vec3 dx, out vec3 dy) {
    // tiling_blend_at and its gradient: the quotient R = Σ k_i r_i / N (N = Σ k_i, or √(Σ k_i²) for
    // the variance-preserving blend) with r_i = e_i − mean (or − m_i, plus the lattice mean's
    // M = Σ k_i m_i / Σ k_i), differentiated with its weights (kernels/noise_gradient.py tiling_slope)
    int a, b, a0, b0;
    float w0, w1, w2;
    bool upper = tl_triangle(anchor, frac, rel, a, b, a0, b0, w0, w1, w2);
    // d(u, v)/d(x, y) of the skewed coordinates, and the weights' gradients
    float hy = TL_SIDE * TL_SQRT3_2;
    vec2 du = vec2(1.0 / TL_SIDE, -0.5 / hy);
    vec2 dv = vec2(0.0, 1.0 / hy);
    vec2 dw0 = -du - dv, dw1 = du, dw2 = dv;
    if (upper) {
        dw0 = du + dv;
        dw1 = -dv;
        dw2 = -du;
    }
    vec2 q0 = tl_patch_point(anchor, anchor_mod, frac, rel, a0, b0);
    vec2 q1 = tl_patch_point(anchor, anchor_mod, frac, rel, a + 1, b);
    vec2 q2 = tl_patch_point(anchor, anchor_mod, frac, rel, a, b + 1);
    // the guide (A) with its gradient, as (value, ∂x, ∂y, -)
    vec4 g0 = vec4(0.0), g1 = vec4(0.0), g2 = vec4(0.0);
    vec4 ex[3], ey[3], e[3];
    e[0] = tl_bilinear_slope(0, q0, ex[0], ey[0]);
    e[1] = tl_bilinear_slope(0, q1, ex[1], ey[1]);
    e[2] = tl_bilinear_slope(0, q2, ex[2], ey[2]);
    if (TL_GUIDE_WEIGHT != 0.0) {
        g0 = vec4(e[0].a, ex[0].a, ey[0].a, 0.0);
        g1 = vec4(e[1].a, ex[1].a, ey[1].a, 0.0);
        g2 = vec4(e[2].a, ex[2].a, ey[2].a, 0.0);
    }
    // the largest guide value and its gradient (the first of equals: ties are a null set)
    vec4 gm = g0;
    if (g1.x > gm.x) gm = g1;
    if (g2.x > gm.x) gm = g2;
    float k0 = tl_sharpened(w0, g0.x - gm.x);
    float k1 = tl_sharpened(w1, g1.x - gm.x);
    float k2 = tl_sharpened(w2, g2.x - gm.x);
    float km = max(k0, max(k1, k2)) * TL_CUTOFF;
    if (k0 < km) k0 = 0.0;
    if (k1 < km) k1 = 0.0;
    if (k2 < km) k2 = 0.0;
    vec2 dk0 = tl_weight_slope(k0, w0, dw0, g0, gm);
    vec2 dk1 = tl_weight_slope(k1, w1, dw1, g1, gm);
    vec2 dk2 = tl_weight_slope(k2, w2, dw2, g2, gm);
    float total = k0 + k1 + k2;
    vec2 dtotal = dk0 + dk1 + dk2;
    // the value, as tiling_blend_at computes it (normalised weights)
    float n0 = k0 / total, n1 = k1 / total, n2 = k2 / total;
    vec3 acc = vec3(0.0);
    vec3 macc = vec3(0.0);
    if (n0 > 0.0) tl_patch_term(q0, n0, acc, macc);
    if (n1 > 0.0) tl_patch_term(q1, n1, acc, macc);
    if (n2 > 0.0) tl_patch_term(q2, n2, acc, macc);
    if (TL_VARIANCE_PRESERVING) acc = acc / sqrt(n0 * n0 + n1 * n1 + n2 * n2);
    // the residuals r_i and their gradients, the lattice mean's m_i
    vec3 r[3], rx[3], ry[3], m[3], mx[3], my[3];
    vec2 qs[3] = vec2[3](q0, q1, q2);
    for (int i = 0; i < 3; i++) {
        m[i] = TL_MEAN;
        mx[i] = vec3(0.0);
        my[i] = vec3(0.0);
        if (TL_RANK != 0) {
            vec4 gx, gy;
            m[i] = tl_bilinear_slope(1, qs[i], gx, gy).rgb;
            mx[i] = gx.rgb;
            my[i] = gy.rgb;
        }
        r[i] = e[i].rgb - m[i];
        rx[i] = ex[i].rgb - mx[i];
        ry[i] = ey[i].rgb - my[i];
    }
    float norm = total;
    vec2 dnorm = dtotal;
    if (TL_VARIANCE_PRESERVING) {
        norm = sqrt(k0 * k0 + k1 * k1 + k2 * k2);
        dnorm = (dk0 * k0 + dk1 * k1 + dk2 * k2) / norm;
    }
    vec3 R = (r[0] * k0 + r[1] * k1 + r[2] * k2) / norm;
    dx = (r[0] * dk0.x + r[1] * dk1.x + r[2] * dk2.x + rx[0] * k0 + rx[1] * k1 + rx[2] * k2 - R * dnorm.x) / norm;
    dy = (r[0] * dk0.y + r[1] * dk1.y + r[2] * dk2.y + ry[0] * k0 + ry[1] * k1 + ry[2] * k2 - R * dnorm.y) / norm;
    if (TL_RANK == 0) return TL_MEAN + acc;
    vec3 M = (m[0] * k0 + m[1] * k1 + m[2] * k2) / total;
    dx += (m[0] * dk0.x + m[1] * dk1.x + m[2] * dk2.x + mx[0] * k0 + mx[1] * k1 + mx[2] * k2 - M * dtotal.x) / total;
    dy += (m[0] * dk0.y + m[1] * dk1.y + m[2] * dk2.y + my[0] * k0 + my[1] * k1 + my[2] * k2 - M * dtotal.y) / total;
    return macc + acc;
}

float tl_table_slope(int c, float g) {
    // the slope of tl_table's linear segment at g; 0 where the table clamps
    float k = float(TL_LUT_SIZE - 1);
    float per = k / (2.0 * TL_GAUSS_RANGE);
    float pos = (g + TL_GAUSS_RANGE) * per;
    if (!(pos >= 0.0 && pos <= k)) return 0.0;
    int i0 = min(int(pos), TL_LUT_SIZE - 2);
    return (texelFetch(tiling_colours, ivec2(i0 + 1, 0), 0)[c] - texelFetch(tiling_colours, ivec2(i0, 0), 0)[c]) * per;
}

vec3 tiling_colour_grad(vec3 v, inout vec3 dx, inout vec3 dy) {
    // tiling_colour(v), and the gradient (dx, dy) of v through the tables' derivative:
    // ∂colour_r = Σ_c P[r][c] T_c'(g_c) / σ_c ∂v_c
    if (!TL_HISTOGRAM) return v;
    vec3 sx = vec3(0.0);
    vec3 sy = vec3(0.0);
    for (int c = 0; c < TL_CHANNELS; c++) {
        float t = tl_table_slope(c, (v[c] - TL_NOISE_MEAN[c]) / TL_NOISE_STD[c]) / TL_NOISE_STD[c];
        sx[c] = t * dx[c];
        sy[c] = t * dy[c];
    }
    for (int r = 0; r < TL_CHANNELS; r++) {
        float ax = 0.0;
        float ay = 0.0;
        for (int c = 0; c < TL_CHANNELS; c++) {
            ax += sx[c] * TL_COLOUR_MATRIX[r][c];
            ay += sy[c] * TL_COLOUR_MATRIX[r][c];
        }
        dx[r] = ax;
        dy[r] = ay;
    }
    return tiling_colour(v);
}

vec3 tiling_blend_grad_at(ivec2 anchor, vec2 frac, vec2 rel, out vec3 dx, out vec3 dy) {
    return tiling_blend_grad_at(anchor, ivec2(0), frac, rel, dx, dy);
}

vec3 tiling_blend_grad(vec2 x, out vec3 dx, out vec3 dy) {
    return tiling_blend_grad_at(ivec2(0), ivec2(0), vec2(0.0), x, dx, dy);
}

vec3 tiling_noise_grad_at(ivec2 anchor, ivec2 anchor_mod, vec2 frac, vec2 rel, out vec3 dx, out vec3 dy) {
    vec3 v = tiling_blend_grad_at(anchor, anchor_mod, frac, rel, dx, dy);
    return tiling_colour_grad(v, dx, dy);
}

vec3 tiling_noise_grad_at(ivec2 anchor, vec2 frac, vec2 rel, out vec3 dx, out vec3 dy) {
    vec3 v = tiling_blend_grad_at(anchor, frac, rel, dx, dy);
    return tiling_colour_grad(v, dx, dy);
}

vec3 tiling_noise_grad(vec2 x, out vec3 dx, out vec3 dy) {
    vec3 v = tiling_blend_grad(x, dx, dy);
    return tiling_colour_grad(v, dx, dy);
}
