"""UV atlases for baked textures: charts from normal clusters, packed by xatlas in a worker process;
and the checks of a mesh's own UVs (:func:`mesh_uvs`, :func:`check_uvs`).

A bake needs every triangle laid once in the unit square, without overlap,
with little stretch. xatlas (the ``mesh`` extra) charts and packs, but its
charting grows charts face by face under a cost of stretch, seams and
roundness: 35 to 45 s for the 100k faces of the Stanford bunny on two CPU
cores, seven times a whole 1024² bake (docs/benchmarks.md, "Atlases").
:func:`make_atlas` therefore charts by itself (``charts="normals"``, the
default) and asks xatlas only to pack:

1. each face takes the one of the six axis directions ±X, ±Y, ±Z closest to
   its normal (a cube map's rule); a few rounds of area-weighted majority
   votes among the faces sharing an edge smooth the labels of a noisy scan,
   a face keeping only labels within 72° of its normal (cos ≥ 0.3);
2. charts are the connected groups of faces with one label; each is
   projected orthographically along its direction, with the in-plane axes
   chosen so that the triangles keep their orientation (every normal points
   along the direction, so no triangle folds over, and the stretch is at most
   1/0.3 across the direction's slope);
3. xatlas packs the charts (``use_input_mesh_uvs``) at the bake's resolution
   with the gutter's padding.

A chart could still overlap itself (a helical surface seen along its axis):
:func:`warp_texton.bake_mesh` finds that when it rasterises the atlas and
makes xatlas's own atlas instead (``charts="xatlas"``).

xatlas runs in a separate process (``atlas_worker.py``) with a time limit and
a memory cap: a crash or an endless loop of the native code becomes one
:class:`TextonError` naming the mesh, and the batch goes on. The vertices it
gets are centred and scaled to the unit box in float64 before the cast to
float32, so coordinates that float64 holds but float32 does not (1e39) never
reach it as infinities.
"""

from __future__ import annotations

import io
import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np

from ..core.errors import TextonError
from ..core.limits import check_memory

#: How charts are made: by normal clusters, packed by xatlas; or xatlas's own charting.
CHART_METHODS = ("normals", "xatlas")
#: The six directions a face's normal is sorted into, and for each the in-plane
#: axes (u, v) with u × v = the direction, so that projected triangles keep their orientation.
DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float64)
U_AXES = np.array([[0, 1, 0], [0, 0, 1], [0, 0, 1], [1, 0, 0], [1, 0, 0], [0, 1, 0]], np.float64)
V_AXES = np.cross(DIRECTIONS, U_AXES)
#: A face may take a direction only within acos(0.3) = 72.5° of its normal (stretch ≤ 3.3).
MIN_COS = 0.3
#: Rounds of majority votes among neighbouring faces.
SMOOTHING_ROUNDS = 4
#: The worker's time limit: a base plus a share per face. xatlas's own charting took
#: 35-45 s for 100k faces on two shared cores, packing alone under 2 s (docs/benchmarks.md).
WORKER_SECONDS = 60.0
WORKER_SECONDS_PER_FACE = 2e-3
#: The environment variable that sets the base of the time limit instead of WORKER_SECONDS
#: (seconds; the share per face is added): a loaded machine or a slow one may need more.
SECONDS_ENV = "WARP_TEXTON_ATLAS_SECONDS"
#: The worker's memory (its address space): xatlas's peak per face (measured on the bunny's
#: 100k faces: 1.25 KB per face packing normal charts, 0.9 KB charting by itself; 28 MB without work) with
#: room, the packer's bit images of the atlas (a few bits per texel), a base for the
#: interpreter, and the stacks of xatlas's threads (one per core; 8 MiB each by default).
WORKER_BYTES_PER_FACE = 4096.0
WORKER_BYTES_PER_TEXEL = 4.0
WORKER_BASE_BYTES = 256 << 20
WORKER_BYTES_PER_THREAD = 16 << 20
#: What the worker holds (its peak resident memory), priced against the memory budget: the
#: measured 28 MB of an idle worker and 1.25 KB a face (packing normal charts), with room, and
#: the packer's bit images. The address-space cap above is larger: an interpreter with NumPy
#: maps far more than it touches.
WORKER_RESIDENT_BASE = 48 << 20
WORKER_RESIDENT_PER_FACE = 2560.0
WORKER_RESIDENT_PER_TEXEL = 1.0
WORKER = Path(__file__).with_name("atlas_worker.py")


