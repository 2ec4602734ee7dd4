"""Benchmark: batches against a loop of ``synthesize``, device output, and large Zarr stores.

* **batch**: ``synthesize_batch`` of N rasters (256² RGB, MNI 30, 32² textons)
  against a Python loop of ``synthesize`` over the same items (same textons,
  seeds, scales, rotations), interleaved in one run; images per second and the
  ratio batch / loop (goal: at least 1.8 on the CPU). Two variants: every item
  at scale 1 without rotation (the fast path), and scales in [0.8, 1.25]
  with any rotation.
* **device output** (CUDA only): ``output="warp"`` against NumPy output.
* **zarr** (``--zarr SIDE``): ``write_zarr`` of a SIDE × SIDE RGB raster into a
  store under ``--zarr-dir`` on local threads, timed, with the peak resident
  memory of the writing process; the store is deleted afterwards.
  ``--cluster SIDE`` does the same on a ``dask.distributed`` LocalCluster of
  processes and reports each worker's peak.

    python benchmarks/bench_scale.py                     # batch (and CUDA output), writes results/
    python benchmarks/bench_scale.py --quick             # smoke run (CI)
    python benchmarks/bench_scale.py --zarr 65536 --zarr-dtype float16 --cluster 16384 --skip-batch
"""

from __future__ import annotations

import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, report_header, run_main  # noqa: E402

from warp_texton import Texton, synthesize, synthesize_batch  # noqa: E402
from warp_texton.core.runtime import resolve_device  # noqa: E402

VARIANTS = {"scale 1, no rotation": {}, "scale 0.8-1.25, any rotation": {"scale": (0.8, 1.25), "rotation": (0, 360)}}


def textons(size: int, n: int = 4) -> list[Texton]:
    """Random textons whose noise has a standard deviation of about 0.15 (as the demo grass)."""
    rng = np.random.default_rng(0)
    return [Texton(0.007 * rng.standard_normal((size, size, 3)) + 0.0004, [0.5] * 3) for _ in range(n)]


def bench_batch(args, device) -> list:
    ts = textons(args.size)
    shape = (args.side, args.side)
    rows = []
    for name, kw in VARIANTS.items():
        _, params = synthesize_batch(ts, args.count, shape, seed=1, mni=args.mni, device=device, **kw)
        items = [(ts[params.texton[k]], params.item(k)) for k in range(args.count)]

        def loop():
            for t, p in items:
                synthesize(t, shape, mni=args.mni, **p, device=device)

        def batch():
            synthesize_batch(ts, args.count, shape, seed=1, mni=args.mni, device=device, **kw)

        loop(), batch()  # warm-up: kernels loaded, pages touched
        times = {"batch": [], "loop": []}
        for _ in range(args.repeat):
            for which, fn in (("batch", batch), ("loop", loop)):
                t0 = time.perf_counter()
                fn()
                times[which].append(time.perf_counter() - t0)
        row = {"variant": name, "count": args.count}
        for which, ts_ in times.items():
            row[which] = {"best_s": min(ts_), "median_s": statistics.median(ts_),
                          "images_per_s": args.count / min(ts_), "ms_per_image": 1e3 * min(ts_) / args.count}
        row["ratio_best"] = row["loop"]["best_s"] / row["batch"]["best_s"]
        row["ratio_median"] = row["loop"]["median_s"] / row["batch"]["median_s"]
        rows.append(row)
        print(f"  {name}: batch {row['batch']['images_per_s']:.0f} img/s, loop {row['loop']['images_per_s']:.0f} "
              f"img/s, ratio {row['ratio_best']:.2f} (median {row['ratio_median']:.2f})", flush=True)
    return rows


