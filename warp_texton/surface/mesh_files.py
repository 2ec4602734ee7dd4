"""Mesh files: glTF's +Y up on write, and the one 8-bit rule of written textures.

glTF and GLB are Y-up by definition (glTF 2.0, §3.4), so every GLB the
package writes has its geometry turned from the mesh's up axis to +Y
(:func:`gltf_rotation`, :func:`to_gltf_axes`): positions and normals turn,
UVs and textures stay as they are. Reading such a file back with up ``"y"``
(``--up auto`` for ``.glb``) gives the same world: the frame rule's up and
side directions, the render's camera and light turn with the geometry. OBJ and
PLY declare no up axis, so they keep the input's coordinates.

Texture images written as PNG (the texture alone, the base colour embedded in
a GLB, an OBJ's PNG; 8 bits, or 16) follow one rule, :func:`texture_pixels`:
values clipped to [0, 1], scaled to the type's range and rounded, as
:func:`warp_texton.write_image` does, and the clipped pixels are reported once
per output file, by its final name (:func:`report_texture_clipping`).
"""

from __future__ import annotations

import contextlib
import io
from typing import Any

from pathlib import Path

import numpy as np

from ..core.errors import TextonError
from .frames import up_rotation
from ..files.images import convert_pixels, report_clipped

#: Mesh formats that declare their up axis: +Y (glTF 2.0).
GLTF_FORMATS = ("glb", "gltf")


def gltf_rotation(up) -> np.ndarray:
    """The rotation M (glTF = M · world) that turns a world whose up is ``up`` to glTF's +Y up.

    M = R_y · R_upᵀ with R from :func:`warp_texton.surface.frames.up_rotation`: the
    world's up goes to +Y and the frame rule's side direction to +X, so the
    texture's frame, views and light keep their place on the surface. For Z up
    it is Blender's glTF export, (x, y, z) → (x, z, −y).

    >>> gltf_rotation("z").astype(int).tolist()
    [[1, 0, 0], [0, 0, 1], [0, -1, 0]]
    >>> bool((gltf_rotation("y") == np.eye(3)).all())
    True
    """
    return up_rotation("y") @ up_rotation(up).T


def to_gltf_axes(mesh, up):
    """``mesh`` with its vertices and vertex normals turned from ``up`` to +Y
    (:func:`gltf_rotation`); faces, UVs, colours and material unchanged. A Y-up
    mesh is returned as it is."""
    m = gltf_rotation(up)
    if np.array_equal(m, np.eye(3)):
        return mesh
    transform = np.eye(4)
    transform[:3, :3] = m
    # trimesh turns the normals it holds (the bake's, given) with the vertices
    return mesh.copy(include_cache=True).apply_transform(transform)


def export_mesh(mesh, fmt: str, up) -> bytes:
    """The bytes of ``mesh`` in ``fmt`` ("ply", "obj", "glb"): glTF turned to +Y from
    ``up``, the other formats in the mesh's own coordinates."""
    if fmt in GLTF_FORMATS:
        mesh = to_gltf_axes(mesh, up)
        reach = float(np.max(np.abs(mesh.vertices))) if len(mesh.vertices) else 0.0
        if not reach < float(np.finfo(np.float32).max):  # glTF stores float32 positions: beyond, infinities
            raise TextonError(f"its coordinates reach {reach:.3g}, more than the float32 positions of glTF hold "
                              f"({float(np.finfo(np.float32).max):.3g}); scale the mesh down, or write OBJ or PLY")
    buf = io.BytesIO()
    mesh.export(buf, file_type=fmt)
    if fmt == "glb" and getattr(mesh.visual, "kind", None) == "vertex":
        return with_colour_material(buf.getvalue())
    return buf.getvalue()


#: The material of a vertex-coloured GLB: white, not metallic, fully rough. glTF multiplies
#: the base colour by ``COLOR_0`` (glTF 2.0, §3.9.2), so the vertex colours are what shows;
#: without a material viewers such as Blender import the colours but show grey.
COLOUR_MATERIAL = {"name": "warp_texton_vertex_colours",
                   "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0,
                                            "roughnessFactor": 1.0}}


