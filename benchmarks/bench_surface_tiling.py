"""Benchmark: tiling models on surfaces without UVs: triplanar projection against tangent frames, and cost.

Measures, on meshes with curvature (icosphere, capsule, torus, the Stanford
bunny, a range scan, as pymeshfix ships it), subdivided until edges are at most one texel, the tiling model of
scikit-image's ``brick`` (``analyze(..., method="tiling")``, defaults):

* **stretch**: at each vertex, the 2 × 2 map from the surface (a tangent frame,
  texels) to the example's plane (texels), fitted by least squares to the
  vertex's edges; its singular values σ1 ≥ σ2 say how much the example is
  stretched (1/σ2) or squeezed (σ1) there. Reported: the share of vertices
  where the example is stretched or squeezed by more than 1.5× (max(σ1, 1/σ2) > 1.5)
  and the 99th percentile of max(σ1, 1/σ2). Triplanar reads the dominant plane;
  "frames" reads (⟨p, u1⟩, ⟨p, u2⟩) with the frame rule's tangents, as texton
  surface noise lays its texton (``tangent_frames``).
* **seams**: the values' jump across an edge per texel of its length, at the
  99.9th percentile, over the same measure on a flat grid of the planar tiling
  at the same spacing (1: no seam sharper than the example's own edges).
* **blend**: the share of vertices in a blend zone (no plane weight above 0.8)
  and the values' standard deviation there over the example's (1: contrast kept).
* **cost**: ``surface_noise`` of the tiling model against texton noise (MNI 60,
  the surface default, a 32² texton of the same example) at the same points,
  interleaved.

    python benchmarks/bench_surface_tiling.py            # full run, writes results/
    python benchmarks/bench_surface_tiling.py --quick    # smoke run
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, report_header, run_main  # noqa: E402

import numpy as np  # noqa: E402
import trimesh  # noqa: E402

from warp_texton import analyze, evaluate, surface_noise, tangent_frames  # noqa: E402
from warp_texton.core.runtime import resolve_device  # noqa: E402
from warp_texton.surface.tiling import TRIPLANAR_SHARPNESS, plane_seeds  # noqa: E402

SHARPNESSES = (2, 4, 8, 16, 32)


def meshes(quick: bool) -> dict:
    """Name -> (mesh, texel size): 64 texels per unit of the primitives (the sphere's radius), the bunny 256 along its diagonal."""
    import importlib.util

    # the Stanford bunny (a range scan, Z up) as pymeshfix ships it; no import: pymeshfix needs VTK
    spec = importlib.util.find_spec("pymeshfix")
    assert spec is not None and spec.submodule_search_locations, "pip install pymeshfix (its example bunny)"
    bunny = trimesh.load(Path(spec.submodule_search_locations[0]) / "examples" / "StanfordBunny.ply", force="mesh")
    out = {
        "sphere": (trimesh.creation.icosphere(subdivisions=3), 1 / 64),
        "capsule": (trimesh.creation.capsule(height=2.0, radius=0.5, count=[32, 32]), 1 / 64),
        "torus": (trimesh.creation.torus(major_radius=1.0, minor_radius=0.35), 1 / 64),
        "Stanford bunny (scan)": (bunny, float(np.linalg.norm(bunny.extents)) / 256),
    }
    if quick:
        out = {k: (m, t * 4) for k, (m, t) in out.items()}
    return out


def fine(mesh: trimesh.Trimesh, texel: float) -> trimesh.Trimesh:
    v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=texel, max_iter=12)
    return trimesh.Trimesh(v, f, process=True)


def axes_planes(p: np.ndarray, n: np.ndarray):
    """The three planes' coordinates (N, 2) each, as kernels/surface_tiling.py maps them (Z up)."""
    x1 = np.where((n[:, 0] < 0)[:, None], np.c_[-p[:, 1], -p[:, 2]], np.c_[p[:, 1], -p[:, 2]])
    x2 = np.where((n[:, 1] < 0)[:, None], np.c_[p[:, 0], -p[:, 2]], np.c_[-p[:, 0], -p[:, 2]])
    x3 = np.where((n[:, 2] < 0)[:, None], np.c_[p[:, 0], p[:, 1]], np.c_[p[:, 0], -p[:, 1]])
    return x1, x2, x3