def unit_box(vertices: np.ndarray, name: str) -> np.ndarray:
    """The vertices centred and scaled to the unit box, float32: what xatlas gets.

    Scaling first keeps coordinates that float64 holds but float32 does not
    (beyond 3.4e38) from reaching xatlas as infinities."""
    v = np.asarray(vertices, np.float64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    with np.errstate(over="ignore", invalid="ignore"):
        extent = float(np.max(hi - lo))
        centre = (lo + hi) / 2.0
        out = (v - centre) / extent if extent > 0 else v - centre
    if not (np.isfinite(extent) and np.isfinite(out).all()):
        raise TextonError(f"{name}: its vertices span more than float64 holds (extent {extent:.3g}); "
                          "an atlas cannot be made")
    return out.astype(np.float32)


def face_adjacency(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of faces sharing an edge, with vertices at the same position taken as one
    (a mesh read without merging, or split along seams, keeps its neighbours)."""
    _, key = np.unique(vertices, axis=0, return_inverse=True)
    g = key.ravel()[faces]
    edges = np.sort(np.concatenate([g[:, [0, 1]], g[:, [1, 2]], g[:, [2, 0]]]), axis=1)
    face = np.tile(np.arange(len(faces)), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, face = edges[order], face[order]
    same = np.all(edges[1:] == edges[:-1], axis=1)
    return face[:-1][same], face[1:][same]


def normal_charts(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(chart of each face, direction index of each chart): the charts of step 1-2 above."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    n_faces = len(faces)
    a, b = face_adjacency(vertices, faces)
    p = vertices[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area = np.linalg.norm(normal, axis=1)
    dots = (normal / np.where(area > 0, area, 1.0)[:, None]) @ DIRECTIONS.T
    label = np.argmax(dots, axis=1)
    adjacency = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(n_faces, n_faces)).tocsr()
    adjacency = adjacency + adjacency.T
    rows = np.arange(n_faces)
    allowed = dots >= MIN_COS
    allowed[rows, label] = True  # the closest direction is always allowed (a degenerate face has no normal)
    for _ in range(SMOOTHING_ROUNDS):
        own = sp.csr_matrix((area + 1e-300, (rows, label)), shape=(n_faces, 6))
        votes = (adjacency @ own).toarray() + own.toarray()
        votes[~allowed] = -1.0
        label = np.argmax(votes, axis=1)
    keep = label[a] == label[b]
    joined = sp.coo_matrix((np.ones(int(keep.sum())), (a[keep], b[keep])), shape=(n_faces, n_faces))
    n_charts, chart = connected_components(joined, directed=False)
    direction = np.empty(n_charts, np.int64)
    direction[chart] = label
    return chart, direction


def project_charts(vertices: np.ndarray, faces: np.ndarray, chart: np.ndarray, direction: np.ndarray):
    """(vertex map, faces, UVs): each vertex split once per chart it lies in, projected
    along its chart's direction (world units)."""
    n_charts = len(direction)
    pair = faces.ravel().astype(np.int64) * n_charts + np.repeat(chart, 3)
    unique, inverse = np.unique(pair, return_inverse=True)
    vmap = unique // n_charts
    d = direction[unique % n_charts]
    p = vertices[vmap]
    uv = np.stack([np.sum(p * U_AXES[d], axis=1), np.sum(p * V_AXES[d], axis=1)], axis=1)
    return vmap, inverse.reshape(-1, 3), uv


def mesh_uvs(mesh) -> np.ndarray | None:
    """The mesh's per-vertex UVs as float64 (V, 2), or None when it has none."""
    visual = getattr(mesh, "visual", None)
    uv = getattr(visual, "uv", None) if getattr(visual, "kind", None) == "texture" else None
    if uv is None:
        return None
    try:
        uv = np.asarray(uv, dtype=np.float64)
    except (TypeError, ValueError):
        raise TextonError("its UVs are not numbers") from None
    return uv


def check_uvs(uv: np.ndarray, vertices: int) -> np.ndarray:
    """UVs a bake can use: (V, 2), finite, inside [0, 1]² (a texture is not repeated)."""
    if uv.ndim != 2 or uv.shape != (vertices, 2):
        raise TextonError(f"its UVs have shape {uv.shape}, not one (u, v) per vertex ({vertices}, 2)")
    if not np.isfinite(uv).all():
        raise TextonError(f"its UVs hold {int((~np.isfinite(uv)).sum())} NaN or infinite values")
    lo, hi = uv.min(), uv.max()
    if lo < -1e-6 or hi > 1 + 1e-6:
        raise TextonError(f"its UVs reach [{lo:.3g}, {hi:.3g}], outside [0, 1]: a repeated texture cannot hold "
                          "a bake")
    return np.clip(uv, 0.0, 1.0)


#: Share of the faces (by 3-D area) whose UV triangles may have no area before a bake warns:
#: those parts of the surface get no texels of their own.
MAX_FLAT_SHARE = 0.0


def uv_face_areas(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The area of each face's UV triangle, in the unit square's units."""
    t = uv[faces]
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    return 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def uv_face_notes(uv: np.ndarray, faces: np.ndarray, vertices: np.ndarray) -> list[str]:
    """What a bake on checked UVs (:func:`check_uvs`) should warn about: faces with surface
    area whose UV triangles have none (that part of the surface gets no texels). UVs
    whose triangles have no area at all cannot hold a bake: refused."""
    flat = uv_face_areas(uv, faces) <= 1e-14
    if flat.all():
        raise TextonError("its UV triangles have no area (every face is laid on a line or a point of the "
                          "texture), so no texel would show the surface")
    p = vertices[faces]
    area3 = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    lost = float(area3[flat].sum()) / max(float(area3.sum()), 1e-300)
    if lost > MAX_FLAT_SHARE:
        return [f"{int(flat.sum())} of {len(faces)} faces ({100 * lost:.3g} % of the surface) have UV triangles "
                "without area, so those parts of the surface show no texels of their own; --uv atlas "
                "(uv='atlas') lays every face"]
    return []


def overlap_note(overlap: float) -> list[str]:
    """The warning for UVs that overlap a little (a bake refuses more than
    ``bake.MAX_OVERLAP``): each texel claimed twice shows one of its surfaces."""
    if overlap <= 0.0:
        return []
    return [f"its UVs overlap ({100 * overlap:.3g} % of the covered texels lie on two or more triangles, each "
            "showing one of them); --uv atlas (uv='atlas') makes charts that do not overlap"]


def uv_coverage(uvs, faces: np.ndarray) -> float:
    """The share of the texture that the faces' UV triangles cover, at most 1 (overlaps
    counted twice: an upper bound); 1 for UVs that :func:`check_uvs` will refuse."""
    t = np.asarray(uvs, np.float64)
    if t.ndim != 2 or t.shape[1] != 2 or not len(faces) or len(t) <= int(faces.max()):
        return 1.0
    with np.errstate(over="ignore", invalid="ignore"):
        e1, e2 = t[faces][:, 1] - t[faces][:, 0], t[faces][:, 2] - t[faces][:, 0]
        covered = float(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()) / 2.0
    return min(covered, 1.0) if np.isfinite(covered) else 1.0


def worker_base_seconds() -> float:
    """The base of the worker's time limit: $WARP_TEXTON_ATLAS_SECONDS, else WORKER_SECONDS."""
    text = os.environ.get(SECONDS_ENV)
    if text is None or not text.strip():
        return WORKER_SECONDS
    try:
        seconds = float(text)
    except ValueError:
        seconds = math.nan
    if not (math.isfinite(seconds) and seconds > 0):
        raise TextonError(f"{SECONDS_ENV}: {text!r:.40} is not a number of seconds > 0")
    return seconds


def worker_limits(n_faces: int, resolution: int) -> tuple[float, float]:
    """(seconds, bytes) that the worker may take for a mesh of ``n_faces`` at ``resolution``²:
    a base (:func:`worker_base_seconds`) plus a share per face, and the memory cap."""
    seconds = worker_base_seconds() + WORKER_SECONDS_PER_FACE * n_faces
    nbytes = (WORKER_BASE_BYTES + WORKER_BYTES_PER_THREAD * (os.cpu_count() or 1) + WORKER_BYTES_PER_FACE * n_faces
              + WORKER_BYTES_PER_TEXEL * resolution ** 2)
    return seconds, nbytes


def run_worker(payload: dict, n_faces: int, resolution: int, name: str) -> dict:
    """Run ``atlas_worker.py`` on ``payload``; its death, time-out or bad output is a
    :class:`TextonError` naming the mesh."""
    seconds, nbytes = worker_limits(n_faces, resolution)
    resident = WORKER_RESIDENT_BASE + WORKER_RESIDENT_PER_FACE * n_faces + WORKER_RESIDENT_PER_TEXEL * resolution ** 2
    check_memory(resident, f"{name}: a UV atlas of {n_faces} faces", "give the mesh UVs, or simplify it")
    buf = io.BytesIO()
    np.savez(buf, **payload)
    try:
        # subprocess.run kills the worker (SIGKILL) on a time-out or Ctrl-C: xatlas ignores SIGTERM
        proc = subprocess.run([sys.executable, str(WORKER), str(int(nbytes))], input=buf.getvalue(),
                              capture_output=True, timeout=seconds)
    except subprocess.TimeoutExpired:
        raise TextonError(f"{name}: xatlas made no atlas within {seconds:.0f} s and was stopped; give the mesh UVs "
                          f"(--uv mesh), simplify it, or allow more time ({SECONDS_ENV})") from None
    if proc.returncode < 0:
        sig = signal.Signals(-proc.returncode).name if -proc.returncode in signal.valid_signals() else "a signal"
        raise TextonError(f"{name}: xatlas crashed making the UV atlas ({sig}); give the mesh UVs or try "
                          "the other charting (--charts)")
    if proc.returncode != 0:
        last = (proc.stderr.decode("utf-8", "replace").strip().splitlines() or ["no message"])[-1]
        # an allocation or a thread's stack refused under the cap
        if any(word in last for word in ("MemoryError", "bad_alloc", "Resource temporarily unavailable")):
            last = f"over its memory cap of {nbytes / (1 << 20):.0f} MiB"
        raise TextonError(f"{name}: xatlas failed making the UV atlas ({last[:200]})")
    try:
        out = np.load(io.BytesIO(proc.stdout))
        return {k: out[k] for k in ("vmap", "faces", "uv", "utilization")}
    except Exception:
        raise TextonError(f"{name}: xatlas's worker gave no atlas") from None


def make_atlas(vertices: np.ndarray, faces: np.ndarray, resolution: int, padding: int, *,
               charts: str = "normals", name: str = "mesh", step=None):
    """A UV atlas: (vertex map into ``vertices``, faces, UVs in [0, 1]², xatlas's utilization).

    ``charts`` is "normals" (clusters of normals, packed by xatlas) or "xatlas"
    (xatlas's own charting); ``padding`` texels separate the charts at
    ``resolution``². ``step()``, when given, is called after the charting and
    after the packing (a progress bar's update). Raises :class:`TextonError`
    naming the mesh (``name``) when xatlas is missing, crashes, runs past its
    time limit or over its memory.
    """
    import importlib.util

    if charts not in CHART_METHODS:
        raise TextonError(f"charts must be one of {', '.join(CHART_METHODS)}, got {charts!r:.40}")
    if importlib.util.find_spec("xatlas") is None:
        raise TextonError("making a UV atlas needs the xatlas package: pip install 'warp-texton[mesh]' "
                          "(or give a mesh with UVs)")
    step = step or (lambda: None)
    faces = np.asarray(faces, np.int64)
    unit = unit_box(vertices, name)
    payload: dict = {"resolution": int(resolution), "padding": int(padding)}
    if charts == "normals":
        chart, direction = normal_charts(unit.astype(np.float64), faces)
        split, split_faces, uv = project_charts(unit.astype(np.float64), faces, chart, direction)
        payload.update(vertices=unit[split], faces=split_faces.astype(np.uint32), uv=uv.astype(np.float32))
    else:
        split = np.arange(len(unit))
        payload.update(vertices=unit, faces=faces.astype(np.uint32))
    step()
    out = run_worker(payload, len(faces), resolution, name)
    step()
    vmap = split[np.asarray(out["vmap"], np.int64)]
    return vmap, np.asarray(out["faces"], np.int64), np.asarray(out["uv"], np.float64), float(out["utilization"])
