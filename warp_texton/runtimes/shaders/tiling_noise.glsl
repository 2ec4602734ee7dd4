#version 300 es
// Tiling and blending by example (Heitz & Neyret 2018; Mikkelsen 2022's sharpened weights),
// exported by warp-texton from a tiling model (docs/tiling.md is the specification).
//
// One source for GLSL ES 3.00 (WebGL2) and, with the first line replaced by "#version 330",
// desktop GLSL 3.30+. It reproduces kernels/noise_tiling.py tiling_value: the vertex draw
// (generated from kernels/tiling_draw.py: the hash and Warp's PCG draws in 32-bit unsigned
// arithmetic, the centre texel, the whole-texel placement, the clamp-to-edge addressing, its
// constants), the triangle, the bilinear lookups, the weights and the blend, in float32. GLSL ES has no float64: positions are taken relative to an anchor vertex of the
// triangle lattice (tiling_noise_at), so only the distance from the anchor is rounded to float32.
//
// Entry points (x in noise units: texels of the example at scale 1, y down as in the package's rasters):
//   vec3 tiling_noise(vec2 x)                                 x near the origin (|x| up to ~10^4)
//   vec3 tiling_noise_at(ivec2 anchor, vec2 frac, vec2 rel)   x = P(anchor) + rel, anywhere
//   vec3 tiling_blend(vec2 x), tiling_blend_at(...)             the blend before the histogram tables
//   vec3 tiling_colour(vec3 v)                                  the tables applied to a blended value
// where anchor = (a, b) is a lattice vertex, p(a, b) = side (a + b/2, b sqrt(3)/2) its position,
// P(a, b) = floor(p(a, b) + 1/2) that position rounded to whole texels (computed in float64 by
// the host: warp_texton.runtimes.tiling_shaders.tiling_anchor) and frac = p(a, b) - P(a, b).
// Texture (RGBA32F, read with texelFetch, no filtering): tiling_example, the example's texels
// in RGB (grey examples in R), the standardised luminance guide in A; row 0 is the example's top row.
// A histogram-preserving model (TL_HISTOGRAM) adds tiling_colours: its inverse-CDF tables (one row,
// K texels, channels in RGB), which tiling_noise* apply after the blend as kernels/noise_colours.py
// colour_value does (texton noise's tables: texton_noise.glsl, texton_colour).
precision highp float;
precision highp int;

uniform highp sampler2D tiling_example;
uniform highp sampler2D tiling_colours;

//@CONSTANTS@

//@TILING_DRAW@

ivec2 tl_centre(int a, int b) {
    // the example texel (column, row) that vertex (a, b) shows on itself: centres range over the
    // texels at least TL_MARGIN from the border
    int cx, cy;
    tl_vertex_centre(tl_seed_state(TL_SEED), a, b, TL_MARGIN, TL_COLS - 2 * TL_MARGIN, TL_MARGIN,
                     TL_ROWS - 2 * TL_MARGIN, cx, cy);
    return ivec2(cx, cy);
}

vec4 tl_texel(int i, int j) {
    return texelFetch(tiling_example, ivec2(tl_texel_index(j, TL_COLS), tl_texel_index(i, TL_ROWS)), 0);
}

vec4 tl_bilinear(vec2 q) {
    // the example (RGB) and guide (A) at q = (x, y) in texel units, clamped to its edge
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

vec2 tl_patch_point(ivec2 anchor, vec2 frac, vec2 rel, int a, int b) {
    // where vertex (a, b)'s patch reads the example: c + (x - P(a, b)), with
    // P(a, b) - P(anchor) = floor(frac + p(a - anchor.x, b - anchor.y) + 1/2) from the anchor's offsets
    float px, py;
    tl_vertex_position(frac.x, frac.y, TL_SIDE, a - anchor.x, b - anchor.y, px, py);
    return vec2(tl_centre(a, b)) + (rel - vec2(px, py));
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

vec3 tiling_blend_at(ivec2 anchor, vec2 frac, vec2 rel) {
    // the triangle: skewed coordinates of x - p(anchor), the lattice's vertices on Z^2
    vec2 d = rel - frac;
    float qx = d.x / TL_SIDE;
    float qy = d.y / TL_SIDE;
    float sy = qy / TL_SQRT3_2;
    float sx = qx - sy * 0.5;
    float fa = floor(sx);
    float fb = floor(sy);
    float u = sx - fa;
    float v = sy - fb;
    int a = anchor.x + int(fa);
    int b = anchor.y + int(fb);
    int a0 = a, b0 = b;
    float w0 = 1.0 - u - v, w1 = u, w2 = v;
    if (u + v > 1.0) {
        a0 = a + 1;
        b0 = b + 1;
        w0 = u + v - 1.0;
        w1 = 1.0 - v;
        w2 = 1.0 - u;
    }
    vec2 q0 = tl_patch_point(anchor, frac, rel, a0, b0);
    vec2 q1 = tl_patch_point(anchor, frac, rel, a + 1, b);
    vec2 q2 = tl_patch_point(anchor, frac, rel, a, b + 1);
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
    if (k0 > 0.0) acc = acc + (tl_bilinear(q0).rgb - TL_MEAN) * k0;
    if (k1 > 0.0) acc = acc + (tl_bilinear(q1).rgb - TL_MEAN) * k1;
    if (k2 > 0.0) acc = acc + (tl_bilinear(q2).rgb - TL_MEAN) * k2;
    if (TL_VARIANCE_PRESERVING) acc = acc / sqrt(k0 * k0 + k1 * k1 + k2 * k2);
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

vec3 tiling_blend(vec2 x) {
    // the anchor (0, 0): p(0, 0) = P(0, 0) = 0
    return tiling_blend_at(ivec2(0), vec2(0.0), x);
}

vec3 tiling_noise_at(ivec2 anchor, vec2 frac, vec2 rel) {
    return tiling_colour(tiling_blend_at(anchor, frac, rel));
}

vec3 tiling_noise(vec2 x) {
    return tiling_colour(tiling_blend(x));
}
