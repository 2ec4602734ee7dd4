"""The process that runs xatlas for :mod:`warp_texton.surface.atlas`: ``python atlas_worker.py LIMIT``.

xatlas is native code: on some meshes it has crashed (a segmentation fault)
or looped without end, ignoring SIGINT and SIGTERM. It therefore runs here, in
a process of its own that the caller can kill and whose death it reports as
one line for that mesh. Run as a script (never imported by the package, so it
starts without Warp): it reads an ``.npz`` from stdin (``vertices`` float32
(V, 3), ``faces`` uint32 (F, 3), optional ``uv`` float32 (V, 2) charts to pack
as they are, ``resolution``, ``padding``), caps its own address space at
``LIMIT`` bytes (argument 1; 0: no cap) and writes an ``.npz`` to stdout:
``vmap`` (output vertex → input vertex), ``faces``, ``uv`` in [0, 1]² and
``utilization`` (xatlas's share of the atlas covered by charts).
"""

from __future__ import annotations

import io
import sys

import numpy as np


def generate(vertices: np.ndarray, faces: np.ndarray, uv, resolution: int, padding: int):
    """(vmap, faces, uv, utilization) of an xatlas atlas: its own charts when ``uv`` is
    None, else the charts of ``uv`` packed as they are."""
    import xatlas

    atlas = xatlas.Atlas()
    chart = xatlas.ChartOptions()
    if uv is None:
        atlas.add_mesh(vertices, faces)
    else:
        atlas.add_mesh(vertices, faces, None, uv)
        chart.use_input_mesh_uvs = True
    pack = xatlas.PackOptions()
    pack.resolution = int(resolution)
    pack.padding = int(padding)
    pack.bilinear = True
    atlas.generate(chart, pack)
    vmap, new_faces, new_uv = atlas[0]
    return vmap, new_faces, new_uv, float(atlas.utilization)


def _cap_memory(limit: int) -> None:
    if limit <= 0:
        return
    import resource

    # on top of what the interpreter and its libraries already map
    with open("/proc/self/statm") as f:
        mapped = int(f.read().split()[0]) * resource.getpagesize()
    resource.setrlimit(resource.RLIMIT_AS, (mapped + limit, mapped + limit))


def main() -> int:
    import xatlas  # noqa: F401  (loaded before the cap: its mapping is not the atlas's memory)

    data = np.load(io.BytesIO(sys.stdin.buffer.read()))
    _cap_memory(int(sys.argv[1]) if len(sys.argv) > 1 else 0)
    uv = data["uv"] if "uv" in data.files else None
    vmap, faces, uv, used = generate(data["vertices"], data["faces"], uv, int(data["resolution"]),
                                     int(data["padding"]))
    out = io.BytesIO()
    np.savez(out, vmap=vmap, faces=faces, uv=uv, utilization=used)
    sys.stdout.buffer.write(out.getvalue())
    return 0


if __name__ == "__main__":
    sys.exit(main())