def with_colour_material(glb: bytes) -> bytes:
    """A GLB (as trimesh writes it: JSON chunk, then binary chunk) with :data:`COLOUR_MATERIAL`
    given to every primitive that has ``COLOR_0`` and no material."""
    import json
    import struct

    magic, version, _ = struct.unpack_from("<4sII", glb, 0)
    json_len, json_type = struct.unpack_from("<I4s", glb, 12)
    if magic != b"glTF" or json_type != b"JSON":
        return glb
    doc = json.loads(glb[20:20 + json_len])
    bare = [prim for mesh in doc.get("meshes", []) for prim in mesh.get("primitives", [])
            if "COLOR_0" in prim.get("attributes", {}) and "material" not in prim]
    if not bare:
        return glb
    materials = doc.setdefault("materials", [])
    for prim in bare:
        prim["material"] = len(materials)
    materials.append(COLOUR_MATERIAL)
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)  # chunks are 4-byte aligned, JSON padded with spaces
    rest = glb[20 + json_len:]
    head = struct.pack("<4sII", magic, version, 12 + 8 + len(text) + len(rest)) + struct.pack("<I4s", len(text),
                                                                                               b"JSON")
    return head + text + rest


def scene_mesh(scene):
    """One mesh of a trimesh Scene (a glTF file), with each node's transform applied and
    the normals the file holds kept (trimesh's own concatenation recomputes them, which
    would lose a GLB's smooth normals across UV seams). A Trimesh is returned as it is."""
    import trimesh

    if not isinstance(scene, trimesh.Scene):
        return scene
    parts = []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        geom = scene.geometry[name]
        if not isinstance(geom, trimesh.Trimesh):
            continue
        held = "vertex_normals" in geom._cache.cache  # read from the file, not computed
        m = np.asarray(transform, np.float64)
        vertices = np.asarray(geom.vertices, np.float64) @ m[:3, :3].T + m[:3, 3]
        normals = None
        if held:  # normals turn by the inverse transpose of the node's linear part
            n = np.asarray(geom.vertex_normals, np.float64) @ np.linalg.inv(m[:3, :3])
            normals = n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
        visual = geom.visual.copy() if geom.visual is not None else None
        parts.append((trimesh.Trimesh(vertices=vertices, faces=geom.faces, vertex_normals=normals, visual=visual,
                                      process=False), normals))
    if len(parts) == 1:
        return parts[0][0]
    if not parts:
        return trimesh.Trimesh()
    merged: Any = trimesh.util.concatenate([mesh for mesh, _ in parts])
    if any(n is None for _, n in parts):
        return merged
    return trimesh.Trimesh(vertices=merged.vertices, faces=merged.faces, visual=merged.visual, process=False,
                           vertex_normals=np.concatenate([n for _, n in parts]))


#: Sample types of written PNG textures: 8 bits (default) or 16 (``bake_mesh(dtype="uint16")``).
PNG_DTYPES = ("uint8", "uint16")


def texture_pixels(texture: np.ndarray, dtype: str = "uint8", *, rgb: bool = True) -> tuple[np.ndarray, int]:
    """(texture as ``dtype``, pixels with a value clipped): the rule of every written PNG
    texture, :func:`warp_texton.files.images.convert_pixels` (values clipped to [0, 1], scaled
    to the type's range, rounded). ``rgb`` spreads a grey texture to RGB (an embedded
    base colour)."""
    data, clipped = convert_pixels(np.asarray(texture, np.float32), dtype)
    if rgb and data.shape[2] == 1:
        data = np.repeat(data, 3, axis=2)
    return data, clipped


def texture_8bit(texture: np.ndarray, *, rgb: bool = True) -> tuple[np.ndarray, int]:
    """:func:`texture_pixels` in 8 bits: the texture a bake's mesh carries in memory."""
    return texture_pixels(texture, "uint8", rgb=rgb)


def report_texture_clipping(path, clipped: int, texture: np.ndarray, dtype: str = "uint8") -> None:
    """Warn once for the output ``path`` (its final name) when more than
    ``io.CLIP_WARN`` of the texture's pixels were clipped."""
    report_clipped(path, clipped, texture.shape[0] * texture.shape[1], dtype)


def png_bytes(data: np.ndarray) -> bytes:
    """A uint8 or uint16 texture (H, W, 1 or 3) as PNG bytes, as :func:`warp_texton.write_image`
    writes it: grey as one channel; 16-bit RGB through imagecodecs (Pillow writes no 48-bit PNG)."""
    from PIL import Image

    if data.dtype == np.uint16 and data.shape[2] == 3:
        try:
            import imagecodecs
        except ImportError:
            raise TextonError("a 16-bit RGB PNG texture needs the imagecodecs package: "
                              "pip install 'warp-texton[formats]'") from None
        return bytes(imagecodecs.png_encode(np.ascontiguousarray(data)))
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(data[:, :, 0] if data.shape[2] == 1 else data)).save(buf, format="PNG")
    return buf.getvalue()


