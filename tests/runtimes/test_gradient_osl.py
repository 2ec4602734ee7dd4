"""The OSL exports' relief outputs in their real client: Blender's Cycles compiles the plane
shaders (``texton_plane``, ``tiling_plane``) and renders their ``GradientX``, ``GradientY``,
``NormalMap`` and ``BumpNormal`` outputs, which equal ``gradient`` (and the normals made of it)
at the points the pixel centres see.

The bound is the value exports' (tests/runtimes/test_shader_osl.py): 99.9 % of the pixels within
10⁻³ of the range. As in that file's exact-point tests, each shader is evaluated at its pixel's
centre (a float32 number here and in the shader), so the render differs from the kernels by float
rounding only; a texton's one-sided slope (order 1, a bilinear example) can differ where float32
rounding puts a point on the other side of a kink, which the 0.1 % allows.
"""

from __future__ import annotations

import numpy as np
import pytest

from test_shader_osl import EXACT_PIXELS, EXACT_TEXEL, MIN_AGREEMENT, TOLERANCE, exact_point_source, plane_mesh, render
from test_tiling_osl import bond_lattice, brick, courses, preserving, wrapped
from warp_texton import Texton, analyze, gradient, read_image
from warp_texton.demo import demo_texture_path
from warp_texton.model.tiling import TilingModel
from warp_texton.runtimes.osl import texton as osl_texton
from warp_texton.runtimes.osl import tiling as osl_tiling

pytestmark = pytest.mark.slow
SIZE = 96
RELIEF = ("GradientX", "GradientY", "NormalMap", "BumpNormal")


def random_texton(channels: int, order: int, size: int = 8, seed: int = 0) -> Texton:
    rng = np.random.default_rng(seed)
    return Texton(rng.standard_normal((size, size, channels)) / size, rng.uniform(0.3, 0.6, channels), order)


def luminance_std(model) -> float:
    """The standard deviation of the luminance (the channel mean) the shaders standardise the height by."""
    c = model.channels
    w = np.full(c, 1.0 / c)
    return float(np.sqrt(w @ np.atleast_2d(model.covariance()) @ w))


