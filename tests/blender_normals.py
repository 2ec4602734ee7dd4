"""Blender side of tests/test_clients_mesh.py's normals tests: the normal of every face
corner as Blender shades it.

Run by ``tests.clients.run_blender`` (Blender 5's ``bpy`` in its own process):

    blender_normals.py FORMAT MESH JSON_OUT ANGLE

FORMAT "ply": import the PLY with its axes as written (+Z up, +Y forward), shade it
smooth and mark edges sharper than ANGLE degrees sharp (Blender's Smooth by Angle,
``Mesh.set_sharp_from_angle``). FORMAT "glb": import the GLB (its normals become
Blender's custom normals; glTF's +Y up becomes Blender's +Z); ANGLE is not used.
JSON_OUT gets, for every face corner of every imported mesh in world coordinates,
its position, its normal (``Mesh.corner_normals``) and its face's normal.
"""

import json
import math
import sys


def main() -> None:
    import bpy  # Blender's own modules: only in run_blender's process

    fmt, mesh_path, json_out, angle = sys.argv[1:5]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if fmt == "glb":
        bpy.ops.import_scene.gltf(filepath=mesh_path)
    else:
        bpy.ops.wm.ply_import(filepath=mesh_path, forward_axis="Y", up_axis="Z")
    out = {"positions": [], "normals": [], "face_normals": []}
    for obj in (o for o in bpy.context.scene.objects if o.type == "MESH"):
        me = obj.data
        if fmt != "glb":
            me.shade_smooth()
            me.set_sharp_from_angle(angle=math.radians(float(angle)))
        world = obj.matrix_world
        turn = world.to_3x3().inverted().transposed()
        corner_normals = me.corner_normals
        for poly in me.polygons:
            face_normal = (turn @ poly.normal).normalized()
            for li in range(poly.loop_start, poly.loop_start + poly.loop_total):
                out["positions"].append(list(world @ me.vertices[me.loops[li].vertex_index].co))
                out["normals"].append(list((turn @ corner_normals[li].vector).normalized()))
                out["face_normals"].append(list(face_normal))
    with open(json_out, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
