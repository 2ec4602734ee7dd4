"""Texton noise as OSL shaders (Blender Cycles, Arnold, RenderMan, V-Ray).

:func:`osl_files` writes two Open Shading Language sources from one template
(``warp_texton/runtimes/shaders/texton_noise.osl``, its placeholders ``$NAME`` filled here):

* ``texton_surface.osl``: surface noise (CGF §6) at the shading point, from
  ``P`` and ``N`` alone, no UVs: the walk of ``kernels/surface_points.py``
  (``surface_value``: the frame rule, the cubes of ``cube_span``, the slab
  weight, CGF Prop. 3's normalisation);
* ``texton_plane.osl``: plane noise (``evaluate``: ``kernels/noise_raster.py``,
  ``evaluate_points``) at a texel-space point made from the UVs or from the
  object-space x, y, with its exact gradient (``kernels/noise_gradient.py``
  ``plane_slope``) and the relief made of it: the outputs ``GradientX``,
  ``GradientY``, ``Height``, ``NormalMap`` and ``BumpNormal`` (:func:`relief_code`,
  shared with tiling models' shader).

Both draw the impacts of ``kernels/impacts.py`` in its order (the cell hash
``avalanche``/``cell_state``/``cell_state3``, Warp's PCG ``rand_pcg``,
``randf``, ``randn`` and ``wp.poisson``: Knuth's product method below a mean of
10, Hörmann's PTRS with ``random_loggam`` above) in OSL's 32-bit ``int``, which
wraps on ``+``, ``-`` and ``*`` as ``uint32`` does; ``>>`` is arithmetic in OSL,
so the logical shifts mask the high bits. The constants (cell sizes, the
support box, λ, the Poisson sampler's per-noise constants, the CGF Prop. 3
shift and scale) come from the host code the kernels use
(:func:`~warp_texton.noise.engine.noise_setup`, :func:`~warp_texton.noise.engine.params_record`,
:func:`~warp_texton.surface.points.surface_setup`, :func:`~warp_texton.surface.points.surface_params`),
and the transcendental ones from Warp's own CPU builtins, so they are the
kernels' float32 values. The texton's padded coefficients are embedded as a
constant array (see docs/renderers.md for why, and the limit
:data:`MAX_EMBEDDED_FLOATS`).

What OSL cannot do as the kernels do: it has no float64, so cells are found
and offsets taken in float32 (the shading point arrives in float32 anyway);
near the origin this changes values by float rounding only, far from it the
offsets lose precision (docs/renderers.md gives the range).

Kernels driven here: ``warp_texton.kernels.noise_raster``.
"""

from __future__ import annotations

import functools
import json
import math
from string import Template

import numpy as np

from ..._version import __version__
from ...model.noise_tables import at_mni
from ...core.checks import check_positive
from ...core.runtime import init_warp
from ...core.errors import TextonError
from ...surface.frames import UP
from ...noise.colours import noise_moments
from ...model.histogram import GAUSS_RANGE
from ...kernels.noise_raster import PAD
from ...noise.engine import CELL_FACTOR, noise_setup, params_record
from ...noise.noise_options import NoiseOptions
from ...surface.points import surface_params, surface_setup
from ...model.texton import Texton
from ...model.tiling import TilingModel
from ..shared import template

#: Floats of padded coefficients a shader embeds at most: a 256 × 256 RGB texton
#: with its margin (a 4.7 MB source, which Blender compiles in about 2 s; the
#: default 64 × 64 of ``analyze`` takes 0.25 s: docs/renderers.md).
MAX_EMBEDDED_FLOATS = (256 + 2 * PAD) ** 2 * 3
#: The files :func:`osl_files` returns.
SURFACE_FILE = "texton_surface.osl"
PLANE_FILE = "texton_plane.osl"
#: The description of an OSL export (either model kind), whose "warp_texton" key marks the folder as an export.
META_FILE = "texton_noise_osl.json"
#: Every file a texton's OSL export may write.
FILES = frozenset({SURFACE_FILE, PLANE_FILE, META_FILE})
#: The one template both shaders are made from (package data).
TEMPLATE = "texton_noise.osl"


