"""Warp Texton for Blender: a material from a photograph (the add-on of ``warp-texton blender-extension``).

``bpy.ops.warp_texton.material_from_image(filepath=...)`` analyses the image (texton noise or the
tiling model, as the structure score chooses, unless ``method`` says) and gives the active object a
material with two outputs: Cycles renders an OSL Script node holding the model (surface noise for a
texton: infinite, no UVs; a tiling model projected on the object's three planes), EEVEE a bake of the
same noise on the object's UVs (made by Smart UV Project when it has none) with its normal map. A
panel in the Shader editor's sidebar (tab "Warp Texton") runs it.

This file runs in Blender only (it is copied into the extension's zip); the computing is
``warp_texton.blender.materials``, installed from the extension's wheels. As Blender's extension rules
ask, it leaves ``sys.path`` alone (Blender as a Python module, ``bpy`` from pip, lacks Blender's own
``oslquery`` on it: the tests' runner adds it, tests/clients.py).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty


def _node(nt, kind, location, **inputs):
    node = nt.nodes.new(kind)
    node.location = location
    for name, value in inputs.items():
        node.inputs[name].default_value = value
    return node


def _math(nt, op, a, b, location):
    node = _node(nt, "ShaderNodeMath", location)
    node.operation = op
    for k, v in enumerate((a, b)):
        if isinstance(v, (int, float)):
            node.inputs[k].default_value = v
        else:
            nt.links.new(v, node.inputs[k])
    return node.outputs[0]


def _script_node(nt, text, location):
    import cycles.osl

    node = _node(nt, "ShaderNodeScript", location)
    node.mode = "INTERNAL"
    node.script = text
    messages = []
    ok = cycles.osl.update_script_node(node, lambda kind, msg: messages.append(msg))
    if not ok or "Linear" not in node.outputs:
        raise RuntimeError(f"the OSL shader {text.name} did not compile: {' '.join(messages)}")
    return node


def _cycles_surface(nt, shader, texel_size):
    """(colour socket, height socket) of the OSL shader: one Script node on the surface, or a
    tiling projected on the object's three coordinate planes, blended by the normal."""
    text = bpy.data.texts.get(shader.name) or bpy.data.texts.new(shader.name)
    text.clear()
    text.write(shader.source)
    if shader.coordinates == "surface":
        node = _script_node(nt, text, (-600, 300))
        node.inputs["texel_size"].default_value = texel_size
        return node.outputs["Linear"], node.outputs["Value"]
    coords = _node(nt, "ShaderNodeTexCoord", (-1400, 300))
    xyz = _node(nt, "ShaderNodeSeparateXYZ", (-1200, 400))
    nrm = _node(nt, "ShaderNodeSeparateXYZ", (-1200, 0))
    nt.links.new(coords.outputs["Object"], xyz.inputs[0])
    nt.links.new(coords.outputs["Normal"], nrm.inputs[0])
    colour = height = total = None
    for k, (a, b) in enumerate((("Y", "Z"), ("X", "Z"), ("X", "Y"))):  # the planes facing x, y and z
        plane = _node(nt, "ShaderNodeCombineXYZ", (-1000, 600 - 300 * k))
        nt.links.new(xyz.outputs[a], plane.inputs[0])
        nt.links.new(xyz.outputs[b], plane.inputs[1])
        node = _script_node(nt, text, (-800, 600 - 300 * k))
        node.inputs["texel_size"].default_value = texel_size
        node.inputs["coordinates"].default_value = "input"
        nt.links.new(plane.outputs[0], node.inputs["Vector"])
        w = _math(nt, "POWER", _math(nt, "ABSOLUTE", nrm.outputs["XYZ"[k]], 0.0, (-1000, -300 * k)), 8.0,
                  (-900, -300 * k))
        scaled = _node(nt, "ShaderNodeVectorMath", (-600, 600 - 300 * k))
        scaled.operation = "SCALE"
        nt.links.new(node.outputs["Linear"], scaled.inputs[0])
        nt.links.new(w, scaled.inputs["Scale"])
        h = _math(nt, "MULTIPLY", node.outputs["Value"], w, (-600, -300 * k))
        if colour is None:
            colour, height, total = scaled.outputs["Vector"], h, w
        else:
            add = _node(nt, "ShaderNodeVectorMath", (-450, 600 - 300 * k))
            nt.links.new(colour, add.inputs[0])
            nt.links.new(scaled.outputs["Vector"], add.inputs[1])
            colour = add.outputs["Vector"]
            height = _math(nt, "ADD", height, h, (-450, -300 * k))
            total = _math(nt, "ADD", total, w, (-450, -100 - 300 * k))
    norm = _node(nt, "ShaderNodeVectorMath", (-300, 300))
    norm.operation = "DIVIDE"
    nt.links.new(colour, norm.inputs[0])
    nt.links.new(total, norm.inputs[1])
    return norm.outputs["Vector"], _math(nt, "DIVIDE", height, total, (-300, 0))


