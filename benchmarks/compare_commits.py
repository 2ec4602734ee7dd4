"""The hot paths of two commits, timed in one run, interleaved.

A change must not make the engine slower, and this machine is shared and
noisy: timing the previous commit yesterday and this one today says little.
This script installs the package of ``--base`` (default ``HEAD~1``) into a
temporary virtual environment, then runs the same timing program alternately
under the base and under the current checkout, ``--rounds`` times each, in
fresh processes, and reports each case's best and median time and the ratio
new / base.

Only calls whose signatures both commits share are timed: plain, rotated and
mixed rasters, points, the filtered plane, surface points and mesh renders
(and, in full runs, surface noise at the 1M vertices of a torus and a 1024²
render of an icosphere of 40 962 vertices).

Usage::

    python benchmarks/compare_commits.py --base 9f79d50            # table + results/compare_commits.json
    python benchmarks/compare_commits.py --base HEAD~3 --quick --out /tmp/cmp
    python benchmarks/compare_commits.py --base 3c913e1 --clock cpu    # CPU seconds instead of wall-clock
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from common import report_header, write_atomic  # noqa: E402

#: The timing program, run in a fresh interpreter under each commit. It prints one JSON
#: object: case -> seconds (best of ``reps`` inside the process, after a warm-up call).
TIMING = r"""
import json, sys, time
import numpy as np
import trimesh
import warp_texton as wt
quick = sys.argv[1] == "1"
clock = time.process_time if sys.argv[2:] == ["cpu"] else time.perf_counter
reps = 2 if quick else 3
side = 512 if quick else 1024
rng = np.random.default_rng(0)
t = wt.Texton(0.02 * rng.standard_normal((64, 64, 3)) + 0.001, [0.5] * 3)
ts = [wt.Texton(0.02 * rng.standard_normal((32, 32, 3)), [0.3 + 0.1 * k] * 3) for k in range(5)]
pts = rng.uniform(-5000, 5000, (100_000 if quick else 400_000, 2))
mesh = trimesh.creation.torus(1.0, 0.35, major_sections=96 if quick else 192, minor_sections=48 if quick else 96)
normals = np.asarray(mesh.vertex_normals)
big = trimesh.creation.torus(1.0, 0.35, major_sections=1000, minor_sections=1000)
big_normals = np.asarray(big.vertex_normals)
sphere = trimesh.creation.icosphere(subdivisions=6)
cases = {
    "raster grid": lambda: wt.synthesize(t, (side, side), mni=30.0, seed=1, device="cpu"),
    "raster 4K": lambda: wt.synthesize(t, (2160, 3840), mni=30.0, seed=1, device="cpu") if not quick else None,
    "raster rotated": lambda: wt.synthesize(t, (side, side), mni=30.0, seed=1, scale=0.8, rotation=30.0, device="cpu"),
    "raster mixed": lambda: wt.synthesize_mixed(ts, "strips", (side, side), mni=30.0, seed=1, device="cpu"),
    "points": lambda: wt.evaluate(t, pts, mni=30.0, seed=1, device="cpu"),
    "plane mip": lambda: wt.render_plane(t, (side // 2, side // 2), filter="mip", device="cpu"),
    "plane anisotropic": lambda: wt.render_plane(t, (side // 2, side // 2), filter="anisotropic", device="cpu"),
    "surface points": lambda: wt.surface_noise(t, mesh.vertices, normals, 0.01, device="cpu"),
    "render mesh": lambda: wt.render_mesh(mesh, t, (side // 2, side // 2), device="cpu"),
    # the surface targets: noise at 1M points, a 1024² render (full runs only)
    "surface 1M points": lambda: wt.surface_noise(t, big.vertices, big_normals, 0.004, device="cpu") if not quick
    else None,
    "render mesh 1024²": lambda: wt.render_mesh(sphere, t, (1024, 1024), texel_size=1 / 128, device="cpu") if not quick
    else None,
}
out = {}
for name, fn in cases.items():
    fn()
    best = float("inf")
    for _ in range(reps):
        t0 = clock(); r = fn(); best = min(best, clock() - t0)
    if r is not None or not quick:
        out[name] = best
print(json.dumps(out))
"""


def install_base(base: str, folder: Path) -> Path:
    """A virtual environment (seeing this Python's packages) with the package of ``base`` installed."""
    src = folder / "src"
    src.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", base], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive, check=True)
    venv = folder / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    python = venv / "bin" / "python"
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", str(src)],
                   check=True)
    return python


def timed(python: Path, quick: bool, cwd: Path, clock: str = "wall") -> dict:
    done = subprocess.run([str(python), "-c", TIMING, "1" if quick else "0", clock], capture_output=True, text=True,
                          cwd=cwd, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--base", default="HEAD~1", help="the commit to compare the checkout with")
    parser.add_argument("--rounds", type=int, default=3, help="alternating runs of each commit")
    parser.add_argument("--quick", action="store_true", help="smaller cases, fewer repetitions")
    parser.add_argument("--out", type=Path, default=HERE / "results", help="folder for compare_commits.json")
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                        help="wall-clock time, or the CPU time of the process (all its threads): steadier on a "
                             "machine that others load")
    args = parser.parse_args(argv)
    base = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.base], capture_output=True,
                          text=True, check=True).stdout.strip()
    runs = {"base": [], "new": []}
    with tempfile.TemporaryDirectory() as tmp:
        print(f"installing {base} into a temporary environment...", flush=True)
        old = install_base(args.base, Path(tmp))
        for r in range(args.rounds):
            for which, python, cwd in (("base", old, Path(tmp)), ("new", Path(sys.executable), ROOT)):
                runs[which].append(timed(python, args.quick, cwd, args.clock))
                print(f"  round {r + 1}/{args.rounds}: {which} done", flush=True)
    report = report_header("compare_commits", "cpu")
    report.update(base=base, rounds=args.rounds, quick=args.quick, clock=args.clock, cases={})
    lines = [f"{'case':<20} {'base best':>10} {'new best':>10} {'ratio':>6} {'base med':>10} {'new med':>10}"]
    for case in runs["base"][0]:
        b = [r[case] for r in runs["base"]]
        n = [r[case] for r in runs["new"]]
        row = {"base_best_s": min(b), "new_best_s": min(n), "base_median_s": statistics.median(b),
               "new_median_s": statistics.median(n), "ratio_best": min(n) / min(b)}
        report["cases"][case] = row
        lines.append(f"{case:<20} {min(b):10.4f} {min(n):10.4f} {row['ratio_best']:6.2f} "
                     f"{row['base_median_s']:10.4f} {row['new_median_s']:10.4f}")
    print("\n".join(lines))
    args.out.mkdir(parents=True, exist_ok=True)
    write_atomic(args.out / "compare_commits.json", json.dumps(report, indent=2) + "\n")
    print(f"wrote {args.out / 'compare_commits.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