#: The float literals of warp/native/rand.h's Poisson sampler and ``randn``, as C reads
#: them (float32; each decimal rounds to the same float32 directly or through float64).
RAND_H = {
    "LG0": "8.333333333333333e-02", "LG1": "-2.777777777777778e-03", "LG2": "7.936507936507937e-04",
    "LG3": "-5.952380952380952e-04", "LG4": "8.417508417508418e-04", "LG5": "-1.917526917526918e-03",
    "LG6": "6.410256410256410e-03", "LG7": "-2.955065359477124e-02", "LG8": "1.796443723688307e-01",
    "LG9": "-1.39243221690590e+00", "RANDN_EPS": "5.96e-8", "B0": "0.931", "B1": "2.53", "A0": "-0.059",
    "A1": "0.02483", "IA0": "1.1239", "IA1": "1.1328", "IA2": "3.4", "VR0": "0.9277", "VR1": "3.6224",
    "US_ACCEPT": "0.07", "US_REJECT": "0.013", "K_SHIFT": "0.43",
}
F = {k: np.float32(float(v)) for k, v in RAND_H.items()}
#: 0.5f * lg2pi and 2.f * M_PI_F, products C evaluates in float32
DERIVED = {"HALF_LG2PI": np.float32(0.5) * np.float32(1.8378770664093453),
           "TWO_PI": np.float32(2.0) * np.float32(3.14159265358979323846)}


def i32(v: int) -> int:
    """An unsigned 32-bit constant as the signed ``int`` OSL holds (the same bits)."""
    v &= 0xFFFFFFFF
    return v - (1 << 32) if v >= 1 << 31 else v


def f32(v) -> str:
    """A float32 value as an OSL literal that parses back to exactly that value."""
    x = float(np.float32(v))
    if not math.isfinite(x):
        raise TextonError(f"a shader constant is not finite ({x}); the texton or options overflow float32")
    s = repr(x)
    return s if ("e" in s or "." in s) else s + ".0"


def counts_constants(mean) -> dict[str, str]:
    """The per-noise constants of ``wp.poisson`` (warp/native/rand.h) for a cell mean,
    with Warp's CPU sqrt, log and exp, so a shader's samplers compare against the
    kernels' values: exp(−mean) for the product method, PTRS's slam, log λ, a, b,
    vr and log(1/α)."""
    wp = init_warp()
    lam = np.float32(mean)
    f = np.float32
    slam = f(wp.sqrt(wp.float32(lam)))
    b = F["B0"] + F["B1"] * slam
    a = F["A0"] + F["A1"] * b
    invalpha = F["IA0"] + F["IA1"] / (b - F["IA2"])
    vr = F["VR0"] - F["VR1"] / (b - f(2.0))
    return {
        "mean": f32(lam), "enlam": f32(wp.exp(wp.float32(-lam))), "slam": f32(slam),
        "loglam": f32(wp.log(wp.float32(lam))), "a": f32(a), "b": f32(b),
        "log_invalpha": f32(wp.log(wp.float32(invalpha))), "vr": f32(vr),
    }


def coefficient_array(coeffs: np.ndarray, channels: int) -> str:
    """The padded coefficients (rows, cols, 3) as an OSL initialiser, row-major, ``channels`` per texel."""
    flat = coeffs[:, :, :channels].reshape(-1)
    lines = []
    for start in range(0, flat.size, 8):
        lines.append("        " + ", ".join(f32(v) for v in flat[start:start + 8]))
    return ",\n".join(lines)


