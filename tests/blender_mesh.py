"""Blender side of tests/test_clients_mesh.py: import a baked mesh, describe it, render it.

Run by ``tests.clients.run_blender`` (Blender 5's ``bpy`` in its own process):

    blender_mesh.py FORMAT MESH JSON_OUT PNG_OUT "px,py,pz" "tx,ty,tz" FOV WIDTH HEIGHT

FORMAT is "glb" (Blender's glTF importer: glTF's +Y up becomes Blender's +Z) or
"obj" (read with +Z up and +Y forward: the package's OBJ keeps the input's axes).
JSON_OUT gets the world bounding box of the imported meshes and, per material,
what feeds the Principled BSDF's Base Color (node type, image colour space and
size). PNG_OUT gets a Cycles render (CPU, one sample per pixel at the pixel's
centre, filter width ~0) through a pinhole camera at ``p`` looking at ``t``
with +Z up and a vertical field of view of FOV degrees, each material's image
shown by an emission shader (no lighting), the "Standard" view transform (the
image's sRGB values come back as they are) and a transparent background.
"""

import json
import math
import sys


def main() -> None:
    import bpy  # Blender's own modules: only in run_blender's process
    import mathutils

    fmt, mesh_path, json_out, png_out, pos, target, fov, width, height = sys.argv[1:10]
    pos = mathutils.Vector([float(x) for x in pos.split(",")])
    target = mathutils.Vector([float(x) for x in target.split(",")])

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if fmt == "glb":
        bpy.ops.import_scene.gltf(filepath=mesh_path)
    else:
        bpy.ops.wm.obj_import(filepath=mesh_path, forward_axis="Y", up_axis="Z")

    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    corners = [o.matrix_world @ v.co for o in meshes for v in o.data.vertices]
    info = {
        "objects": len(meshes),
        "min": [min(c[i] for c in corners) for i in range(3)],
        "max": [max(c[i] for c in corners) for i in range(3)],
        "materials": [],
    }

    for mat in {m for o in meshes for m in o.data.materials if m is not None}:
        nodes, links = mat.node_tree.nodes, mat.node_tree.links
        bsdf = next(n for n in nodes if n.type == "BSDF_PRINCIPLED")
        link = next((lk for lk in links if lk.to_node == bsdf and lk.to_socket.name == "Base Color"), None)
        source = link.from_node if link else None
        entry = {"name": mat.name, "base_color_from": source.type if source else None}
        if source is not None and source.type == "TEX_IMAGE":
            entry["colorspace"] = source.image.colorspace_settings.name
            entry["size"] = list(source.image.size)
            # the image alone, unlit: an emission shader fed by the same image node
            source.interpolation = "Linear"
            emission = nodes.new("ShaderNodeEmission")
            emission.inputs["Strength"].default_value = 1.0
            links.new(source.outputs["Color"], emission.inputs["Color"])
            output = next(n for n in nodes if n.type == "OUTPUT_MATERIAL")
            links.new(emission.outputs["Emission"], output.inputs["Surface"])
        info["materials"].append(entry)

    scene = bpy.context.scene
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.location = pos
    camera.rotation_euler = (target - pos).to_track_quat("-Z", "Y").to_euler()
    camera.data.sensor_fit = "VERTICAL"
    camera.data.angle_y = math.radians(float(fov))
    camera.data.clip_start = 1e-3
    camera.data.clip_end = 1e4

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.filter_width = 0.01  # every sample at its pixel's centre, as the package's ray cast
    scene.render.resolution_x, scene.render.resolution_y = int(width), int(height)
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.image_settings.color_depth = "8"
    scene.render.filepath = png_out
    bpy.ops.render.render(write_still=True)

    with open(json_out, "w") as f:
        json.dump(info, f)


if __name__ == "__main__":
    main()