def expected(model, grad: np.ndarray, strength: float) -> dict[str, np.ndarray]:
    """The relief outputs at points of (N, C, 2) gradients, (N, 3) each: the gradients per channel
    (grey: in every component), the tangent-space normal map (n + 1) / 2 and the normal itself (the
    plane faces +z, its object space the world's: the bent normal is the tangent-space one)."""
    c = model.channels
    gx, gy = grad[..., 0].astype(np.float64), grad[..., 1].astype(np.float64)
    if c == 1:
        gx, gy = np.repeat(gx, 3, axis=1), np.repeat(gy, 3, axis=1)
    k = strength / luminance_std(model)
    n = np.stack([-k * grad[..., 0].mean(axis=1), k * grad[..., 1].mean(axis=1), np.ones(len(grad))], axis=-1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return {"GradientX": gx, "GradientY": gy, "NormalMap": 0.5 * n + 0.5, "BumpNormal": n}


#: (name, model, export keywords, the node's strength): texton noise of orders 1 (PTRS counts), 3
#: (grey, a period), 5 (the node's mni set: λ from OSL's arithmetic), a histogram-preserving texton;
#: tiling models plain, guided with the linear blend, histogram-preserving, read wrapped, on 2-D
#: lattices (wrapped and clamped) and on courses.
def cases():
    hist = analyze(read_image(demo_texture_path()), size=16, order=3, seed=0, histogram="preserve")
    return [
        ("order1", random_texton(3, 1, seed=4), dict(mni=30.0, seed=9), 1.0),
        ("order3_period", random_texton(1, 3, seed=5), dict(mni=20.0, seed=2**31 + 5, period=(24.0, 40.0)), 2.0),
        ("order5_node_mni", random_texton(3, 5, seed=6), dict(mni=30.0, seed=3), 1.0),
        ("histogram", hist, dict(mni=30.0, seed=4), 1.0),
        ("tiling", TilingModel(brick(1), 32.0, 16, 0.0, {}, "variance"), dict(seed=5), 1.0),
        ("tiling_guide", TilingModel(brick(3), 21.7, 4, 2.0, {}, "linear"), dict(seed=6), 2.0),
        ("tiling_hist", preserving(3), dict(seed=7), 1.0),
        ("tiling_wrapped", wrapped(), dict(seed=8), 1.0),
        ("tiling_lattice", bond_lattice(), dict(seed=2**31 + 3), 1.0),
        ("tiling_lattice_clamped", bond_lattice(clamped=True), dict(seed=10), 1.0),
        ("tiling_courses", courses(), dict(seed=11), 1.0),
    ]


def plane_source(model, kw: dict) -> str:
    if isinstance(model, TilingModel):
        source = osl_tiling.tiling_osl_files(model, kw["seed"], EXACT_TEXEL)[osl_tiling.OSL_FILE]
    else:
        source = osl_texton.osl_files(model, texel_size=EXACT_TEXEL, **kw)[osl_texton.PLANE_FILE]
    return exact_point_source(source.decode(), "plane")


def test_relief_outputs_equal_gradient(tmp_path):
    jobs, checks = [], []
    c = ((np.arange(SIZE) - SIZE // 2 + 0.5) / EXACT_PIXELS).astype(np.float32)
    sx, sy = np.meshgrid(c, c[::-1])
    pts = np.stack([sx / np.float32(EXACT_TEXEL), -sy / np.float32(EXACT_TEXEL)], -1).reshape(-1, 2)
    for n, (name, model, kw, strength) in enumerate(cases()):
        osl = tmp_path / f"relief_{n}.osl"
        osl.write_text(plane_source(model, kw))
        inputs = {"strength": strength}
        if name.endswith("node_mni"):  # the node's mni, not the export's
            inputs["mni"] = 40.0
            kw = {**kw, "mni": 40.0}
        grad = gradient(model, pts.astype(np.float64), device="cpu", **kw)
        want = expected(model, grad, strength)
        for output in RELIEF:
            jobs.append({"osl": str(osl), "ortho_scale": SIZE / EXACT_PIXELS, "width": SIZE, "height": SIZE,
                         "output": output, "inputs": inputs, **plane_mesh(1.0)})
            checks.append((name, output, want[output].reshape(SIZE, SIZE, 3)))
    failed = []
    for (name, output, want), rep in zip(checks, render(tmp_path, jobs)):
        got = rep["rgba"][..., :3]
        assert (rep["rgba"][..., 3] == 1.0).all()
        span = float(want.max() - want.min())
        err = np.abs(got - want).max(axis=-1) / span
        fraction = float(np.mean(err <= TOLERANCE))
        print(f"{name} {output}: {fraction:.5f} of the pixels within {TOLERANCE:g} of the range {span:.3g}, "
              f"max {err.max():.2e}, median {np.median(err):.1e}; compile {rep['compile_s']:.2f} s")
        assert span > 0.0
        if fraction < MIN_AGREEMENT:
            failed.append(f"{name} {output}: {fraction:.5f}")
    assert not failed, failed


#: UV units per texel in the UV test (a power of two: the points are float32 numbers here and there).
UV_TEXEL = 1.0 / 32.0
UV_SNAP = """        point p_uv = transform("object", P);
        // the pixel's centre, whatever point of the pixel the camera's jittered ray hit, and its UVs
        float u_ = ((floor(p_uv[0] * 64.0) + 0.5) / 64.0 + 1.0) * 0.5;
        float v_ = ((floor(p_uv[1] * 64.0) + 0.5) / 64.0 + 1.0) * 0.5;
        x0 = u_ / texel_size;
        x1 = (1.0 - v_) / texel_size;
"""


def exact_uv_source(source: str) -> str:
    """The plane shader in its UV mode evaluated at its pixel's centre (the plane's UVs there: (x + 1) / 2,
    (y + 1) / 2); the UVs' derivatives, which give BumpNormal its tangent frame, are the renderer's."""
    old = "        x0 = Vector[0] / texel_size;\n        x1 = (1.0 - Vector[1]) / texel_size;\n"
    assert source.count(old) == 1
    return source.replace(old, UV_SNAP)


def test_relief_outputs_on_uvs(tmp_path):
    """With ``coordinates = "input"`` (UVs) the outputs are those of the noise at the UVs' texel coordinates,
    and BumpNormal is bent in the UVs' tangent frame, made of the ray differentials (on the plane: +u along
    +x, +v along +y, so the tangent-space normal itself)."""
    c = ((np.arange(SIZE) - SIZE // 2 + 0.5) / EXACT_PIXELS).astype(np.float32)
    sx, sy = np.meshgrid(c, c[::-1])
    u, v = (sx + np.float32(1.0)) * np.float32(0.5), (sy + np.float32(1.0)) * np.float32(0.5)
    pts = np.stack([u / np.float32(UV_TEXEL), (np.float32(1.0) - v) / np.float32(UV_TEXEL)], -1).reshape(-1, 2)
    jobs, checks = [], []
    models = [("order3", random_texton(3, 3, seed=7), dict(mni=30.0, seed=2)),
              ("tiling_guide", TilingModel(brick(3), 21.7, 4, 2.0, {}, "linear"), dict(seed=6))]
    for n, (name, model, kw) in enumerate(models):
        if isinstance(model, TilingModel):
            source = osl_tiling.tiling_osl_files(model, kw["seed"], UV_TEXEL)[osl_tiling.OSL_FILE]
        else:
            source = osl_texton.osl_files(model, texel_size=UV_TEXEL, **kw)[osl_texton.PLANE_FILE]
        osl = tmp_path / f"uv_{n}.osl"
        osl.write_text(exact_uv_source(source.decode()))
        want = expected(model, gradient(model, pts.astype(np.float64), device="cpu", **kw), 1.5)
        for output in ("GradientX", "BumpNormal"):
            jobs.append({"osl": str(osl), "ortho_scale": SIZE / EXACT_PIXELS, "width": SIZE, "height": SIZE,
                         "output": output, "inputs": {"strength": 1.5, "coordinates": "input"},
                         "uv_input": "Vector", **plane_mesh(1.0)})
            checks.append((name, output, want[output].reshape(SIZE, SIZE, 3)))
    for (name, output, want), rep in zip(checks, render(tmp_path, jobs)):
        err = np.abs(rep["rgba"][..., :3] - want).max(axis=-1) / float(want.max() - want.min())
        print(f"UVs, {name} {output}: {np.mean(err <= TOLERANCE):.5f} within {TOLERANCE:g} of the range, "
              f"max {err.max():.2e}")
        assert np.mean(err <= TOLERANCE) >= MIN_AGREEMENT, (name, output)


#: Renders the plane lit by a sun (Cycles, a diffuse BSDF, no bounces) with the shading normal left flat,
#: set to the script node's BumpNormal, or made by Blender's Bump node from its Height
#: (argv: the .osl file, the Bump node's distance, the output folder).
LIT_SCENE = """
import math, sys
import bpy, cycles.osl
osl, distance, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
for variant in ("flat", "bump_normal", "bump_node"):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.shading_system = True
    sc.cycles.samples = 1
    sc.cycles.use_denoising = False
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.pixel_filter_type = "BOX"
    sc.cycles.filter_width = 0.01
    sc.cycles.max_bounces = 0
    sc.render.resolution_x = sc.render.resolution_y = 96
    sc.view_settings.view_transform = "Standard"
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    me = bpy.data.meshes.new("plane")
    me.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    uv = me.uv_layers.new(name="UVMap")
    for loop in me.loops:
        x, y, _ = me.vertices[loop.vertex_index].co
        uv.data[loop.index].uv = ((x + 1.0) / 2.0, (y + 1.0) / 2.0)
    ob = bpy.data.objects.new("plane", me)
    sc.collection.objects.link(ob)
    mat = bpy.data.materials.new("lit")
    nt = mat.node_tree
    nt.nodes.clear()
    node = nt.nodes.new("ShaderNodeScript")
    node.mode = "EXTERNAL"
    node.filepath = osl
    assert cycles.osl.update_script_node(node, lambda *a: None)
    # the UVs through the Vector input: a Texture Coordinate node, whose outputs Blender's bump offsets
    node.inputs["coordinates"].default_value = "input"
    nt.links.new(nt.nodes.new("ShaderNodeTexCoord").outputs["UV"], node.inputs["Vector"])
    bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    if variant == "bump_normal":
        nt.links.new(node.outputs["BumpNormal"], bsdf.inputs["Normal"])
    elif variant == "bump_node":
        bump = nt.nodes.new("ShaderNodeBump")
        bump.inputs["Strength"].default_value = 1.0
        bump.inputs["Distance"].default_value = distance
        nt.links.new(node.outputs["Height"], bump.inputs["Height"])
        nt.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    output = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    me.materials.append(mat)
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 3.0
    sun.angle = 0.0
    sun_ob = bpy.data.objects.new("sun", sun)
    sun_ob.rotation_euler = (math.radians(50.0), 0.0, math.radians(30.0))
    sc.collection.objects.link(sun_ob)
    cam = bpy.data.cameras.new("cam")
    cam.type = "ORTHO"
    cam.ortho_scale = 1.8
    cam_ob = bpy.data.objects.new("cam", cam)
    cam_ob.location = (0.0, 0.0, 10.0)
    sc.collection.objects.link(cam_ob)
    sc.camera = cam_ob
    sc.render.filepath = f"{out}/{variant}.exr"
    bpy.ops.render.render(write_still=True)
"""


def test_bump_normal_shades_a_lit_plane(tmp_path):
    """In a Cycles render lit by a sun, BumpNormal on a diffuse BSDF's Normal shades the flat plane with
    the relief (the flat normal shades it evenly), and Blender's own Bump node fed the Height output with
    the same height scale (its distance strength · texel size in world units / σ_L) shades it alike: its
    finite differences over the ray differentials against the shader's exact gradient. The coordinates
    come through the Vector input (UVs from a Texture Coordinate node), whose outputs Blender's bump
    offsets; a script that reads P itself (coordinates "object") is not offset, and gives the Bump node a
    flat height (docs/renderers.md)."""
    import OpenEXR

    from clients import run_blender

    model = random_texton(3, 3, seed=8)
    texel = 0.04  # UV units a texel: 0.08 world units, about four pixels
    (tmp_path / "plane.osl").write_bytes(osl_texton.osl_files(model, mni=30.0, seed=1, texel_size=texel)[
        osl_texton.PLANE_FILE])
    run_blender(LIT_SCENE, str(tmp_path / "plane.osl"), str(2.0 * texel / luminance_std(model)), str(tmp_path),
                timeout=600)
    img = {v: OpenEXR.File(str(tmp_path / f"{v}.exr")).channels()["RGBA"].pixels[..., 0].astype(np.float64)
           for v in ("flat", "bump_normal", "bump_node")}
    flat, ours, node = img["flat"], img["bump_normal"], img["bump_node"]
    corr = float(np.corrcoef(ours.ravel(), node.ravel())[0, 1])
    print(f"lit plane: flat {flat.mean():.4f} ± {flat.std():.1e}, BumpNormal {ours.mean():.4f} ± {ours.std():.3f}, "
          f"Bump node {node.mean():.4f} ± {node.std():.3f}; correlation {corr:.4f}")
    assert flat.mean() > 0.1 and flat.std() < 1e-4 * flat.mean()
    assert ours.std() > 0.05 * flat.mean()  # not flat: the relief shades it
    assert corr > 0.99
