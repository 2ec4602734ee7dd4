"""Benchmark: structured textures — the tiling model against the benchmark's tiling and blending and texton noise.

For each structured texture of ``structured_textures.STRUCTURED`` that loads here
and each seed, every method makes a 512² output; measured against the example:

* **patch** — :func:`warp_texton.model.tiling.patch_distance` (multi-scale 7 × 7 patch
  sliced Wasserstein) over the example's half-to-half distance (the floor);
* **blend zone** — :func:`structure.blend_zone_energy` (ln HF energy in the blend
  zones over the example's; whole output for methods without a blend);
* **repetition** — ``bench_quality.repetition``;
* **W1** — ``bench_quality.marginal_w1``: the 1-D Wasserstein distance between the
  marginal histograms of output and example, mean over the channels;
* **ms** — milliseconds per output on ``--device`` (the NumPy peer on the host),
  best of the seeds, methods interleaved.

Then the CPU cost goal: the default tiling model against texton noise of the same
example at MNI 30 (default options) on the same 512² raster, best of ``--repeat``
interleaved runs each, and their **ratio** (below 1 meets the goal).

    python benchmarks/bench_structure.py            # → results/structure.{json,md}
    python benchmarks/bench_structure.py --quick    # brick only, one seed
    python benchmarks/bench_structure.py --sharpness 2 4   # also the variance blend at these sharpnesses,
                                                           # with and without histogram="preserve"
    python benchmarks/bench_structure.py --speed    # only the cost ratio (every texture)
    python benchmarks/bench_structure.py --filters  # only the filters' plane errors (every texture)

``--filters`` measures the tiling model's filters on a ground plane seen in
perspective (``render_plane``, 96 × 96, tilt 75°, fov 40°, texel size 0.004: footprints
from under a texel to past the example): the RMS error of "none", "mip" and
"anisotropic" against "supersample" with 24 × 24 jittered samples a pixel, and
their ratio to the unfiltered error (the goal: at most 1/3).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from bench_quality import marginal_w1, repetition  # noqa: E402
from common import machine_line, report_header, run_main  # noqa: E402
from structure import blend_zone_energy  # noqa: E402
from structured_textures import STRUCTURED  # noqa: E402

from warp_texton import analyze, synthesize  # noqa: E402
from warp_texton.model.tiling import TilingModel, half_distance, patch_distance  # noqa: E402

SHAPE = (512, 512)
SEEDS = (1, 2, 3)


def peer_weights(tb, shape, side):
    """The largest barycentric weight of the peer's triangle grid at each pixel."""
    from benchmarks.peers import triangle_grid

    h, w = shape
    yy, xx = np.meshgrid(np.arange(h) + 0.5, np.arange(w) + 0.5, indexing="ij")
    return triangle_grid(np.stack([xx, yy], -1), side)[1].max(axis=0)


def tiling_weights(model: TilingModel, shape):
    """The largest blend weight of the tiling model at each pixel (scale 1, guide ignored)."""
    from benchmarks.peers import triangle_grid

    h, w = shape
    yy, xx = np.meshgrid(np.arange(h) + 0.5, np.arange(w) + 0.5, indexing="ij")
    b = triangle_grid(np.stack([xx, yy], -1), model.side)[1] ** model.sharpness
    return (b / b.sum(axis=0)).max(axis=0)


def methods(u, device, mni, sweep=()):
    """name → (sample(seed), max_weight map or None, host-only)."""
    from benchmarks.peers import TilingBlending

    out = {}
    tb = TilingBlending(u)
    out["tiling and blending (benchmark)"] = (lambda s: tb(SHAPE, seed=s), peer_weights(tb, SHAPE, tb.side), True)
    base = analyze(u, method="tiling")
    for sharp, blend in ((8, "linear"), (16, "linear"), (16, "variance")):
        m = TilingModel(base.example, base.side, sharp, 0.0, base.metadata, blend)
        out[f"tiling s={sharp} {blend}"] = (lambda s, m=m: synthesize(m, SHAPE, seed=s, device=device),
                                            tiling_weights(m, SHAPE), False)
    hp = analyze(u, method="tiling", histogram="preserve")
    out["tiling s=16 variance, histogram preserve"] = (lambda s: synthesize(hp, SHAPE, seed=s, device=device),
                                                       tiling_weights(hp, SHAPE), False)
    for sharp in sweep:  # wider blend zones: where the histogram tables matter
        for tables in (False, True):
            src = hp if tables else base
            m = TilingModel(src.example, src.side, sharp, 0.0, src.metadata, "variance", src.histogram)
            out[f"tiling s={sharp} variance" + (", histogram preserve" if tables else "")] = (
                lambda s, m=m: synthesize(m, SHAPE, seed=s, device=device), tiling_weights(m, SHAPE), False)
    t = analyze(u, size=min(64, *u.shape[:2]), seed=0)
    out[f"texton noise MNI {mni:g}"] = (lambda s: synthesize(t, SHAPE, mni=mni, seed=s, device=device), None, False)
    return out, base.structure


