"""Relief of a bake: a tangent-space normal texture in the GLB beside the base colour.

:func:`write_baked_relief` writes a bake (:func:`warp_texton.bake_mesh`) as GLB with a
``normalTexture``: the normals of the height h = strength · L / σ_L (L the
luminance of the baked texture, the channel mean, σ_L its standard deviation over the covered
texels; as :func:`warp_texton.normal_map`), in the glTF convention (+X along u, +Y up the image, +Z
out), with the tangents glTF's default gives (the viewer's MikkTSpace from the UVs: none
are stored). The bake is of *surface* noise, whose derivative along the surface is not
computed here: the slopes are central differences of the baked texels (one-sided at a
chart's gutter), so seams between charts show a slight crease where the gutter ends.
docs/relief.md, "Bakes".
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np

from ..core.checks import check_positive
from .mesh_files import export_mesh, png_bytes, write_set


def baked_normals(baked, strength: float = 1.0) -> np.ndarray:
    """(RES, RES, 3) float32 in [0, 1]: the bake's tangent-space normals (glTF's convention)."""
    strength = check_positive(strength, "strength")
    lum = np.asarray(baked.texture, np.float64).mean(axis=2)
    covered = lum[np.asarray(baked.coverage, bool)] if np.any(baked.coverage) else lum.ravel()
    h = lum * (strength / max(float(covered.std()), 1e-12))
    d_row, d_col = np.gradient(h)
    n = np.stack([-d_col, d_row, np.ones_like(h)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.clip(0.5 * (n + 1.0), 0.0, 1.0).astype(np.float32)


_COMPONENTS = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def _accessor(doc: dict, binary: bytes, k: int) -> np.ndarray:
    acc = doc["accessors"][k]
    view = doc["bufferViews"][acc["bufferView"]]
    dtype = np.dtype(_COMPONENTS[acc["componentType"]])
    width = _WIDTH[acc["type"]]
    if view.get("byteStride", dtype.itemsize * width) != dtype.itemsize * width:
        raise ValueError("interleaved vertex data")  # trimesh writes packed views
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    return np.frombuffer(binary, dtype, acc["count"] * width, start).reshape(acc["count"], width)


def vertex_tangents(positions: np.ndarray, normals: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(N, 4) float32 glTF tangents: xyz along +u, orthogonal to the normal; w the sign that makes
    cross(normal, xyz) · w point up the image (towards smaller glTF v, the normal maps' +Y)."""
    p = positions.astype(np.float64)
    t = uv.astype(np.float64) * [1.0, -1.0]  # (u, up the image)
    e1 = p[faces[:, 1]] - p[faces[:, 0]]
    e2 = p[faces[:, 2]] - p[faces[:, 0]]
    d1 = t[faces[:, 1]] - t[faces[:, 0]]
    d2 = t[faces[:, 2]] - t[faces[:, 0]]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    r = np.where(np.abs(det) > 1e-20, 1.0 / np.where(det == 0, 1.0, det), 0.0)[:, None]
    su = (e1 * d2[:, 1:] - e2 * d1[:, 1:]) * r
    sv = (e2 * d1[:, :1] - e1 * d2[:, :1]) * r
    tan = np.zeros_like(p)
    bit = np.zeros_like(p)
    for c in range(3):
        np.add.at(tan, faces[:, c], su)
        np.add.at(bit, faces[:, c], sv)
    n = normals.astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)
    tan -= n * np.sum(n * tan, axis=1, keepdims=True)
    length = np.linalg.norm(tan, axis=1, keepdims=True)
    # a vertex without a usable u direction (degenerate UVs): any unit vector orthogonal to n
    other = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    fallback = np.cross(n, other)
    tan = np.where(length > 1e-12, tan / np.maximum(length, 1e-20),
                   fallback / np.linalg.norm(fallback, axis=1, keepdims=True))
    w = np.where(np.sum(np.cross(n, tan) * bit, axis=1) < 0.0, -1.0, 1.0)
    return np.concatenate([tan, w[:, None]], axis=1).astype(np.float32)


def with_normal_texture(glb: bytes, png: bytes) -> bytes:
    """A GLB (one buffer, in its binary chunk) with ``png`` appended as an image and its
    first material's ``normalTexture`` (sampled as the base colour is), and TANGENT
    attributes on every primitive that lacks them (:func:`vertex_tangents`)."""
    json_len = struct.unpack_from("<I", glb, 12)[0]
    doc = json.loads(glb[20:20 + json_len])
    bin_start = 20 + json_len + 8
    binary = glb[bin_start:bin_start + struct.unpack_from("<I", glb, 20 + json_len)[0]]
    binary += b"\0" * (-len(binary) % 4)
    for mesh in doc["meshes"]:
        for prim in mesh["primitives"]:
            at = prim["attributes"]
            if "TANGENT" in at or not {"POSITION", "NORMAL", "TEXCOORD_0"} <= set(at):
                continue
            pos = _accessor(doc, binary, at["POSITION"])
            faces = _accessor(doc, binary, prim["indices"]).reshape(-1, 3).astype(np.int64) if "indices" in prim \
                else np.arange(len(pos)).reshape(-1, 3)
            tangents = vertex_tangents(pos, _accessor(doc, binary, at["NORMAL"]),
                                       _accessor(doc, binary, at["TEXCOORD_0"]), faces)
            doc["bufferViews"].append({"buffer": 0, "byteOffset": len(binary), "byteLength": tangents.nbytes,
                                       "target": 34962})
            binary += tangents.tobytes()
            doc["accessors"].append({"bufferView": len(doc["bufferViews"]) - 1, "componentType": 5126,
                                     "count": len(tangents), "type": "VEC4"})
            at["TANGENT"] = len(doc["accessors"]) - 1
    doc["bufferViews"].append({"buffer": 0, "byteOffset": len(binary), "byteLength": len(png)})
    binary += png + b"\0" * (-len(png) % 4)
    doc["buffers"][0]["byteLength"] = len(binary)
    doc.setdefault("images", []).append({"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/png"})
    texture: dict = {"source": len(doc["images"]) - 1}
    base = doc["materials"][0].get("pbrMetallicRoughness", {}).get("baseColorTexture")
    if base is not None and "sampler" in doc["textures"][base["index"]]:
        texture["sampler"] = doc["textures"][base["index"]]["sampler"]
    doc.setdefault("textures", []).append(texture)
    ref: dict = {"index": len(doc["textures"]) - 1}
    if base is not None and base.get("texCoord"):
        ref["texCoord"] = base["texCoord"]
    doc["materials"][0]["normalTexture"] = ref
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(text), b"JSON") + text
            + struct.pack("<I4s", len(binary), b"BIN\0") + binary)


def write_baked_relief(baked, path, *, strength: float = 1.0) -> Path:
    """Write ``baked`` as a GLB (``path``, atomically) whose material holds the base colour of
    :func:`warp_texton.write_baked` and the normal texture of :func:`baked_normals`.

    Parameters
    ----------
    baked : BakedMesh
    path : str or Path
        Ends in ``.glb``.
    strength : float
        > 0: the height of one standard deviation of the luminance, in texels of the texture.

    Returns
    -------
    Path
    """
    from ..core.errors import TextonError

    path = Path(path)
    if path.suffix.lower() != ".glb":
        raise TextonError(f"path must end in .glb, got {str(path)!r}", param="path")
    normals = np.round(baked_normals(baked, strength) * 255.0).astype(np.uint8)
    glb = with_normal_texture(export_mesh(baked.mesh, "glb", baked.up), png_bytes(normals))
    write_set({path: glb})
    return path
