"""Render OSL Script nodes with Cycles (run by Blender's Python through clients.run_blender).

Argument: a JSON file listing renders. Each render: an .osl file ("osl") loaded
as an internal text block or as an external file ("mode"), the node's inputs to
set ("inputs"), the one to link the UVs to ("uv_input") and the output to show
("output", default "Color"), a mesh from .npy files ("vertices", "faces", optional per-vertex
"uvs"; flat shaded, or smooth with "smooth") at the origin; Blender's vertex
normals are saved beside the render, seen by an orthographic camera looking down
−z at ("centre", default the origin) with a view "ortho_scale" wide, "width" × "height" pixels, written as a float32 EXR ("out").
Emission only, one sample, a box pixel filter of the smallest width, the
Standard view transform with no look: the pixels hold the shader's values.
This script runs in Blender's interpreter and imports nothing of warp_texton;
``bpy`` is imported inside the functions, so that the suite's collection can
import the file without Blender.
"""

import json
import sys
import time
from pathlib import Path

import numpy as np


def scene_settings(sc, width, height):
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.shading_system = True  # OSL
    sc.cycles.samples = 1
    sc.cycles.use_denoising = False
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.pixel_filter_type = "BOX"
    sc.cycles.filter_width = 0.01
    sc.cycles.max_bounces = 0
    sc.render.film_transparent = True
    sc.render.resolution_x = width
    sc.render.resolution_y = height
    sc.render.resolution_percentage = 100
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.render.image_settings.exr_codec = "ZIP"


def script_node(nt, job, messages):
    import bpy
    import cycles.osl

    node = nt.nodes.new("ShaderNodeScript")
    path = Path(job["osl"])
    if job.get("mode", "internal") == "internal":
        text = bpy.data.texts.new(path.name)
        text.write(path.read_text())
        node.mode = "INTERNAL"
        node.script = text
    else:
        node.mode = "EXTERNAL"
        node.filepath = str(path)
    ok = cycles.osl.update_script_node(node, lambda kind, msg: messages.append(f"{sorted(kind)} {msg}"))
    if not ok or "Color" not in node.outputs:
        raise SystemExit(f"OSL compilation failed: {messages}")
    for name, value in job.get("inputs", {}).items():
        node.inputs[name].default_value = value
    if "uv_input" in job:
        coords = nt.nodes.new("ShaderNodeTexCoord")
        nt.links.new(coords.outputs["UV"], node.inputs[job["uv_input"]])
    return node


def mesh_object(job):
    import bpy

    verts = np.load(job["vertices"])
    faces = np.load(job["faces"])
    me = bpy.data.meshes.new("m")
    me.from_pydata([tuple(map(float, v)) for v in verts], [], [tuple(map(int, f)) for f in faces])
    if job.get("smooth"):
        me.shade_smooth()
    else:
        me.shade_flat()
    if "uvs" in job:
        uvs = np.load(job["uvs"])
        layer = me.uv_layers.new(name="UVMap")
        for loop in me.loops:
            layer.data[loop.index].uv = tuple(map(float, uvs[loop.vertex_index]))
    me.update()
    # the vertex normals Blender computed (those Cycles interpolates on smooth faces)
    normals = np.array([tuple(v.normal) for v in me.vertices], np.float32)
    np.save(job["out"] + ".normals.npy", normals)
    ob = bpy.data.objects.new("m", me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def render(job):
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    scene_settings(sc, job["width"], job["height"])
    ob = mesh_object(job)
    mat = bpy.data.materials.new("osl")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    messages = []
    t0 = time.perf_counter()
    node = script_node(nt, job, messages)
    compiled = time.perf_counter() - t0
    emission = nt.nodes.new("ShaderNodeEmission")
    output = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(node.outputs[job.get("output", "Color")], emission.inputs["Color"])
    nt.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    ob.data.materials.append(mat)
    cam = bpy.data.cameras.new("cam")
    cam.type = "ORTHO"
    cam.ortho_scale = job["ortho_scale"]
    cam_ob = bpy.data.objects.new("cam", cam)
    cx, cy = job.get("centre", (0.0, 0.0))
    cam_ob.location = (cx, cy, 10.0)
    sc.collection.objects.link(cam_ob)
    sc.camera = cam_ob
    sc.render.filepath = job["out"]
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return {"compile_s": compiled, "render_s": time.perf_counter() - t0, "messages": messages}


def main():
    spec = json.loads(Path(sys.argv[1]).read_text())
    report = [render(job) for job in spec["renders"]]
    Path(spec["report"]).write_text(json.dumps(report))


if __name__ == "__main__":  # Blender runs it; pytest's doctest collection only imports it
    main()