def _image(name, rgb, colorspace):
    """A packed Blender image of ``rgb`` (H, W, 3) in [0, 1], row 0 at the top."""
    h, w, _ = rgb.shape
    img = bpy.data.images.get(name)
    if img is not None:
        bpy.data.images.remove(img)
    img = bpy.data.images.new(name, w, h, alpha=False)
    img.colorspace_settings.name = colorspace
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = np.clip(rgb[::-1], 0.0, 1.0)  # Blender's rows start at the bottom
    img.pixels.foreach_set(rgba.ravel())
    img.update()
    try:
        img.pack()
    except RuntimeError:  # an image Blender cannot pack stays in memory, saved with the file as generated
        pass
    return img


def _corners(ob):
    """(positions, corner normals, uvs) of the object's loop triangles, three rows a triangle."""
    me = ob.data
    me.calc_loop_triangles()
    tris = me.loop_triangles
    loops = np.empty(len(tris) * 3, np.int64)
    tris.foreach_get("loops", loops)
    co = np.empty(len(me.vertices) * 3, np.float64)
    me.vertices.foreach_get("co", co)
    vidx = np.empty(len(me.loops), np.int64)
    me.loops.foreach_get("vertex_index", vidx)
    normals = np.empty(len(me.loops) * 3, np.float64)
    me.corner_normals.foreach_get("vector", normals)
    uv = np.empty(len(me.loops) * 2, np.float64)
    me.uv_layers.active.data.foreach_get("uv", uv)
    return co.reshape(-1, 3)[vidx[loops]], normals.reshape(-1, 3)[loops], uv.reshape(-1, 2)[loops]


def _ensure_uvs(context, ob) -> bool:
    """Give ``ob`` UVs (Smart UV Project) when it has none; True when made."""
    if ob.data.uv_layers.active is not None:
        return False
    ob.data.uv_layers.new(name="UVMap")
    with context.temp_override(active_object=ob, object=ob, selected_objects=[ob],
                               selected_editable_objects=[ob]):
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.uv.smart_project(island_margin=0.02)
        bpy.ops.object.mode_set(mode="OBJECT")
    return True


def _eevee_surface(nt, bake, name):
    """(colour socket, normal socket) of the bake: image textures on the UVs, a Normal Map node."""
    uvmap = _node(nt, "ShaderNodeUVMap", (-900, -700))
    colour = _node(nt, "ShaderNodeTexImage", (-650, -600))
    colour.image = _image(f"{name} colour", bake.colour, "sRGB")
    normal = _node(nt, "ShaderNodeTexImage", (-650, -900))
    normal.image = _image(f"{name} normal", bake.normal, "Non-Color")
    for tex in (colour, normal):
        nt.links.new(uvmap.outputs["UV"], tex.inputs["Vector"])
    nmap = _node(nt, "ShaderNodeNormalMap", (-350, -900))
    nmap.space = "TANGENT"
    nt.links.new(normal.outputs["Color"], nmap.inputs["Color"])
    return colour.outputs["Color"], nmap.outputs["Normal"]


