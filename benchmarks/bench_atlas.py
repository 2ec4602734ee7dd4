"""Benchmark: UV atlases for bakes, a whole bake against a re-bake from the mesh's own UVs.

The Stanford bunny as pymeshfix ships it (a range scan, about 100k faces,
Z up) baked at 1024² (``bake_mesh``, default texel size: the diagonal / 256):

* with an atlas charted by normal clusters and packed by xatlas
  (``charts="normals"``, the default), and with xatlas's own charting
  (``charts="xatlas"``);
* then re-baked from the UVs of that bake (``uv="mesh"``): the cost of the bake
  alone, the yardstick (goal: a bake with its atlas within 3× of it);
* and, for each atlas, its coverage (the share of the texels on a triangle)
  and the vertices it splits along the charts' seams.

Runs take turns (the whole bake, then the re-bake, ``--repeat`` times; best
reported). ``--quick``: a torus of about 5,000 faces at 256², normal charts only.

    python benchmarks/bench_atlas.py            # full run, writes results/atlas.{json,md}
    python benchmarks/bench_atlas.py --quick    # smoke run (CI)
"""

from __future__ import annotations

import importlib.util
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

import trimesh  # noqa: E402

from warp_texton import analyze, bake_mesh  # noqa: E402
from warp_texton.surface.mesh import default_texel_size  # noqa: E402
from warp_texton.core.runtime import resolve_device  # noqa: E402


def bunny():
    """The Stanford bunny shipped by pymeshfix (imported by path only: pymeshfix needs VTK), or None."""
    spec = importlib.util.find_spec("pymeshfix")
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(spec.submodule_search_locations[0]) / "examples" / "StanfordBunny.ply"
    return trimesh.load(path, process=False) if path.is_file() else None


def measure(texton, mesh, res: int, device, *, repeat: int, mni: float, chartings=("normals", "xatlas")) -> list:
    """Per charting: the best of ``repeat`` whole bakes (atlas included) and re-bakes from the UVs
    made, taking turns, with the coverage and the vertices split along the seams."""
    texel = default_texel_size(mesh)
    bake_mesh(trimesh.creation.icosphere(1), texton, 0.1, resolution=32, device=device)  # load the kernels
    rows = []
    for charts in chartings:
        whole, again = [], []
        for _ in range(repeat if charts == "normals" else 1):
            t0 = time.perf_counter()
            baked = bake_mesh(mesh, texton, texel, resolution=res, mni=mni, device=device, charts=charts, up="z")
            whole.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            bake_mesh(baked.mesh, texton, texel, resolution=res, mni=mni, device=device, uv="mesh", up="z")
            again.append(time.perf_counter() - t0)
        rows.append({"charts": charts, "bake_s": min(whole), "rebake_s": min(again),
                     "ratio": min(whole) / min(again), "coverage": baked.covered,
                     "vertices_out": len(baked.mesh.vertices), "vertices_in": len(mesh.vertices)})
    return rows


def subject(quick: bool):
    """(mesh, name, resolution): the bunny at 1024², or (quick, or without pymeshfix) a torus at 256²."""
    mesh = None if quick else bunny()
    if mesh is None:
        return trimesh.creation.torus(1.0, 0.35, major_sections=64, minor_sections=40), "torus", 256
    return mesh, "Stanford bunny (pymeshfix)", 1024


def run(args) -> dict:
    device = resolve_device(args.device)
    texton = analyze(make_texture(256), size=args.size, seed=0)
    mesh, name, res = subject(args.quick)
    chartings = ("normals",) if args.quick else ("normals", "xatlas")
    rows = measure(texton, mesh, res, device, repeat=args.repeat, mni=args.mni, chartings=chartings)
    for row in rows:
        print(f"  {row['charts']}: bake {row['bake_s']:.2f} s, re-bake {row['rebake_s']:.2f} s "
              f"(x{row['ratio']:.2f}), coverage {100 * row['coverage']:.1f} %", flush=True)
    return {
        **report_header("atlas", device),
        "parameters": {"mesh": name, "faces": len(mesh.faces), "resolution": res,
                       "texel_size": default_texel_size(mesh), "texton": list(texton.size), "mni": args.mni,
                       "repeat": args.repeat, "quick": args.quick},
        "rows": rows,
    }


def markdown(report: dict) -> str:
    p = report["parameters"]
    lines = [f"# Atlases: {p['mesh']}, {p['faces']} faces, baked at {p['resolution']}²", "",
             machine_line(report) + f" {report['date']}.", "",
             "| charts | bake with atlas (s) | re-bake from its UVs (s) | ratio | coverage | vertices (in → out) |",
             "|---|---:|---:|---:|---:|---|"]
    rows = [f"| {r['charts']} | {r['bake_s']:.2f} | {r['rebake_s']:.2f} | {r['ratio']:.2f} | "
            f"{100 * r['coverage']:.1f} % | {r['vertices_in']} → {r['vertices_out']} |" for r in report["rows"]]
    return "\n".join(lines + rows) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "atlas", run, markdown, argv, repeat=2, mni=60.0)


if __name__ == "__main__":
    sys.exit(main())