def bench_device_output(args, device) -> list:
    if device == "cpu":
        return []
    import warp as wp

    t = textons(args.size, 1)[0]
    rows = []
    for side in (512, 2048):
        times = {"numpy": [], "warp": []}
        for out in ("numpy", "warp"):
            synthesize(t, (side, side), mni=args.mni, device=device, output=out)
        for _ in range(args.repeat):
            for out in ("numpy", "warp"):
                t0 = time.perf_counter()
                synthesize(t, (side, side), mni=args.mni, device=device, output=out)
                wp.synchronize_device(device)
                times[out].append(time.perf_counter() - t0)
        rows.append({"side": side, **{k: {"best_s": min(v), "median_s": statistics.median(v)} for k, v in times.items()}})
        print(f"  {side}²: numpy {min(times['numpy']) * 1e3:.2f} ms, warp {min(times['warp']) * 1e3:.2f} ms", flush=True)
    return rows


ZARR_SCRIPT = r"""
import json, resource, sys, time
import numpy as np
from warp_texton import Texton, synthesize
from warp_texton.noise.dask_arrays import write_zarr
path, side, chunk, dtype, size, mni, workers = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], int(sys.argv[5]), float(sys.argv[6]), int(sys.argv[7])
rng = np.random.default_rng(0)
t = Texton(0.007 * rng.standard_normal((size, size, 3)) + 0.0004, [0.5] * 3)
synthesize(t, (256, 256), mni, device="cpu")
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
report = write_zarr(path, t, (side, side), chunk, dtype, mni=mni, seed=1, device="cpu", workers=workers or None, progress=True)
seconds = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"seconds": seconds, "rss_before_mib": before / 1024, "rss_peak_mib": peak / 1024, "clipped": report["clipped"]}))
"""

CLUSTER_SCRIPT = r"""
import json, resource, sys, time
import numpy as np
from distributed import Client, LocalCluster
from warp_texton import Texton
from warp_texton.noise.dask_arrays import write_zarr
path, side, chunk, dtype, size, mni, workers = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], int(sys.argv[5]), float(sys.argv[6]), int(sys.argv[7])
rng = np.random.default_rng(0)
t = Texton(0.007 * rng.standard_normal((size, size, 3)) + 0.0004, [0.5] * 3)
if __name__ == "__main__":
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50) as cluster:
        t0 = time.perf_counter()
        write_zarr(path, t, (side, side), chunk, dtype, scheduler=cluster.scheduler_address, mni=mni, seed=1, device="cpu")
        seconds = time.perf_counter() - t0
        with Client(cluster) as client:
            peaks = client.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    print(json.dumps({"seconds": seconds, "worker_peak_rss_mib": sorted(peaks.values())}))
"""


def folder_bytes(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def bench_zarr(args, side: int, cluster: bool) -> dict:
    folder = Path(tempfile.mkdtemp(dir=args.zarr_dir, prefix="bench_scale_"))
    store = folder / "noise.zarr"
    script = CLUSTER_SCRIPT if cluster else ZARR_SCRIPT
    workers = args.workers or (2 if cluster else 0)
    try:
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", script, str(store), str(side), str(args.chunk), args.zarr_dtype,
                               str(args.size), str(args.mni), str(workers)],
                              stdout=subprocess.PIPE, text=True, check=True)
        wall = time.perf_counter() - t0
        result = json.loads(done.stdout.strip().splitlines()[-1])
        result.update(side=side, chunk=args.chunk, dtype=args.zarr_dtype, store_bytes=folder_bytes(store),
                      process_wall_s=wall, pixels_per_s=side * side / result["seconds"],
                      raw_bytes=side * side * 3 * np.dtype(args.zarr_dtype).itemsize,
                      scheduler="LocalCluster of processes" if cluster else "threads",
                      workers=workers or "cores")
        print(f"  zarr {side}² {args.zarr_dtype} ({result['scheduler']}): {result['seconds']:.1f} s, "
              f"{result['store_bytes'] / 2**30:.2f} GiB on disk", flush=True)
        return result
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def run(args) -> dict:
    device = resolve_device(args.device)
    if args.quick:
        args.count, args.side, args.size = min(args.count, 16), min(args.side, 128), min(args.size, 32)
    report = {**report_header("scale", device),
              "parameters": {"count": args.count, "side": args.side, "texton": args.size, "mni": args.mni,
                             "repeat": args.repeat, "quick": args.quick}}
    if not args.skip_batch:
        report["batch"] = bench_batch(args, device)
        report["device_output"] = bench_device_output(args, device)
    report["zarr"] = []
    if args.zarr:
        report["zarr"].append(bench_zarr(args, args.zarr, cluster=False))
    if args.cluster:
        report["zarr"].append(bench_zarr(args, args.cluster, cluster=True))
    return report