def weights(n: np.ndarray, sharpness: int) -> np.ndarray:
    k = np.abs(n) ** sharpness
    k[k < 1e-4 * k.max(axis=1, keepdims=True)] = 0.0
    return k / k.sum(axis=1, keepdims=True)


def stretch(mesh: trimesh.Trimesh, coords: np.ndarray, texel: float, plane=None) -> np.ndarray:
    """max(σ1, 1/σ2) per vertex of the least-squares map surface -> plane (texels); ``coords``
    (N, 2), or (P, N, 2) with ``plane`` (N,) the plane each vertex reads its edges in."""
    n = np.asarray(mesh.vertex_normals)
    u1, u2 = tangent_frames(n)
    e = np.asarray(mesh.edges_unique)
    e = np.r_[e, e[:, ::-1]]
    d3 = (mesh.vertices[e[:, 1]] - mesh.vertices[e[:, 0]]) / texel
    t = np.stack([np.einsum("nd,nd->n", d3, u1[e[:, 0]]), np.einsum("nd,nd->n", d3, u2[e[:, 0]])], 1)
    if plane is None:
        dc = coords[e[:, 1]] - coords[e[:, 0]]
    else:  # both ends in the plane of the edge's first vertex
        dc = coords[plane[e[:, 0]], e[:, 1]] - coords[plane[e[:, 0]], e[:, 0]]
    # normal equations per vertex: J = (Σ dc tᵀ)(Σ t tᵀ)⁻¹
    tt = np.zeros((len(n), 2, 2))
    ct = np.zeros((len(n), 2, 2))
    np.add.at(tt, e[:, 0], t[:, :, None] * t[:, None, :])
    np.add.at(ct, e[:, 0], dc[:, :, None] * t[:, None, :])
    ok = np.linalg.det(tt) > 1e-9
    J = ct[ok] @ np.linalg.inv(tt[ok])
    s = np.linalg.svd(J, compute_uv=False)
    return np.maximum(s[:, 0], 1.0 / np.maximum(s[:, 1], 1e-9))


def seam(mesh: trimesh.Trimesh, values: np.ndarray, texel: float) -> float:
    e = np.asarray(mesh.edges_unique)
    length = np.linalg.norm(mesh.vertices[e[:, 1]] - mesh.vertices[e[:, 0]], axis=1) / texel
    jump = np.abs(values[e[:, 1]] - values[e[:, 0]]).max(axis=1) / np.maximum(length, 1e-9)
    return float(np.percentile(jump, 99.9))


def flat_seam(model, spacing: float) -> float:
    """The same measure on a flat equilateral grid of the planar tiling (no seam at all)."""
    side = 400
    j, i = np.meshgrid(np.arange(side), np.arange(side))
    p = np.stack([(j + 0.5 * (i % 2)) * spacing, i * spacing * np.sqrt(3) / 2], -1).reshape(-1, 2)
    v = evaluate(model, p, seed=3, device="cpu").reshape(side, side, -1)
    jumps = [np.abs(v[:, 1:] - v[:, :-1]).max(axis=2).ravel(), np.abs(v[1:] - v[:-1]).max(axis=2).ravel()]
    return float(np.percentile(np.concatenate(jumps), 99.9)) / spacing