def speed(u, device, mni: float, repeat: int) -> dict:
    """ms of the default tiling model and of texton noise (MNI ``mni``) on the same 512² raster, best of
    ``repeat`` interleaved runs, and their ratio."""
    model = analyze(u, method="tiling")
    t = analyze(u, size=min(64, *u.shape[:2]), seed=0)
    fns = {"tiling": lambda s: synthesize(model, SHAPE, seed=s, device=device),
           "texton": lambda s: synthesize(t, SHAPE, mni=mni, seed=s, device=device)}
    best = {k: float("inf") for k in fns}
    cpu = {k: float("inf") for k in fns}
    for fn in fns.values():
        fn(0)  # compiles
    for r in range(repeat):
        for key, fn in fns.items():
            t0, c0 = time.perf_counter(), time.process_time()
            out = fn(r + 1)
            if hasattr(out, "numpy"):  # a device array: wait for it
                out.numpy()
            best[key] = min(best[key], time.perf_counter() - t0)
            cpu[key] = min(cpu[key], time.process_time() - c0)
    # process CPU time (all threads) is less sensitive than wall time to other jobs on a shared machine
    return {"tiling_ms": 1e3 * best["tiling"], "texton_ms": 1e3 * best["texton"],
            "ratio": best["tiling"] / best["texton"], "tiling_cpu_ms": 1e3 * cpu["tiling"],
            "texton_cpu_ms": 1e3 * cpu["texton"], "cpu_ratio": cpu["tiling"] / cpu["texton"]}


#: The plane view of ``--filters``.
PLANE = dict(shape=(96, 96), tilt=75.0, fov=40.0, texel_size=0.004)


def filter_errors(u, device) -> dict:
    """RMS errors of the default tiling model's filters against a 24 × 24 supersampled reference on a
    plane view (:data:`PLANE`), mean of the seeds, and the ms of each filter (best of the seeds)."""
    from warp_texton import FilterOptions, render_plane

    model = analyze(u, method="tiling")
    kw = {k: v for k, v in PLANE.items() if k != "shape"}
    errors: dict[str, list[float]] = {"none": [], "mip": [], "anisotropic": []}
    ms: dict[str, float] = {k: float("inf") for k in errors}
    for seed in SEEDS:
        ref = render_plane(model, PLANE["shape"], filter=FilterOptions("supersample", supersample=24), seed=seed,
                           device=device, **kw).astype(np.float64)
        for kind in errors:
            t0 = time.perf_counter()
            v = render_plane(model, PLANE["shape"], filter=kind, seed=seed, device=device, **kw)
            ms[kind] = min(ms[kind], 1e3 * (time.perf_counter() - t0))
            errors[kind].append(float(np.sqrt(np.mean((v - ref) ** 2))))
    out = {f"{k}_rms": float(np.mean(e)) for k, e in errors.items()}
    out.update({f"{k}_ms": ms[k] for k in ms})
    return out


