"""Install the extension zip in Blender, run its operator on the default cube, render (run by Blender's
Python through clients.run_blender, with a user folder of its own: BLENDER_USER_RESOURCES).

Argument: a JSON file: "zip" (the extension), "image" (the operator's filepath), "runs" and "report".
Each run is the operator on an object ("object": "Cube", the default, or "sphere without UVs", made
for it), with its other properties ("operator", "filepath" among them to override "image"), then
"renders" of the material it made, each: "out", a PNG path; "branch": "material" the material as the operator made it
(Cycles renders its OSL branch, EEVEE its bake), "baked" its EEVEE branch (the bake and normal map)
shown in Cycles, "flat" the same lighting with a constant base colour and no bump or normal map; "engine": "CYCLES"
(default) or "EEVEE"; "width", "height", "samples". The report (JSON): the validator's verdict, the
install's result and, for each run, the operator's (and its error, an operator that reports one
raises in background mode), the object's UV layers before and after, whether its material is
unchanged, the material's nodes and images, the renders' times. Renders are RGBA with a transparent film: alpha marks the object.
This script imports nothing of warp_texton itself: the add-on, installed from the zip, does.
"""

import json
import subprocess
import sys
import time
from pathlib import Path


def validate(zip_path):
    """Blender's own validator of extension packages (``blender --command extension validate``)."""
    import bpy

    cli = Path(bpy.utils.resource_path("LOCAL")) / "scripts" / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"
    proc = subprocess.run([sys.executable, str(cli), "validate", zip_path], capture_output=True, text=True)
    return {"returncode": proc.returncode, "output": (proc.stdout + proc.stderr).strip()}


def material_facts(mat):
    nt = mat.node_tree
    outputs = {n.name: n.target for n in nt.nodes if n.bl_idname == "ShaderNodeOutputMaterial"}
    images = {}
    for n in nt.nodes:
        if n.bl_idname == "ShaderNodeTexImage" and n.image is not None:
            images[n.image.name] = {"size": list(n.image.size), "colorspace": n.image.colorspace_settings.name,
                                    "packed": n.image.packed_file is not None}
    scripts = [n.script.name for n in nt.nodes if n.bl_idname == "ShaderNodeScript"]
    return {"name": mat.name, "outputs": outputs, "images": images, "scripts": scripts,
            "node_types": sorted({n.bl_idname for n in nt.nodes})}


def show_branch(mat, branch, engine):
    """Make the output ``engine`` renders show ``branch``."""
    nt = mat.node_tree
    outputs = {n.target: n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputMaterial"}
    out = outputs.get(engine, outputs.get("ALL"))
    if branch == "baked":
        baked = outputs["EEVEE"].inputs["Surface"].links[0].from_node
        nt.links.new(baked.outputs["BSDF"], out.inputs["Surface"])
    elif branch == "flat":
        bsdf = out.inputs["Surface"].links[0].from_node
        for name in ("Base Color", "Normal"):
            for link in list(bsdf.inputs[name].links):
                nt.links.remove(link)
        bsdf.inputs["Base Color"].default_value = (0.1, 0.1, 0.1, 1.0)


def target(name):
    """The object a run is on: the default scene's ``Cube``, or ``"sphere without UVs"``, made hidden
    from the camera beside it."""
    import bpy

    if name in bpy.data.objects:
        return bpy.data.objects[name]
    assert name == "sphere without UVs", name
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=0.5, location=(0.0, 0.0, 5.0))
    ob = bpy.context.active_object
    while ob.data.uv_layers:
        ob.data.uv_layers.remove(ob.data.uv_layers[0])
    ob.name = name
    ob.hide_render = True
    return ob


def render(scene, job):
    import bpy

    scene.render.engine = "BLENDER_EEVEE" if job.get("engine") == "EEVEE" else "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = job.get("samples", 8)
    scene.cycles.use_denoising = False
    scene.cycles.seed = 0
    if hasattr(scene, "eevee"):
        scene.eevee.taa_render_samples = job.get("samples", 8)
    scene.render.film_transparent = True
    scene.render.resolution_x = job["width"]
    scene.render.resolution_y = job["height"]
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.filepath = job["out"]
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return time.perf_counter() - t0


def main():
    import bpy

    spec = json.loads(Path(sys.argv[1]).read_text())
    report = {"validate": validate(spec["zip"])}
    t0 = time.perf_counter()
    report["install"] = sorted(bpy.ops.extensions.package_install_files(
        filepath=spec["zip"], repo="user_default", enable_on_install=True))
    report["install_s"] = time.perf_counter() - t0
    report["addons"] = sorted(k for k in bpy.context.preferences.addons.keys() if "warp_texton" in k)
    panel = getattr(bpy.types, "WARP_TEXTON_PT_material", None)
    report["panel"] = None if panel is None else {k: getattr(panel, k) for k in (
        "bl_space_type", "bl_region_type", "bl_category")}
    scene = bpy.context.scene
    report["runs"] = []
    for run in spec["runs"]:  # each: the operator on an object, then renders of its material
        ob = target(run.get("object", "Cube"))
        bpy.context.view_layer.objects.active = ob
        scene.render.engine = "CYCLES"
        before = ob.active_material.name if ob.active_material else None
        done = {"uv_layers_before": len(ob.data.uv_layers)}
        t0 = time.perf_counter()
        try:
            done["operator"] = sorted(bpy.ops.warp_texton.material_from_image(
                **{"filepath": spec["image"], **run.get("operator", {})}))
        except RuntimeError as exc:  # an operator that reports an error raises, in background mode
            done["operator"], done["error"] = ["CANCELLED"], str(exc)
        done["operator_s"] = time.perf_counter() - t0
        done["uv_layers_after"] = len(ob.data.uv_layers)
        mat = ob.active_material
        done["material_unchanged"] = (mat.name if mat else None) == before
        if "error" not in done:
            done["package"] = sys.modules["warp_texton"].__file__  # the installed wheel's, not a checkout's
            done["material"] = material_facts(mat)
            done["osl"] = bool(scene.cycles.shading_system)
        done["renders"] = []
        for job in run.get("renders", []):
            copy = mat.copy()
            ob.active_material = copy
            show_branch(copy, job["branch"], job.get("engine", "CYCLES"))
            done["renders"].append({"out": job["out"], "seconds": render(scene, job)})
            ob.active_material = mat
        report["runs"].append(done)
    Path(spec["report"]).write_text(json.dumps(report))


if __name__ == "__main__":  # Blender runs it; pytest's doctest collection only imports it
    main()