def colour_map_code(texton: Texton | TilingModel, slopes: bool = False) -> str:
    """The statements that map the noise value g to the example's colours through the
    texton's histogram transform, as kernels/noise_colours.py ``colour_value`` does (the
    unfiltered table, embedded; float32 arithmetic in the same order); none without one.
    ``slopes``: the gradient (gx, gy) of g is mapped too, through the tables' slopes
    (:func:`colour_slope_code`), before g is."""
    tr = texton.histogram
    if tr is None:
        return ""
    c = texton.channels
    k = tr.lut.shape[1]
    mean, std = noise_moments(texton)
    lut = "\n".join("        " + ", ".join(f32(v) for v in row) + ","
                     for row in np.asarray(tr.lut, np.float32).reshape(-1, 8))
    per = f32(np.float32(k - 1) / (np.float32(2.0) * np.float32(GAUSS_RANGE)))
    mix = "\n".join(f"    g[{r}] = " + f32(tr.centre[r]) + "".join(f" + z[{q}] * {f32(tr.matrix[q, r])}" for q in range(c))
                     + ";" for r in range(c))
    return f"""    // the histogram transform: the example's colours (kernels/noise_colours.py colour_value)
    float L[{c * k}] = {{
{lut.rstrip(",")}
    }};
    float mu[{c}] = {{{", ".join(f32(v) for v in mean)}}};
    float sd[{c}] = {{{", ".join(f32(v) for v in std)}}};
{colour_slope_code(texton) if slopes else ""}    color z = 0;
    for (int c = 0; c < {c}; c++) {{
        float gz = (g[c] - mu[c]) / sd[c];
        float pos = clamp((gz + {f32(GAUSS_RANGE)}) * {per}, 0.0, {float(k - 1):.1f});
        int i0 = min(int(pos), {k - 2});
        float t = pos - float(i0);
        z[c] = L[c * {k} + i0] * (1.0 - t) + L[c * {k} + i0 + 1] * t;
    }}
{mix}
"""


def colour_slope_code(model: Texton | TilingModel) -> str:
    """The statements that map the gradient (gx, gy) of the noise value g through the histogram
    tables' derivative, d colour_r = Σ_c P[c, r] T_c'(g_c) / σ_c dg_c (T' the slope of the table's
    linear segment, 0 where it clamps: ``noise.relief.table_slopes``), with the tables L, mu and sd
    that :func:`colour_map_code` declares."""
    tr = model.histogram
    if tr is None:
        return ""
    c = model.channels
    k = tr.lut.shape[1]
    per = f32(np.float32(k - 1) / (np.float32(2.0) * np.float32(GAUSS_RANGE)))
    mix = "\n".join(f"    {v}[{r}] = " + " + ".join(f"s{v}[{q}] * {f32(tr.matrix[q, r])}" for q in range(c)) + ";"
                     for v in ("gx", "gy") for r in range(c))
    return f"""    // the gradient through the tables: T'(g) / sd, 0 where a table clamps (docs/relief.md)
    color sgx = 0;
    color sgy = 0;
    for (int c = 0; c < {c}; c++) {{
        float pos = ((g[c] - mu[c]) / sd[c] + {f32(GAUSS_RANGE)}) * {per};
        float t = 0.0;
        if (pos >= 0.0 && pos <= {float(k - 1):.1f}) {{
            int i0 = min(int(pos), {k - 2});
            t = (L[c * {k} + i0 + 1] - L[c * {k} + i0]) * {per} / sd[c];
        }}
        sgx[c] = t * gx[c];
        sgy[c] = t * gy[c];
    }}
{mix}
"""


#: The plane shaders' relief parameters and outputs (before the shared ones).
RELIEF_PARAMETERS = """\
    float strength = 1.0,  // the relief: the height of one standard deviation of Height, in texels
    output color GradientX = 0,  // d Color / dx per channel, per texel along the noise's x (right)
    output color GradientY = 0,  // d Color / dy per channel, per texel along the noise's y (down)
    output float Height = 0,  // the luminance (channel mean) of Color: a Bump node's Height
    output color NormalMap = color(0.5, 0.5, 1.0),  // tangent space, OpenGL (green up): a Normal Map node's Color
    output normal BumpNormal = N,  // N bent by the relief (exact gradient): a BSDF's Normal
"""


