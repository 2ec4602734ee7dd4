"""Benchmark: corner normals split by angle (``warp_texton.surface.mesh.corner_normals``) against
the render they feed and against trimesh's vertex normals.

Meshes: tori of about 16k and 262k faces (smooth: no edge sharper than 30°) and a
cylinder of 4096 sections (two cap fans of 4096 faces each, hard rims). For each,
in turns, ``--repeat`` times (best reported): trimesh's vertex normals (what the
renderer took before, with a per-pixel crease test), ``corner_normals`` (default
``normals="angle"``: positions joined, edges sorted, fans found as connected
components), and ``render_mesh`` at 512×384 (which computes them once). The
ratio says how much of a render the normals are.

    python benchmarks/bench_normals.py            # full run, writes results/normals.{json,md}
    python benchmarks/bench_normals.py --quick    # smoke run (CI): the small torus only
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, report_header, run_main  # noqa: E402

import numpy as np  # noqa: E402
import trimesh  # noqa: E402

from warp_texton import Texton, render_mesh  # noqa: E402
from warp_texton.surface.mesh import corner_normals  # noqa: E402
from warp_texton.core.runtime import resolve_device  # noqa: E402

SHAPE = (384, 512)


def meshes(quick: bool) -> dict:
    out = {"torus 16k": trimesh.creation.torus(1.0, 0.35, 128, 64)}
    if not quick:
        out["torus 262k"] = trimesh.creation.torus(1.0, 0.35, 512, 256)
        out["cylinder 4096 sections"] = trimesh.creation.cylinder(0.5, 1.5, sections=4096)
    return out


def fresh(mesh):
    """A copy without trimesh's caches (face normals, angles), as a mesh read from a file."""
    return trimesh.Trimesh(np.array(mesh.vertices), np.array(mesh.faces), process=False)


def run(args) -> dict:
    device = resolve_device(args.device)
    texton = Texton(np.random.default_rng(0).standard_normal((16, 16, 1)) / 16, [0.5])
    render_mesh(trimesh.creation.icosphere(1), texton, (16, 16), device=device)  # load the kernels
    rows = []
    for name, mesh in meshes(args.quick).items():
        times: dict[str, list] = {"vertex_normals": [], "corner_normals": [], "render": []}
        for _ in range(args.repeat):
            m = fresh(mesh)
            t0 = time.perf_counter()
            _ = m.vertex_normals
            times["vertex_normals"].append(time.perf_counter() - t0)
            m = fresh(mesh)
            t0 = time.perf_counter()
            corner_normals(m)
            times["corner_normals"].append(time.perf_counter() - t0)
            m = fresh(mesh)
            t0 = time.perf_counter()
            render_mesh(m, texton, SHAPE, device=device, mni=args.mni)
            times["render"].append(time.perf_counter() - t0)
        best = {k: min(v) for k, v in times.items()}
        rows.append({"mesh": name, "faces": len(mesh.faces), **{f"{k}_s": v for k, v in best.items()},
                     "share_of_render": best["corner_normals"] / best["render"]})
        print(f"  {name}: corner normals {best['corner_normals']:.3f} s, render {best['render']:.3f} s", flush=True)
    return {**report_header("normals", device),
            "parameters": {"shape": list(SHAPE), "mni": args.mni, "repeat": args.repeat, "quick": args.quick},
            "rows": rows}


def markdown(report: dict) -> str:
    lines = ["# Corner normals against the render they feed (512×384)", "",
             machine_line(report) + f" {report['date']}.", "",
             "| mesh | faces | trimesh vertex normals (s) | corner normals (s) | render (s) | normals / render |",
             "|---|---:|---:|---:|---:|---:|"]
    rows = [f"| {r['mesh']} | {r['faces']} | {r['vertex_normals_s']:.3f} | {r['corner_normals_s']:.3f} | "
            f"{r['render_s']:.3f} | {r['share_of_render']:.2f} |" for r in report["rows"]]
    return "\n".join(lines + rows) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "normals", run, markdown, argv, repeat=3, mni=60.0)


if __name__ == "__main__":
    sys.exit(main())