def run(args) -> dict:
    names = ["brick"] if args.quick else list(STRUCTURED)
    seeds = SEEDS[:1] if args.quick else SEEDS
    rows, skipped, costs, filters = [], [], [], []
    for name in names:
        source, load = STRUCTURED[name]
        try:
            u = load()
        except OSError as exc:
            skipped.append({"case": f"texture {name}", "reason": str(exc)})
            continue
        u = u[:, :, None] if u.ndim == 2 else u
        if not args.filters:
            cost = {"texture": name, **speed(u, args.device, args.mni, args.repeat)}
            costs.append(cost)
            print(f"  {name:12s} tiling {cost['tiling_ms']:.1f} ms, texton noise MNI {args.mni:g} "
                  f"{cost['texton_ms']:.1f} ms: ratio {cost['ratio']:.2f}; CPU time {cost['tiling_cpu_ms']:.1f} / "
                  f"{cost['texton_cpu_ms']:.1f} ms: ratio {cost['cpu_ratio']:.2f}", flush=True)
        if args.filters:
            fe = {"texture": name, **filter_errors(u, args.device)}
            filters.append(fe)
            print(f"  {name:12s} plane RMS: none {fe['none_rms']:.4f}, mip {fe['mip_rms']:.4f} "
                  f"({fe['mip_rms'] / fe['none_rms']:.2f}), anisotropic {fe['anisotropic_rms']:.4f} "
                  f"({fe['anisotropic_rms'] / fe['none_rms']:.2f})", flush=True)
        if args.speed or args.filters:
            continue
        floor = half_distance(u)
        ms, score = methods(u, args.device, args.mni, tuple(args.sharpness or ()))
        for fn, _, _ in ms.values():
            fn(0)  # warm up (compiles)
        acc: dict[str, dict[str, list[float]]] = {k: {"patch": [], "blend": [], "rep": [], "w1": [], "s": []} for k in ms}
        for seed in seeds:
            for key, (fn, weights, _) in ms.items():
                t0 = time.perf_counter()
                o = fn(seed)
                acc[key]["s"].append(time.perf_counter() - t0)
                acc[key]["patch"].append(patch_distance(o, u, seed=seed) / floor)
                acc[key]["blend"].append(blend_zone_energy(u, o, weights))
                acc[key]["rep"].append(repetition(o))
                acc[key]["w1"].append(float(np.mean(marginal_w1(o, u))))
        for key, a in acc.items():
            row = {"texture": name, "source": source, "structure": score, "method": key,
                   "device": "host" if ms[key][2] else args.device, "patch": float(np.mean(a["patch"])),
                   "patch_seeds": a["patch"], "blend_zone": float(np.mean(a["blend"])),
                   "repetition": float(np.mean(a["rep"])), "w1": float(np.mean(a["w1"])),
                   "ms": 1e3 * min(a["s"])}
            rows.append(row)
            print(f"  {name:12s} {key:34s} patch {row['patch']:.3f}  blend {row['blend_zone']:+.3f}  "
                  f"rep {row['repetition']:.3f}  W1 {row['w1']:.4f}  {row['ms']:.0f} ms", flush=True)
    return {**report_header("structure", args.device),
            "parameters": {"shape": list(SHAPE), "seeds": list(seeds), "mni": args.mni, "repeat": args.repeat,
                           "sharpness_sweep": list(args.sharpness or ())},
            "results": rows, "cost": costs, "filters": filters, "skipped": skipped}


def markdown(report: dict) -> str:
    lines = [f"# Structured textures ({report['date']})", "", machine_line(report),
             "patch: multi-scale 7×7 patch sliced-Wasserstein distance to the example over the example's "
             "half-to-half distance, mean of the seeds; blend zone: ln HF energy in blend zones over the example's; "
             "ms: best of the seeds.", "",
             "| texture | structure | method | patch | blend zone | repetition | W1 | ms |",
             "|---|---:|---|---:|---:|---:|---:|---:|"]
    for r in report["results"]:
        lines.append(f"| {r['texture']} | {r['structure']:.2f} | {r['method']} | {r['patch']:.3f} | "
                     f"{r['blend_zone']:+.3f} | {r['repetition']:.3f} | {r.get('w1', float('nan')):.4f} | {r['ms']:.0f} |")
    mni = report["parameters"]["mni"]
    lines += ["", f"CPU cost on the same {SHAPE[0]}² raster, best of {report['parameters']['repeat']} interleaved runs "
              "(ratio below 1 meets the goal):", "",
              f"| texture | tiling ms | texton noise MNI {mni:g} ms | ratio | CPU time ms (all threads) | CPU ratio |",
              "|---|---:|---:|---:|---:|---:|"]
    for c in report.get("cost", []):
        lines.append(f"| {c['texture']} | {c['tiling_ms']:.1f} | {c['texton_ms']:.1f} | {c['ratio']:.2f} | "
                     f"{c['tiling_cpu_ms']:.1f} / {c['texton_cpu_ms']:.1f} | {c['cpu_ratio']:.2f} |")
    if report.get("filters"):
        lines += ["", "Filters of the tiling model on a plane view: RMS error against 24 × 24 supersampling "
                  "(ratio to the unfiltered error), mean of the seeds:", "",
                  "| texture | none | mip | anisotropic | ms none / mip / anisotropic |", "|---|---:|---:|---:|---:|"]
        for f in report["filters"]:
            lines.append(f"| {f['texture']} | {f['none_rms']:.4f} | {f['mip_rms']:.4f} ({f['mip_rms'] / f['none_rms']:.2f}) "
                         f"| {f['anisotropic_rms']:.4f} ({f['anisotropic_rms'] / f['none_rms']:.2f}) | "
                         f"{f['none_ms']:.0f} / {f['mip_ms']:.0f} / {f['anisotropic_ms']:.0f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    def extra(parser):
        parser.add_argument("--sharpness", type=int, nargs="*", choices=(1, 2, 4, 8, 32, 64),
                            help="also these sharpnesses of the variance blend, with and without the histogram tables")
        parser.add_argument("--speed", action="store_true", help="only the CPU cost ratio")
        parser.add_argument("--filters", action="store_true", help="only the filters' plane errors")

    given = sys.argv[1:] if argv is None else argv
    name = "structure_speed" if "--speed" in given else "structure_filters" if "--filters" in given else "structure"
    return run_main(__doc__, name, run, markdown, argv, repeat=12, extra_args=extra)


if __name__ == "__main__":
    sys.exit(main())
