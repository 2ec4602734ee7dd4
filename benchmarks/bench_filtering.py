"""Benchmark: anti-aliased texton noise on a ground plane in perspective (CGF §5, Fig. 3).

Renders a 1024² view of an infinite plane (camera 1 unit up, tilted 70° from
straight down, vertical field of view 40°, so the horizon is the top edge;
texel size 0.0011, about one texel per pixel at the bottom) with an RGB texton
of 64², MNI 30, and measures for "mip" and "anisotropic":

* error: the RMSE against a 20 × 20 jittered supersampled reference over the
  far (top) half of the image, relative to the noise's standard deviation, and
  its ratio to the unfiltered render's RMSE (target ≤ 1/3). The reference is
  computed on every 4th row and column of the far half (a 400-sample average
  per pixel is what makes a full reference cost minutes);
* cost: the time of the whole filtered render over the unfiltered one
  (target ≤ 3), best of interleaved runs.

It also records the per-band variance from far to near (reference, none,
mip, anisotropic) and, in a full run, a sweep over ``max_aniso`` and the level
bias that justifies the defaults.

    python benchmarks/bench_filtering.py            # full run, writes results/
    python benchmarks/bench_filtering.py --quick    # smoke run (CI)
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

from warp_texton import FilterOptions, analyze  # noqa: E402
from warp_texton.noise.filtering import FADE_ENERGY, LOD_BIAS, MAX_ANISO, kept_levels, level_energies  # noqa: E402
from warp_texton.noise.ground_plane import PlaneCamera, plane_pixels  # noqa: E402
from warp_texton.core.runtime import resolve_device  # noqa: E402

#: The view: camera height, tilt and field of view (degrees), texel size at 1024 rows.
VIEW = {"height": 1.0, "tilt": 70.0, "fov": 40.0, "texel_1024": 0.0011}
BANDS = 8


def plane_view(side: int) -> PlaneCamera:
    return PlaneCamera((side, side), VIEW["height"], VIEW["tilt"], VIEW["fov"], VIEW["texel_1024"] * 1024 / side)


def far_half_sample(view: PlaneCamera, every: int) -> np.ndarray:
    """Flat indices of every ``every``-th row and column of the top half."""
    h, w = view.shape
    return np.arange(h // 2 * w).reshape(h // 2, w)[::every, ::every].ravel()


def stats(times):
    return {"best_s": min(times), "median_s": statistics.median(times), "runs": len(times)}


def run(args) -> dict:
    device = resolve_device(args.device)
    side = 256 if args.quick else 1024
    n_ref = 8 if args.quick else 20
    texton = analyze(make_texture(256 if args.quick else 512), size=args.size, seed=0)
    sigma = float(np.sqrt(np.mean(np.diag(np.atleast_2d(texton.covariance())))))
    view = plane_view(side)
    h, w = view.shape
    everything = np.arange(h * w)
    sample = far_half_sample(view, 4)
    common = dict(mni=args.mni, seed=1, device=device)
    plane_pixels(texton, plane_view(32), np.arange(32 * 32), filter="anisotropic", **common)  # compile
    print(f"reference: {sample.size} far-half pixels x {n_ref}x{n_ref} samples", flush=True)
    t0 = time.perf_counter()
    ref = plane_pixels(texton, view, sample, filter=FilterOptions("supersample", supersample=n_ref), **common)
    t_ref = time.perf_counter() - t0
    filters = ("none", "mip", "anisotropic")
    times = {f: [] for f in filters}
    images = {}
    for _ in range(args.repeat):  # interleaved: every filter sees the same load
        for f in filters:
            t0 = time.perf_counter()
            images[f] = plane_pixels(texton, view, everything, filter=f, **common)
            times[f].append(time.perf_counter() - t0)
    rmse = {f: float(np.sqrt(np.mean((images[f][sample] - ref) ** 2))) for f in filters}
    rows = []
    for f in filters:
        row = {"filter": f, "time": stats(times[f]), "rmse_over_sigma": rmse[f] / sigma,
               "error_ratio": rmse[f] / rmse["none"],
               "cost_best": min(times[f]) / min(times["none"]),
               "cost_median": statistics.median(times[f]) / statistics.median(times["none"])}
        rows.append(row)
        print(f"  {f}: {row['time']['best_s']:.3f} s (x{row['cost_best']:.2f}), RMSE/sigma "
              f"{row['rmse_over_sigma']:.3f} (x{row['error_ratio']:.3f} of unfiltered)", flush=True)
    # variance by distance: bands of rows of the sampled far half, far (top) to near
    rows_of = sample // w
    edges = np.linspace(0, h // 2, BANDS + 1)
    bands = []
    for b in range(BANDS):
        sel = (rows_of >= edges[b]) & (rows_of < edges[b + 1])
        entry = {"rows": [int(edges[b]), int(edges[b + 1])], "reference": float(ref[sel].var(axis=0).mean())}
        for f in filters:
            entry[f] = float(images[f][sample][sel].var(axis=0).mean())
        bands.append(entry)
    sweep = []
    if not args.quick:
        second_moment = -0.5 * float(np.log2(3.0))
        settings = [("mip", {"lod_bias": 0.0}), ("mip", {"lod_bias": second_moment}), ("mip", {"lod_bias": -1.0}),
                    ("mip", {}), ("mip", {"lod_bias": -1.6}), ("mip", {"fade_energy": 0.1}),
                    ("mip", {"fade_energy": 0.0}), ("anisotropic", {"lod_bias": 0.0}),
                    ("anisotropic", {"lod_bias": second_moment}), ("anisotropic", {"lod_bias": -0.4}),
                    ("anisotropic", {}), ("anisotropic", {"fade_energy": 0.1}),
                    ("anisotropic", {"fade_energy": 0.0}), ("anisotropic", {"max_aniso": 2}),
                    ("anisotropic", {"max_aniso": 4}), ("anisotropic", {"max_aniso": 16})]
        for f, kw in settings:
            t_f, t_none = [], []
            for _ in range(2):  # interleaved with the unfiltered render
                t0 = time.perf_counter()
                img = plane_pixels(texton, view, everything, filter=FilterOptions(f, **kw), **common)
                t_f.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                plane_pixels(texton, view, everything, filter="none", **common)
                t_none.append(time.perf_counter() - t0)
            e = float(np.sqrt(np.mean((img[sample] - ref) ** 2)))
            entry = {"filter": f, "max_aniso": kw.get("max_aniso", MAX_ANISO),
                     "lod_bias": kw.get("lod_bias", LOD_BIAS[f]), "fade_energy": kw.get("fade_energy", FADE_ENERGY),
                     "error_ratio": e / rmse["none"], "cost": min(t_f) / min(t_none)}
            sweep.append(entry)
            print(f"  sweep {f} max_aniso {entry['max_aniso']} bias {entry['lod_bias']:.2f} fade "
                  f"{entry['fade_energy']:g}: error x{entry['error_ratio']:.3f}, cost x{entry['cost']:.2f}", flush=True)
    return {
        **report_header("filtering", device),
        "parameters": {"texton": list(texton.size), "channels": texton.channels, "order": texton.order,
                       "mni": args.mni, "repeat": args.repeat, "quick": args.quick, "shape": [h, w],
                       "view": {**VIEW, "texel_size": view.texel_size}, "reference_samples": n_ref,
                       "reference_pixels": int(sample.size), "reference_seconds": t_ref, "sigma": sigma,
                       "max_aniso": MAX_ANISO, "lod_bias": LOD_BIAS, "fade_energy": FADE_ENERGY,
                       "level_energies": [float(e) for e in level_energies(texton)],
                       "kept_levels": kept_levels(texton)},
        "results": rows,
        "bands": bands,
        "sweep": sweep,
    }


def markdown(report: dict) -> str:
    p = report["parameters"]
    h, w = p["shape"]
    v = p["view"]
    lines = [
        f"# Anti-aliased texton noise on a plane ({report['date']})",
        "",
        machine_line(report),
        f"{w}x{h} plane view: camera height {v['height']:g}, tilt {v['tilt']:g}°, fov {v['fov']:g}°, "
        f"texel size {v['texel_size']:.3g}; texton {p['texton'][0]}x{p['texton'][1]}, MNI {p['mni']:g}. "
        f"Error: RMSE against a {p['reference_samples']}x{p['reference_samples']} supersampled reference "
        f"on {p['reference_pixels']} pixels of the far half (every 4th row and column), over the noise's "
        f"standard deviation σ = {p['sigma']:.4f}. Cost: whole render, best of {p['repeat']} interleaved "
        "runs (median in brackets), over the unfiltered render.",
        "",
        "| filter | time (s) | cost vs none | RMSE / σ | error vs none |",
        "|---|---|---|---|---|",
    ]
    for r in report["results"]:
        lines.append(f"| {r['filter']} | {r['time']['best_s']:.3f} ({r['time']['median_s']:.3f}) | "
                     f"{r['cost_best']:.2f} ({r['cost_median']:.2f}) | {r['rmse_over_sigma']:.3f} | "
                     f"{r['error_ratio']:.3f} |")
    lines += ["", "Variance by distance (far half, top band first), mean over channels:", "",
              "| rows | reference | none | mip | anisotropic |", "|---|---|---|---|---|"]
    for b in report["bands"]:
        lines.append(f"| {b['rows'][0]}–{b['rows'][1]} | {b['reference']:.2e} | {b['none']:.2e} | "
                     f"{b['mip']:.2e} | {b['anisotropic']:.2e} |")
    if report["sweep"]:
        energies = ", ".join(f"{e:.3g}" for e in p["level_energies"])
        lines += ["", "Settings sweep (error and cost relative to the unfiltered render, best of 2 interleaved "
                  f"runs each). Level energies ∫h_ℓ²/∫h² of this texton: {energies}; the default fade "
                  f"({p['fade_energy']:g}) keeps {p['kept_levels']} levels, fade 0 keeps them all.", "",
                  "| filter | max_aniso | level bias | fade | error vs none | cost vs none |",
                  "|---|---|---|---|---|---|"]
        for s in report["sweep"]:
            aniso = s["max_aniso"] if s["filter"] == "anisotropic" else "–"
            lines.append(f"| {s['filter']} | {aniso} | {s['lod_bias']:.2f} | {s['fade_energy']:g} | "
                         f"{s['error_ratio']:.3f} | {s['cost']:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "filtering", run, markdown, argv, repeat=5)


if __name__ == "__main__":
    sys.exit(main())