def quality(model, quick: bool) -> list[dict]:
    rows = []
    sd = float(model.example.std())
    assert model.blend == "variance"
    for name, (mesh, texel) in meshes(quick).items():
        m = fine(mesh, texel)
        p, n = np.asarray(m.vertices) / texel, np.asarray(m.vertex_normals)
        spacing = float(np.median(m.edges_unique_length)) / texel
        base = flat_seam(model, spacing)
        planes = axes_planes(p, n)
        dominant = np.argmax(np.abs(n), axis=1)
        sx = stretch(m, np.stack(planes), texel, dominant)
        seeds = plane_seeds(3)
        plane_values = [evaluate(model, x, seed=s, device="cpu") for x, s in zip(planes, seeds)]
        mean = model.example.mean(axis=(0, 1))
        for k in SHARPNESSES:
            w = weights(n, k)
            acc = sum(w[:, [a]] * (plane_values[a] - mean) for a in range(3))
            vals = mean + acc / np.sqrt((w ** 2).sum(axis=1, keepdims=True))
            if k == TRIPLANAR_SHARPNESS:  # this replica against the package's kernel
                check = float(np.abs(vals - surface_noise(model, m.vertices, n, texel, seed=3, device="cpu")).max())
            zone = w.max(axis=1) < 0.8
            rows.append({"mesh": name, "method": f"triplanar, sharpness {k}", "vertices": len(p),
                         "stretched_share": float(np.mean(sx > 1.5)), "stretch_p99": float(np.percentile(sx, 99)),
                         "seam": seam(m, vals, texel) / base, "blend_share": float(np.mean(zone)),
                         "blend_contrast": float(vals[zone].std() / sd) if zone.any() else float("nan"),
                         "replica_error": check if k == TRIPLANAR_SHARPNESS else None})
        u1, u2 = tangent_frames(n)
        fc = np.stack([np.einsum("nd,nd->n", p, u1), np.einsum("nd,nd->n", p, u2)], 1)
        sf = stretch(m, fc, texel)
        vals = evaluate(model, fc, seed=3, device="cpu")
        rows.append({"mesh": name, "method": "tangent frames", "vertices": len(p),
                     "stretched_share": float(np.mean(sf > 1.5)), "stretch_p99": float(np.percentile(sf, 99)),
                     "seam": seam(m, vals, texel) / base, "blend_share": 0.0, "blend_contrast": float("nan")})
    return rows


def unrolled_points(centre: np.ndarray, radius: float, side: int):
    """A side² grid of texel spacing on a sphere (radius in texels) around the direction ``centre``
    (with positive components), laid by the exponential map with its columns and rows along the
    axes the dominant plane reads the example's x and y on: (points, normals)."""
    c = centre / np.linalg.norm(centre)
    # the image's axes are those the dominant plane reads (the floor's on ties), laid on the tangent plane
    k = 2 if abs(c[2]) >= np.abs(c).max() else int(np.argmax(np.abs(c)))
    x_axis, y_axis = {0: ([0, 1, 0], [0, 0, -1]), 1: ([-1, 0, 0], [0, 0, -1]), 2: ([1, 0, 0], [0, -1, 0])}[k]
    a = np.array(x_axis, float) - c * (c @ x_axis)
    a /= np.linalg.norm(a)
    b = np.array(y_axis, float) - c * (c @ y_axis)
    b -= a * (a @ b)
    b /= np.linalg.norm(b)
    j, i = np.meshgrid(np.arange(side) - side / 2 + 0.5, np.arange(side) - side / 2 + 0.5)
    r = np.hypot(j, i).ravel() / radius
    d = (np.outer(j.ravel(), a) + np.outer(i.ravel(), b)) / np.maximum(np.hypot(j, i).ravel(), 1e-12)[:, None]
    n = c * np.cos(r)[:, None] + d * np.sin(r)[:, None]
    return radius * n, n


def triplanar_replica(model, p, n, sharpness: int, seed: int) -> np.ndarray:
    planes = axes_planes(p, n)
    values = [evaluate(model, x, seed=s, device="cpu") for x, s in zip(planes, plane_seeds(seed))]
    w = weights(n, sharpness)
    mean = model.example.mean(axis=(0, 1))
    return mean + sum(w[:, [a]] * (values[a] - mean) for a in range(3)) / np.sqrt((w ** 2).sum(axis=1,
                                                                                             keepdims=True))