def relief_code(model: Texton | TilingModel) -> dict[str, str]:
    """The plane shaders' relief (docs/relief.md, "Shaders"): the placeholders RELIEF_FUNCTIONS (the
    function ``relief``), RELIEF_PARAMETERS and RELIEF (its call, from the colour g and its gradient
    gx, gy along the noise's x and y). The height is the luminance L (the channel mean, as
    ``normal_map`` takes it) standardised by its model standard deviation (``covariance``) and
    scaled by ``strength``, in texels: the normal map is ``normal_map``'s at one pixel a texel."""
    c = model.channels
    wts = np.full(c, 1.0 / c)
    cov = np.atleast_2d(model.covariance())
    std = float(np.sqrt(max(float(wts @ cov @ wts), 1e-30)))
    luma = (lambda v: f"({v}[0] + {v}[1] + {v}[2]) / 3.0") if c == 3 else (lambda v: f"{v}[0]")
    spread = (lambda v: v) if c == 3 else (lambda v: f"color({v}[0], {v}[0], {v}[0])")
    functions = f"""// the relief outputs from the colour g and its gradient (gx, gy) along the noise's x and y (texels)
void relief(color g, color gx, color gy, string coordinates, vector Vector, float strength,
            output color GradientX, output color GradientY, output float Height, output color NormalMap,
            output normal BumpNormal)
{{
    GradientX = {spread("gx")};
    GradientY = {spread("gy")};
    Height = {luma("g")};
    // the height strength (L - mean) / sd in texels; its tangent-space normal (-dh/dx, dh/dy, 1): y down
    float k = strength / {f32(std)};
    float hx = k * {luma("gx")};
    float hy = k * {luma("gy")};
    vector nt = normalize(vector(-hx, hy, 1.0));
    NormalMap = color(0.5 * nt[0] + 0.5, 0.5 * nt[1] + 0.5, 0.5 * nt[2] + 0.5);
    BumpNormal = N;
    if (coordinates == "input") {{
        // the UVs' tangent frame from the ray differentials, dP = T_u du + T_v dv (as a Normal Map node's)
        vector dV0 = Dx(Vector);
        vector dV1 = Dy(Vector);
        vector dP0 = Dx(P);
        vector dP1 = Dy(P);
        float det = dV0[0] * dV1[1] - dV0[1] * dV1[0];
        if (det != 0.0) {{
            vector tu = (dP0 * dV1[1] - dP1 * dV0[1]) / det;
            vector tv = (dP1 * dV0[0] - dP0 * dV1[0]) / det;
            vector t = tu - N * dot(N, tu);
            if (length(t) > 0.0) {{
                t = normalize(t);
                vector b = cross(N, t);
                if (dot(b, tv) < 0.0)
                    b = -b;
                BumpNormal = normalize(nt[0] * t + nt[1] * b + nt[2] * N);
            }}
        }}
    }} else {{
        // the height's gradient in the coordinates' space, (dh/dx, -dh/dy, 0) per unit (x = q[0] / texel,
        // y = -q[1] / texel), is a covector: transformed as a normal; N less its tangential part
        normal G = transform(coordinates, "common", normal(hx, -hy, 0.0));
        BumpNormal = normalize(N - (G - N * dot(N, G)));
    }}
}}
"""
    call = ("    relief(g, gx, gy, coordinates, Vector, strength, GradientX, GradientY, Height, NormalMap, "
            "BumpNormal);\n")
    return {"RELIEF_FUNCTIONS": functions, "RELIEF_PARAMETERS": RELIEF_PARAMETERS, "RELIEF": call}


def colour_of(channels: int) -> str:
    return "color(T[k], T[k + 1], T[k + 2])" if channels == 3 else "color(T[k], 0.0, 0.0)"


