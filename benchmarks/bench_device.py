"""Benchmark: the device API in a user's kernel against the package's own calls, same points, same run.

A user's ``@wp.kernel`` (this file) calling ``plane_value``, ``filtered_value``
and ``surface_value`` of ``warp_texton.runtimes.warp_api``, one launch over all points,
against ``evaluate``, the filtered ``synthesize`` and ``surface_noise`` (walk and
blocks) at the same points, interleaved so that all see the same machine load.
The values are checked equal (bit for bit) before timing. On the CPU one Warp
launch runs on one thread, while the package splits its launches over a pool
of threads: the ratio shows what that split gains, and what a user's kernel on
the CPU gives up unless it splits its own launches.

    python benchmarks/bench_device.py            # full run, writes results/device.{json,md}
    python benchmarks/bench_device.py --quick    # smoke run
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_surface import interleaved  # noqa: E402
from common import machine_line, make_texture, report_header, run_main  # noqa: E402

import numpy as np  # noqa: E402
import trimesh  # noqa: E402
import warp as wp  # noqa: E402

from warp_texton import analyze, evaluate, surface_noise, synthesize  # noqa: E402
from warp_texton.runtimes import warp_api as td  # noqa: E402
from warp_texton.core.runtime import cpu_threads, resolve_device  # noqa: E402
from warp_texton.noise.filtering import RasterPixels  # noqa: E402
from warp_texton.noise.raster import raster_geometry  # noqa: E402


@wp.kernel
def plane_at(noise: td.PlaneNoise, points: wp.array(dtype=wp.vec2d), out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.plane_value(noise, points[t])


@wp.kernel
def filtered_at(noise: td.FilteredNoise, points: wp.array(dtype=wp.vec2d), footprint: wp.mat22,
                out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.filtered_value(noise, points[t], footprint)


@wp.kernel
def colours_at(cmap: td.ColourMap, values: wp.array(dtype=wp.vec3), out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.colour_value(cmap, values[t])


@wp.kernel
def surface_at(noise: td.SurfaceNoise, points: wp.array(dtype=wp.vec3d), normals: wp.array(dtype=wp.vec3d),
               out: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    out[t] = td.surface_value(noise, points[t], normals[t])


def user_launch(kernel, noise, inputs, n, device):
    """A user's call: upload the inputs, one launch, read the values back."""
    def call():
        out = wp.zeros(n, dtype=wp.vec3, device=device)
        wp.launch(kernel, dim=n, inputs=[noise, *(f() for f in inputs)], outputs=[out], device=device)
        return out.numpy()
    return call


def run(args) -> dict:
    device = resolve_device(args.device)
    texton = analyze(make_texture(128 if args.quick else 256), size=args.size, seed=0)
    n_plane = 64 * 64 if args.quick else 512 * 512
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1000.0, 1000.0, (n_plane, 2))
    rows = []

    def row(what, points, ours, package, check):
        assert check(), f"{what}: the user's kernel and the package differ"
        t = interleaved({"device API": ours, "package": package}, args.repeat)
        rows.append({"what": what, "points": points, **t, "ratio_best": t["device API"]["best_s"] / t["package"]["best_s"]})
        print(f"  {what}: device API {t['device API']['best_s']:.3f} s, package {t['package']['best_s']:.3f} s",
              flush=True)

    noise = td.pack_plane(texton, mni=args.mni, seed=1, device=device)
    plane = user_launch(plane_at, noise, [lambda: wp.array(pts, dtype=wp.vec2d, device=device)], n_plane, device)
    plain = lambda: evaluate(texton, pts, mni=args.mni, seed=1, device=device)  # noqa: E731
    row("plane_value / evaluate", n_plane, plane, plain,
        lambda: np.array_equal(plane()[:, :texton.channels], plain()))

    side = 64 if args.quick else 512
    shape = (side, side)
    J = np.array([[4.0, 0.0], [0.0, 4.0]])  # 4 x 4 texels per pixel
    centres = RasterPixels(shape, *raster_geometry(shape, 0.25, 0.0, (0.0, 0.0)), J).centres(0, side * side)
    fnoise = td.pack_filtered(texton, mni=args.mni, seed=1, filter="anisotropic", device=device)
    filt = user_launch(filtered_at, fnoise, [lambda: wp.array(centres, dtype=wp.vec2d, device=device),
                                             lambda: wp.mat22(*J.ravel())], side * side, device)
    raster = lambda: synthesize(texton, shape, mni=args.mni, seed=1, scale=0.25, filter="anisotropic",  # noqa: E731
                                device=device)
    row("filtered_value / synthesize (anisotropic, scale 0.25)", side * side, filt, raster,
        lambda: np.array_equal(filt()[:, :texton.channels].reshape(*shape, -1), raster()))

    mesh = trimesh.creation.icosphere(subdivisions=4 if args.quick else 6)
    p, nrm = np.asarray(mesh.vertices), np.asarray(mesh.vertex_normals)
    snoise = td.pack_surface(texton, 0.005, seed=1, device=device)
    surf = user_launch(surface_at, snoise, [lambda: wp.array(p, dtype=wp.vec3d, device=device),
                                            lambda: wp.array(nrm, dtype=wp.vec3d, device=device)], len(p), device)
    for method in ("points", "blocks"):
        ref = lambda m=method: surface_noise(texton, p, nrm, 0.005, seed=1, method=m, device=device)  # noqa: E731
        check = (lambda r=ref: np.array_equal(surf()[:, :texton.channels], r())) if device == "cpu" or \
            method == "points" else (lambda: True)
        row(f"surface_value / surface_noise ({method})", len(p), surf, ref, check)
    maps = colour_maps(args, device)
    return {
        **report_header("device", device),
        "colour_maps": maps,
        "parameters": {"texton": list(texton.size), "channels": texton.channels, "mni": args.mni,
                       "surface_mni": 60.0, "repeat": args.repeat, "quick": args.quick,
                       "cpu_threads": cpu_threads() if device == "cpu" else None},
        "results": rows,
    }