def unrolled(model, quick: bool) -> list[dict]:
    """Patch distance (docs/tiling.md's measure, over the example's half-to-half distance) of
    the surface's values unrolled from a sphere of radius 256 texels by the exponential map,
    around a face (one plane), an edge (two planes blend) and a corner (three) of the triplanar
    projection; seeds 1-3. The planar tiling's own distance is the row "plane"."""
    from warp_texton import synthesize
    from warp_texton.model.tiling import half_distance, patch_distance

    side = 128 if quick else 256
    floor = half_distance(model.example)
    seeds = (1,) if quick else (1, 2, 3)
    # the plane at scale 1 reads the example's texels themselves; turned, it reads between them (bilinear),
    # as a curved surface does
    rows = [{"where": "plane", "method": f"planar tiling{', turned 10°' if turn else ''}", "distance": float(np.mean(
        [patch_distance(synthesize(model, (side, side), seed=s, rotation=turn, device="cpu"), model.example)
         for s in seeds])) / floor} for turn in (0.0, 10.0)]
    for where, c in (("face", [0.0, 0.0, 1.0]), ("edge", [1.0, 0.0, 1.0]), ("corner", [1.0, 1.0, 1.0])):
        p, n = unrolled_points(np.array(c), 256.0, side)
        u1, u2 = tangent_frames(n)
        methods = {f"triplanar, sharpness {k}": (lambda s, k=k: triplanar_replica(model, p, n, k, s))
                   for k in SHARPNESSES}
        methods["tangent frames"] = lambda s: evaluate(
            model, np.stack([np.einsum("nd,nd->n", p, u1), np.einsum("nd,nd->n", p, u2)], 1), seed=s, device="cpu")
        for name, fn in methods.items():
            d = np.mean([patch_distance(fn(s).reshape(side, side, -1), model.example) for s in seeds])
            rows.append({"where": where, "method": name, "distance": float(d) / floor})
    return rows


def cost(model, texton, repeat: int, device: str, quick: bool) -> dict:
    s = trimesh.creation.icosphere(subdivisions=5 if quick else 7)
    pts, nrm = s.vertices, s.vertex_normals
    runs = {"tiling": lambda: surface_noise(model, pts, nrm, 1 / 128, seed=1, device=device),
            "texton MNI 60": lambda: surface_noise(texton, pts, nrm, 1 / 128, seed=1, device=device)}
    for fn in runs.values():
        fn()
    times: dict = {k: [] for k in runs}
    for _ in range(repeat):
        for k, fn in runs.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    out = {k: {"best_s": min(v), "median_s": statistics.median(v)} for k, v in times.items()}
    out["points"] = len(pts)
    out["ratio_best"] = out["tiling"]["best_s"] / out["texton MNI 60"]["best_s"]
    return out


def run(args) -> dict:
    from skimage import data

    device = resolve_device(args.device)
    brick = data.brick().astype(np.float32) / 255.0
    model = analyze(brick, method="tiling")
    texton = analyze(brick, size=32)
    report = report_header("surface_tiling", device)
    report["texture"] = "scikit-image data.brick (512², grey, CC0), analyze(method='tiling') defaults"
    report["quality"] = quality(model, args.quick)
    report["unrolled"] = unrolled(model, args.quick)
    report["cost"] = cost(model, texton, args.repeat, device, args.quick)
    return report


def markdown(report: dict) -> str:
    lines = ["## Tiling models on surfaces", "", machine_line(report), "", report["texture"], "",
             "| mesh | method | vertices | stretched > 1.5× | stretch p99 | seam (flat = 1) | blend share | "
             "blend contrast |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in report["quality"]:
        lines.append(f"| {r['mesh']} | {r['method']} | {r['vertices']} | {100 * r['stretched_share']:.1f} % | "
                     f"{r['stretch_p99']:.2f} | {r['seam']:.2f} | {100 * r['blend_share']:.1f} % | "
                     f"{r['blend_contrast']:.2f} |")
    lines += ["", "Patch distance of the values unrolled from a sphere of radius 256 texels (over the example's "
              "half-to-half distance; mean of seeds 1-3):", "", "| where | method | distance |", "|---|---|---:|"]
    for r in report["unrolled"]:
        lines.append(f"| {r['where']} | {r['method']} | {r['distance']:.3f} |")
    c = report["cost"]
    lines += ["", f"surface_noise at {c['points']} points: tiling {1e3 * c['tiling']['best_s']:.1f} ms, texton "
              f"noise MNI 60 {1e3 * c['texton MNI 60']['best_s']:.1f} ms (best of interleaved runs): "
              f"ratio {c['ratio_best']:.3f}", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(run_main(__doc__, "surface_tiling", run, markdown, repeat=5))