def osl_files(
    texton: Texton,
    *,
    mni: float = 30.0,
    seed: int = 0,
    period=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    texel_size: float = 0.01,
    up=UP,
    side=None,
    noise: NoiseOptions | None = None,
) -> dict[str, bytes]:
    """OSL sources of texton noise: a surface shader (P, N) and a plane/UV shader.

    Parameters
    ----------
    texton : Texton
        Its padded coefficients are embedded in both shaders (at most
        ``MAX_EMBEDDED_FLOATS`` floats: a 256 × 256 RGB texton).
    mni : float
        The default of both shaders' ``mni`` parameter (as in
        :func:`~warp_texton.evaluate`; surfaces want about 60,
        :func:`~warp_texton.surface_noise`).
    seed : int
        The default of the shaders' ``seed`` parameter, in [0, 2**32); OSL's
        ``int`` is signed, so seeds from 2**31 show as seed − 2**32.
    period : (Px, Py), optional
        The plane shader's period in texels (as in :func:`~warp_texton.evaluate`);
        fixed at export.
    poisson : {"exact", "gaussian"}
        The default of the shaders' ``exact_poisson`` parameter (1 or 0).
    cell_factor : float
        As in :func:`~warp_texton.evaluate` and :func:`~warp_texton.surface_noise`;
        fixed at export.
    texel_size : float
        The default of the shaders' ``texel_size`` parameter: coordinate units
        (object or world units, or UV units for the plane shader's UVs) per texel.
    up, side
        The surface frame rule's directions (:func:`~warp_texton.tangent_frames`);
        fixed at export.
    noise : NoiseOptions, optional
        ``mni``, ``seed``, ``period``, ``poisson`` and ``cell_factor`` as one
        value (:class:`~warp_texton.NoiseOptions`), in place of those keywords.

    Returns
    -------
    dict
        ``{"texton_surface.osl": bytes, "texton_plane.osl": bytes}``.

    Raises
    ------
    TextonError
        For a texton too large to embed, and for the options that
        :func:`~warp_texton.evaluate` and :func:`~warp_texton.surface_noise`
        refuse.

    Notes
    -----
    The shaders draw the kernels' impacts (the same hash, PCG stream and
    Poisson sampler, in integer arithmetic) and sum the same terms in the same
    order, in float32: see docs/renderers.md for what is equal and the measured
    agreement with Blender's Cycles.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton
    >>> from warp_texton.runtimes.osl.texton import osl_files
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> files = osl_files(t, mni=30, seed=7)
    >>> sorted(files)
    ['texton_plane.osl', 'texton_surface.osl']
    >>> b"shader texton_surface(" in files["texton_surface.osl"]
    True
    """
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    noise = NoiseOptions.given(noise, mni=mni, seed=seed, period=period, poisson=poisson, cell_factor=cell_factor)
    mni, seed, period, poisson, cell_factor = noise.mni, noise.seed, noise.period, noise.poisson, noise.cell_factor
    texel_size = check_positive(texel_size, "texel_size")
    setup = noise_setup(texton, mni, period, cell_factor)
    rows, cols, _ = setup.coeffs.shape
    channels = texton.channels
    if rows * cols * channels > MAX_EMBEDDED_FLOATS:
        r, s = texton.size
        raise TextonError(
            f"texton of {r} x {s} texels with {channels} channels is too large for an OSL shader: "
            f"{rows * cols * channels} floats with its margin, at most {MAX_EMBEDDED_FLOATS} (a 256 x 256 RGB texton); "
            "analyze with a smaller size", param="texton")
    rec = params_record(texton, setup, seed, poisson)
    surf = surface_setup(texton, mni, cell_factor)
    sp = surface_params(texton, surf, seed, poisson, up, side)
    common = {
        **{k: f32(v) for k, v in {**F, **DERIVED}.items()},
        "COLS": str(cols), "ROWS": str(rows), "PAD": str(PAD), "CHANNELS": str(channels), "ORDER": str(texton.order),
        "TEXEL": colour_of(channels), "COEFFS": coefficient_array(setup.coeffs, channels), "N": str(rows * cols * channels),
        "M1": str(i32(0x7FEB352D)), "M2": str(i32(0x846CA68B)), "GOLDEN": str(i32(0x9E3779B9)),
        "SPACE_TAG": str(i32(0x5BD1E995)), "PCG_MUL": str(i32(747796405)), "PCG_INC": str(i32(2891336453)),
        "PCG_OUT": str(i32(277803737)), "SEED": str(i32(seed)), "MNI": f32(setup.mni), "AREA": f32(texton.support_area),
        "TEXEL_SIZE": f32(texel_size), "EXACT": "1" if poisson == "exact" else "0",
        "VALUE": "g[0]", "COLOUR": "g" if channels == 3 else "color(g[0], g[0], g[0])",
        "MAP": colour_map_code(texton),
        "RELIEF_FUNCTIONS": "", "RELIEF": "",
    }
    cells = rec["cells"]
    # the plane's tables are those of its noise at this MNI; the surface's those the analysis
    # fitted, as surface_noise applies them (docs/histogram.md, "Tables for the MNI in use")
    plane = dict(common, **{
        "CW": f32(cells["size"][0]), "CH": f32(cells["size"][1]), "PX": str(int(cells["period"][0])),
        "PY": str(int(cells["period"][1])), "LO0": f32(rec["lo"][0]), "LO1": f32(rec["lo"][1]),
        "HI0": f32(rec["hi"][0]), "HI1": f32(rec["hi"][1]), "LAM": f32(rec["lam"]),
        "MEAN": colour_literal(rec["mean"]), "INTEGRAL": colour_literal(rec["integral"]),
        **{f"K_{k}": v for k, v in counts_constants(cells["mean_count"]).items()},
        **relief_code(texton), "MAP": colour_map_code(at_mni(texton, mni), slopes=True),
    })
    surface = dict(common, **{
        "C": f32(sp.cells.size), "HALF": f32(sp.half), "R": f32(2.0 * sp.half),
        "CENTRE0": f32(sp.centre[0]), "CENTRE1": f32(sp.centre[1]),
        "LO0": f32(sp.lo[0]), "LO1": f32(sp.lo[1]), "HI0": f32(sp.hi[0]), "HI1": f32(sp.hi[1]),
        "SHIFT": colour_literal(sp.shift), "INV_SCALE": f32(sp.inv_scale), "MEAN": colour_literal(sp.mean),
        "INTEGRAL": colour_literal(np.pad(np.asarray(texton.integral, np.float64), (0, 3 - channels))),
        "UP": vector_literal(sp.up), "SIDE": vector_literal(sp.side),
        **{f"K_{k}": v for k, v in counts_constants(sp.cells.mean_count).items()},
    })
    return {SURFACE_FILE: shader_source("surface", surface), PLANE_FILE: shader_source("plane", plane)}