def colour_maps(args, device) -> dict:
    """A histogram-preserving texton's colour map over 2^20 (quick: 2^14) RGB noise values: a
    user's kernel (``colour_value``), the package's host mapping (``colours.to_colours``, the
    same function launched on the CPU) and the float64 NumPy lookup of
    ``HistogramTransform.to_colours`` (the transform's reference), interleaved."""
    from warp_texton.noise.colours import noise_moments, to_colours

    texton = analyze(make_texture(128), size=args.size, seed=0, histogram="preserve")
    n = 1 << (14 if args.quick else 20)
    values = (np.random.default_rng(1).standard_normal((n, 3)) * np.sqrt(np.diag(texton.covariance()))
              + texton.mean).astype(np.float32)
    mean, std = noise_moments(texton)
    cmap = td.pack_colours(texton, device=device)
    user = user_launch(colours_at, cmap, [lambda: wp.array(values, dtype=wp.vec3, device=device)], n, device)

    def host():
        out = values.copy()
        to_colours(out, texton)
        return out

    def numpy_lookup():
        return texton.histogram.to_colours((values.astype(np.float64) - mean) / std)

    if device == "cpu":
        assert np.array_equal(user(), host()), "colour_value and to_colours differ"
    diff = float(np.abs(host() - numpy_lookup()).max())
    t = interleaved({"device API": user, "package": host, "NumPy float64": numpy_lookup}, args.repeat)
    print(f"  colour map of {n} values: device API {t['device API']['best_s']:.3f} s, package "
          f"{t['package']['best_s']:.3f} s, NumPy float64 {t['NumPy float64']['best_s']:.3f} s", flush=True)
    return {"values": n, **t, "max_diff_numpy": diff, "range": float(np.ptp(texton.histogram.lut))}


def markdown(report: dict) -> str:
    p = report["parameters"]
    threads = f"; the package splits CPU launches over {p['cpu_threads']} threads" if p["cpu_threads"] else ""
    lines = [
        f"# The device API in a user's kernel vs the package ({report['date']})",
        "",
        machine_line(report),
        f"RGB texton {p['texton'][0]}x{p['texton'][1]}, MNI {p['mni']:g} (surface {p['surface_mni']:g}); best of "
        f"{p['repeat']} interleaved runs (median in brackets), uploads and read-back included{threads}. "
        "The values are bit for bit equal.",
        "",
        "| user kernel / package call | points | device API (s) | package (s) | ratio |",
        "|---|---|---|---|---|",
    ]
    for r in report["results"]:
        a, b = r["device API"], r["package"]
        lines.append(f"| {r['what']} | {r['points']} | {a['best_s']:.3f} ({a['median_s']:.3f}) | "
                     f"{b['best_s']:.3f} ({b['median_s']:.3f}) | {r['ratio_best']:.2f} |")
    m = report.get("colour_maps")
    if m:
        lines += ["", f"A histogram-preserving texton's colour map over {m['values']} RGB noise values (the same "
                  "interleaved runs): a user's kernel calling `colour_value`, the package's host mapping "
                  "(`colours.to_colours`: the same function launched on the CPU) and the float64 NumPy lookup "
                  f"of `HistogramTransform.to_colours`, which the float32 map matches to {m['max_diff_numpy']:.1e} "
                  f"(tables' range {m['range']:.2f}).", "",
                  "| map | best (s) | median (s) | vs NumPy |", "|---|---|---|---|"]
        for name in ("device API", "package", "NumPy float64"):
            lines.append(f"| {name} | {m[name]['best_s']:.3f} | {m[name]['median_s']:.3f} | "
                         f"{m[name]['best_s'] / m['NumPy float64']['best_s']:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "device", run, markdown, argv, repeat=5)


if __name__ == "__main__":
    sys.exit(main())