class WARP_TEXTON_OT_material_from_image(bpy.types.Operator):
    """Give the active object a material made from an image: texton noise or the tiling model in
    Cycles (an OSL Script node), and a bake of it with its normal map for EEVEE"""

    bl_idname = "warp_texton.material_from_image"
    bl_label = "Material from Image"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="Image", subtype="FILE_PATH")  # type: ignore[valid-type]
    filter_image: BoolProperty(default=True, options={"HIDDEN", "SKIP_SAVE"})  # type: ignore[valid-type]
    method: EnumProperty(  # type: ignore[valid-type]
        name="Model", default="auto",
        items=[("auto", "Auto", "Texton or tiling, as the structure score of the image chooses"),
               ("texton", "Texton noise", "A Gaussian texture (no shapes): sand, fabric, stone"),
               ("tiling", "Tiling", "Tiling and blending of the image: bricks, tiles, paving")])
    texel_size: FloatProperty(name="Texel size", default=0.01, min=1e-6, soft_max=1.0,  # type: ignore[valid-type]
                              description="Object units per texel of the image")
    seed: IntProperty(name="Seed", default=0, min=0)  # type: ignore[valid-type]
    bake: BoolProperty(name="Bake for EEVEE", default=True,  # type: ignore[valid-type]
                       description="Bake the noise on the object's UVs for EEVEE (Cycles uses the OSL node)")
    resolution: IntProperty(name="Bake resolution", default=1024, min=16, max=8192)  # type: ignore[valid-type]
    bump: FloatProperty(name="Bump", default=0.3, min=0.0, max=1.0)  # type: ignore[valid-type]

    def invoke(self, context, event):
        if not self.filepath:
            context.window_manager.fileselect_add(self)
            return {"RUNNING_MODAL"}
        return self.execute(context)

    def execute(self, context):
        from warp_texton import ExampleWarning, TextonError
        from warp_texton.blender import materials

        ob = context.active_object
        if ob is None or ob.type != "MESH":
            self.report({"ERROR"}, "Warp Texton: the active object must be a mesh")
            return {"CANCELLED"}
        path = bpy.path.abspath(self.filepath)
        if not Path(path).is_file():
            self.report({"ERROR"}, f"Warp Texton: filepath: {path} is not a file")
            return {"CANCELLED"}
        wm = context.window_manager
        wm.progress_begin(0, 100)

        def progress(fraction, message):
            wm.progress_update(int(100 * fraction))
            self.report({"INFO"}, f"Warp Texton: {message}")

        try:
            with warnings.catch_warnings(record=True) as caught:  # the analysis's ExampleWarnings, as reports
                warnings.simplefilter("always", ExampleWarning)
                model = materials.model_of_image(path, method=self.method, seed=self.seed, progress=progress)
            for w in caught:
                if isinstance(w.message, ExampleWarning):  # it names the image by its file
                    self.report({"WARNING"}, f"Warp Texton: {w.message.in_words({'u': Path(path).name})}")
                else:  # others as Python shows them
                    warnings.showwarning(w.message, w.category, w.filename, w.lineno)
            shader = materials.osl_shader(model, texel_size=self.texel_size, seed=self.seed)
            bake = None
            if self.bake:
                made = _ensure_uvs(context, ob)
                if made:
                    progress(0.55, "made UVs for the bake (Smart UV Project)")
                bake = materials.bake_corners(model, *_corners(ob), texel_size=self.texel_size,
                                              resolution=self.resolution, seed=self.seed, progress=progress)
            mat = self.material(context, ob, Path(path).stem, model, shader, bake)
        except (TextonError, RuntimeError) as exc:
            self.report({"ERROR"}, f"Warp Texton: {exc}")
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        kind = materials.model_kind(model)
        self.report({"INFO"}, f"Warp Texton: {mat.name}: the {kind} model of {Path(path).name}"
                    + (", baked for EEVEE" if bake is not None else ""))
        return {"FINISHED"}

    def material(self, context, ob, stem, model, shader, bake):
        scene = context.scene
        if hasattr(scene, "cycles"):
            scene.cycles.shading_system = True  # OSL: the Script node renders on the CPU
        mat = bpy.data.materials.new(f"Warp Texton {stem}")
        mat.use_nodes = True
        nt = mat.node_tree
        nt.nodes.clear()
        colour, height = _cycles_surface(nt, shader, self.texel_size)
        bump = _node(nt, "ShaderNodeBump", (-150, 0), Strength=self.bump, Distance=self.texel_size)
        nt.links.new(height, bump.inputs["Height"])
        bsdf = _node(nt, "ShaderNodeBsdfPrincipled", (100, 300), Roughness=0.8)
        nt.links.new(colour, bsdf.inputs["Base Color"])
        nt.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
        out = _node(nt, "ShaderNodeOutputMaterial", (400, 300))
        nt.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
        if bake is not None:
            out.target = "CYCLES"
            base, normal = _eevee_surface(nt, bake, mat.name)
            baked = _node(nt, "ShaderNodeBsdfPrincipled", (100, -600), Roughness=0.8)
            nt.links.new(base, baked.inputs["Base Color"])
            nt.links.new(normal, baked.inputs["Normal"])
            eevee = _node(nt, "ShaderNodeOutputMaterial", (400, -600))
            eevee.target = "EEVEE"
            nt.links.new(baked.outputs["BSDF"], eevee.inputs["Surface"])
        ob.data.materials.clear()
        ob.data.materials.append(mat)
        ob.active_material = mat
        return mat


class WARP_TEXTON_PT_material(bpy.types.Panel):
    """The Shader editor's sidebar tab "Warp Texton"."""

    bl_space_type = "NODE_EDITOR"
    bl_region_type = "UI"
    bl_category = "Warp Texton"
    bl_label = "Material from Image"

    @classmethod
    def poll(cls, context):
        space = context.space_data
        return space is not None and getattr(space, "tree_type", "") == "ShaderNodeTree"

    def draw(self, context):
        layout = self.layout
        ob = context.active_object
        layout.label(text=f"Object: {ob.name}" if ob is not None else "No active object")
        layout.operator(WARP_TEXTON_OT_material_from_image.bl_idname, icon="IMAGE_DATA")


CLASSES = (WARP_TEXTON_OT_material_from_image, WARP_TEXTON_PT_material)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