@functools.cache
def template_sections() -> dict[str, str]:
    """The sections of the template (``warp_texton/runtimes/shaders/texton_noise.osl``), each
    after a line ``//@ name: ...``: the shared functions, the shared start and end
    of both shaders, and each shader's body."""
    text = template(TEMPLATE)
    sections = {}
    for part in text.split("//@ ")[1:]:
        header, _, body = part.partition("\n")
        sections[header.split(":")[0]] = body
    return sections


def shader_source(kind: str, values: dict[str, str]) -> bytes:
    """One shader's source: the shared functions and its body, the placeholders filled."""
    sec = template_sections()
    body = sec[kind].replace("$START", sec["start"]).replace("$END", sec["end"])
    return Template(sec["functions"] + body).substitute(values).encode()


def colour_literal(v) -> str:
    return f"color({f32(v[0])}, {f32(v[1])}, {f32(v[2])})"


def vector_literal(v) -> str:
    return f"vector({f32(v[0])}, {f32(v[1])}, {f32(v[2])})"


def osl_meta(texton: Texton, files: dict, noise: NoiseOptions, frame: dict, texel_size) -> bytes:
    """The description of a texton's OSL export: its files and settings, marked as the package's."""
    values = {"mni": noise.mni, "seed": noise.seed, "period": noise.period, "poisson": noise.poisson,
              "cell_factor": noise.cell_factor, **frame}
    settings = {k: (None if v is None else (v if isinstance(v, (int, float, str)) else [float(x) for x in v]))
                for k, v in values.items()}
    settings["texel_size"] = 0.01 if texel_size is None else float(texel_size)
    meta = {"warp_texton": __version__, "language": "osl", "shaders": sorted(files), "order": texton.order,
            "channels": texton.channels, "settings": settings}
    return (json.dumps(meta, indent=2) + "\n").encode()