def markdown(report: dict) -> str:
    p = report["parameters"]
    lines = [f"# Scale: batches, device output, Zarr ({report['date']})", "", machine_line(report), ""]
    if report.get("batch"):
        lines += [f"`synthesize_batch` of {p['count']} rasters of {p['side']}² RGB (textons {p['texton']}², MNI "
                  f"{p['mni']:g}) against a loop of `synthesize` over the same items; best of {p['repeat']} "
                  "interleaved runs (the ratio of medians in brackets).", "",
                  "| items | batch (img/s) | loop (img/s) | batch (ms/img) | loop (ms/img) | ratio |",
                  "|---|---|---|---|---|---|"]
        for r in report["batch"]:
            lines.append(f"| {r['variant']} | {r['batch']['images_per_s']:.0f} | {r['loop']['images_per_s']:.0f} | "
                         f"{r['batch']['ms_per_image']:.2f} | {r['loop']['ms_per_image']:.2f} | "
                         f"{r['ratio_best']:.2f} ({r['ratio_median']:.2f}) |")
        lines.append("")
    if report.get("device_output"):
        lines += ["| raster | output numpy (ms) | output warp (ms) |", "|---|---|---|"]
        for r in report["device_output"]:
            lines.append(f"| {r['side']}² | {r['numpy']['best_s'] * 1e3:.2f} | {r['warp']['best_s'] * 1e3:.2f} |")
        lines.append("")
    for z in report.get("zarr", []):
        peak = (f"peak RSS {z['rss_peak_mib']:.0f} MiB (after start-up {z['rss_before_mib']:.0f} MiB)"
                if "rss_peak_mib" in z else f"worker peak RSS {', '.join(f'{v:.0f}' for v in z['worker_peak_rss_mib'])} MiB")
        lines.append(f"* Zarr {z['side']} × {z['side']} RGB {z['dtype']} in {z['chunk']}² chunks on {z['scheduler']}: "
                     f"{z['seconds']:.1f} s ({z['pixels_per_s'] / 1e6:.1f} Mpixel/s), {peak}; "
                     f"{z['store_bytes'] / 2**30:.2f} GiB on disk ({z['raw_bytes'] / 2**30:.2f} GiB raw).")
    return "\n".join(lines) + "\n"


def extra_args(parser):
    parser.set_defaults(size=32)
    parser.add_argument("--count", type=int, default=64, help="rasters per batch")
    parser.add_argument("--side", type=int, default=256, help="raster side of the batch items")
    parser.add_argument("--skip-batch", action="store_true", help="only the Zarr runs")
    parser.add_argument("--zarr", type=int, help="write a SIDE x SIDE RGB Zarr store on local threads")
    parser.add_argument("--cluster", type=int, help="write a SIDE x SIDE RGB Zarr store on a LocalCluster of processes")
    parser.add_argument("--zarr-dtype", default="float16", help="stored type of the Zarr runs")
    parser.add_argument("--zarr-dir", default=tempfile.gettempdir(), help="folder for the (deleted) stores")
    parser.add_argument("--chunk", type=int, default=4096, help="Zarr chunk side")
    parser.add_argument("--workers", type=int, help="threads / cluster processes for the Zarr runs")


if __name__ == "__main__":
    sys.exit(run_main(__doc__, "scale", run, markdown, repeat=5, extra_args=extra_args))