def with_image(glb: bytes, png: bytes) -> bytes:
    """A GLB (one buffer, in its binary chunk) with its first image's bytes replaced by
    ``png``: the buffer views after it move, the lengths follow."""
    import json
    import struct

    json_len = struct.unpack_from("<I", glb, 12)[0]
    doc = json.loads(glb[20:20 + json_len])
    bin_start = 20 + json_len + 8
    binary = glb[bin_start:bin_start + struct.unpack_from("<I", glb, 20 + json_len)[0]]
    view = doc["bufferViews"][doc["images"][0]["bufferView"]]
    start, old_len = view.get("byteOffset", 0), view["byteLength"]
    padded = png + b"\0" * (-len(png) % 4)  # keep the views after it 4-byte aligned
    shift = len(padded) - (old_len + (-old_len % 4))
    for other in doc["bufferViews"]:
        if other.get("byteOffset", 0) > start:
            other["byteOffset"] += shift
    view["byteLength"] = len(png)
    binary = binary[:start] + padded + binary[start + old_len + (-old_len % 4):]
    binary += b"\0" * (-len(binary) % 4)
    doc["buffers"][0]["byteLength"] = len(binary)
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(text), b"JSON") + text
            + struct.pack("<I4s", len(binary), b"BIN\0") + binary)


@contextlib.contextmanager
def named_as(tmp, path):
    """Errors raised inside name the output ``path``, never the temporary ``tmp``."""
    try:
        yield
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
    except TextonError as exc:
        raise TextonError(str(exc).replace(str(tmp), str(path)), exc.param, mentions=exc.mentions) from None


def write_set(writes) -> None:
    """Write a set of files all or none: ``writes`` maps each output path to its bytes or to a
    function that writes the file it is given (a temporary path with the output's suffix).

    Every name is checked first, every file is written to a temporary name before the first
    rename, and should a rename still fail the outputs already renamed are removed again."""
    from ..files.images import atomic_path, check_output_name

    for path in writes:
        check_output_name(path)
    before = {Path(p): _identity(Path(p)) for p in writes}
    try:
        with contextlib.ExitStack() as stack:
            for path, data in writes.items():
                tmp = Path(stack.enter_context(atomic_path(path)))
                if isinstance(data, (bytes, bytearray)):
                    tmp.write_bytes(data)
                else:  # writers that choose the format by suffix write beside the temporary file,
                    # under its name with the output's suffix for .part: no longer than it, so a name
                    # that fits the file system has a side name that fits too
                    side = tmp.with_suffix(Path(path).suffix)
                    try:
                        with named_as(side, path):
                            data(side)
                        side.replace(tmp)
                    finally:
                        side.unlink(missing_ok=True)
    except BaseException:
        for path, old in before.items():
            if _identity(path) not in (None, old):  # renamed in by this call: not left alone
                path.unlink(missing_ok=True)
        raise


def _identity(path: Path):
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns, st.st_size


def check_surface(mesh, name: str) -> None:
    """Refuse a mesh without area (every vertex on a line or at one point): it has no
    normals, so no surface to texture and no up axis to honour."""
    v = np.asarray(mesh.vertices, np.float64)
    f = np.asarray(mesh.faces, np.int64)
    area = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    scale = float(np.ptp(v, axis=0).max()) if len(v) else 0.0
    if not np.any(area > 1e-12 * max(scale, 1e-300) ** 2):
        where = "at one point" if scale == 0.0 else "on a line"
        raise TextonError(f"{name}: degenerate mesh: its triangles have no area (the vertices lie {where}), "
                          "so it has no normals and no up axis to honour")



#: Files a bake writes for each mesh format (besides the optional texture file).
BAKE_FORMATS = ("glb", "obj")
#: Formats of the texture file: 8-bit PNG or float32 EXR.
TEXTURE_FORMATS = ("png", "exr")


def bake_outputs(stem: Path, fmt: str, texture: str | None = None) -> list[Path]:
    """The files :func:`write_baked` writes for ``stem`` (a path without extension)."""
    stem = Path(stem)
    out = [stem.with_suffix(".glb")] if fmt == "glb" else [stem.with_suffix(".obj"), stem.with_suffix(".mtl"),
                                                            stem.with_suffix(".png")]
    if texture is not None:
        out.append(stem.parent / f"{stem.name}_texture.{texture}")
    return out


def write_baked(baked, stem, *, fmt: str = "glb", texture: str | None = None, linear: bool = False,
                also=None) -> list[Path]:
    """Write a bake as GLB or OBJ + MTL + PNG, and optionally the texture alone.

    ``STEM.glb`` holds the texture embedded as the base colour of a PBR
    material, with the mesh's UVs and normals, its geometry turned from the
    bake's up axis (``baked.up``, the ``up`` given to
    :func:`warp_texton.bake_mesh`) to +Y, since glTF is Y-up by definition:
    read it back with ``up="y"`` (``--up auto``) for the same world. UVs and
    texture are not changed. ``STEM.obj`` + ``STEM.mtl`` + ``STEM.png`` keep
    the mesh's own coordinates (OBJ declares no up axis): the MTL's ``map_Kd``
    names the PNG, with a diffuse factor of 1. Every file is written to a
    temporary name first and all are renamed at the end: all files appear
    together, or none.

    Every PNG texture (embedded in the GLB, the OBJ's PNG, ``STEM_texture.png``)
    holds the values clipped to [0, 1], in 8 bits, or 16 for a bake made with
    ``dtype="uint16"`` (``baked.dtype``); when more than 1 % of the texels are
    clipped a warning names that output, once.

    Parameters
    ----------
    baked : BakedMesh
        From :func:`warp_texton.bake_mesh`.
    stem : str or Path
        The output path without its extension.
    fmt : {"glb", "obj"}
    texture : {"png", "exr"}, optional
        Also write the texture alone: ``STEM_texture.png`` (sRGB, 8 or 16 bits as ``baked.dtype``) or
        ``STEM_texture.exr`` (float32: the noise's values).
    linear : bool
        The EXR texture holds the sRGB decoding of the values instead.
    also : dict, optional
        More files of the same set (path -> bytes or a writer, as :func:`write_set`
        takes them), written and renamed with the bake's: a render, say.

    Returns
    -------
    list of Path
        The paths written.

    Raises
    ------
    TextonError
        For a bad ``fmt`` or ``texture``, and the errors of the file system
        (naming the output, never a temporary file).

    Examples
    --------
    See :func:`warp_texton.bake_mesh`; ``write_baked(baked, "torus_baked",
    fmt="obj")`` writes ``torus_baked.obj``, ``.mtl`` and ``.png``.
    """
    from ..files.images import write_exr
    from .mesh import srgb_to_linear

    if fmt not in BAKE_FORMATS:
        raise TextonError(f"fmt must be {' or '.join(repr(f) for f in BAKE_FORMATS)} (a baked mesh's file format), "
                          f"got {fmt!r:.40}")
    if texture is not None and texture not in TEXTURE_FORMATS:
        raise TextonError(f"texture must be one of {', '.join(TEXTURE_FORMATS)}, got {texture!r}")
    paths = bake_outputs(stem, fmt, texture)
    depth = getattr(baked, "dtype", "uint8")
    pixels, clipped = texture_pixels(baked.texture, depth)
    blobs: dict[Path, bytes] = {}
    if fmt == "glb":
        blobs[paths[0]] = export_mesh(baked.mesh, "glb", baked.up)
        if depth != "uint8":  # the mesh carries the 8-bit image; the file gets the deeper one
            blobs[paths[0]] = with_image(blobs[paths[0]], png_bytes(pixels))
    else:
        from trimesh.exchange.obj import export_obj

        text, files = export_obj(baked.mesh, include_normals=False, include_texture=True, return_texture=True,
                                 mtl_name=paths[1].name)
        png = next(v for k, v in files.items() if not k.endswith(".mtl"))
        mtl = files[paths[1].name].decode("utf-8")
        # the texture alone gives the colour: a diffuse factor of 1 (Kd multiplies map_Kd in viewers)
        fixed = {"map_Kd": f"map_Kd {paths[2].name}", "Kd": "Kd 1.00000000 1.00000000 1.00000000"}
        mtl = "\n".join(fixed.get(ln.split(" ")[0], ln) for ln in mtl.splitlines())
        blobs[paths[0]] = text.encode("utf-8")
        blobs[paths[1]] = (mtl + "\n").encode("utf-8")
        blobs[paths[2]] = png if depth == "uint8" else png_bytes(pixels)
    if texture == "png":
        blobs[paths[-1]] = png_bytes(texture_pixels(baked.texture, depth, rgb=False)[0])
    writes: dict = dict(blobs)
    if texture == "exr":
        img = baked.texture
        if linear:
            img = srgb_to_linear(np.clip(img, 0.0, 1.0)).astype(np.float32)
        writes[paths[-1]] = lambda tmp: write_exr(tmp, img)
    writes.update(also or {})
    write_set(writes)
    for path in paths:  # one report per 8-bit texture written, by its own name
        if path.suffix == ".png" or path.suffix == ".glb":
            report_texture_clipping(path, clipped, baked.texture, depth)
    return paths
