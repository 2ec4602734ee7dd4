"""The ``warp-texton`` command line."""

from __future__ import annotations

import argparse
import re
import signal
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np

from ._version import __version__
from .errors import TextonError

EPILOG_ANALYZE = """examples:
  warp-texton analyze wood.png -o wood.exr
  warp-texton analyze wood.png -o wood.texton --size 32 --order 1
"""
EPILOG_SYNTHESIZE = """examples:
  warp-texton synthesize wood.exr -o noise.png --width 1920 --height 1080
  warp-texton synthesize wood.png -o tile.exr --width 512 --height 512 --period 512 512
  warp-texton synthesize wood.texton -o far.png --scale 0.25 --rotation 30 --mni 10
  warp-texton synthesize wood.texton -o far_aa.png --scale 0.1 --filter anisotropic
"""
EPILOG_PLANE = """examples:
  warp-texton render-plane wood.exr -o plane.png --width 1024 --height 1024
  warp-texton render-plane wood.texton -o plane_mip.png --filter mip --tilt 80 --texel-size 0.002
  warp-texton render-plane wood.exr -o reference.exr --filter supersample --supersample 20
"""
EPILOG_MIX = """examples:
  warp-texton mix wood.png marble.png -o mix.png --steps 21 --width 2048 --height 256
  warp-texton mix wood.exr marble.texton -o mix.exr --map mask.png
"""
EPILOG_SURFACE = """examples:
  warp-texton surface scans/*.ply --texton wood.exr --out-dir textured --render 512x512
  warp-texton surface @meshes.txt --texton wood.texton --out-dir out --texel-size 0.002 --format glb --jobs 2
"""
EPILOG_VIEW = """examples:
  warp-texton view wood.png                      # then open http://127.0.0.1:8000/
  warp-texton view wood.exr --port 8080 --open --device cpu
  warp-texton view wood.png --mix marble.png --size 32
on a remote GPU machine: run it there, then on your laptop
  ssh -L 8000:127.0.0.1:8000 gpu-host            # and open http://127.0.0.1:8000/
"""
EPILOG_GAUSSIAN = """examples:
  warp-texton gaussian wood.png -o wood_gaussian.png
  warp-texton gaussian wood.png -o big.exr --width 1024 --height 768 --seed 3
"""


class _Formatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """Keeps the hand-wrapped descriptions and examples, and shows each option's default."""

    def _get_help_string(self, action):
        if action.default is None or isinstance(action.default, bool):
            return action.help  # nothing useful to show
        return super()._get_help_string(action)


class _Parser(argparse.ArgumentParser):
    """argparse whose usage errors follow the project's one-line, exit-2 rule."""

    def error(self, message):
        self.exit(2, f"warp-texton: error: {message}\n")


def _add_analyze_options(p: argparse.ArgumentParser, seed: bool = True) -> None:
    g = p.add_argument_group("analysis options" + ("" if seed else " (when INPUT is an image)"))
    g.add_argument("--size", type=int, default=64, help="texton side (square) or diameter (disk), in texels")
    g.add_argument("--order", type=int, default=1, choices=(0, 1, 3, 5),
                   help="interpolation order: 0 nearest (EUSIPCO SOT), 1 bilinear (CGF), 3/5 B-spline")
    g.add_argument("--iterations", type=int, default=50, help="alternating projections")
    if seed:
        g.add_argument("--seed", type=int, default=0, help="random seed")
    g.add_argument("--support", choices=("square", "disk"), default="square", help="shape of the texton support")
    g.add_argument("--no-periodic", dest="periodic", action="store_false",
                   help="analyse the image itself, not its periodic component")
    g.add_argument("--no-color-correction", dest="color_correction", action="store_false",
                   help="skip the colour-covariance correction")


def _add_noise_image_options(p: argparse.ArgumentParser, what: str) -> None:
    """INPUT, -o, the image size, MNI and seed of the commands that write noise images."""
    p.add_argument("input", help="texton file or example image")
    p.add_argument("-o", "--output", required=True, help="output image: .png, .jpg or .exr")
    p.add_argument("--width", type=int, default=512, help=f"{what} width in pixels")
    p.add_argument("--height", type=int, default=512, help=f"{what} height in pixels")
    p.add_argument("--mni", type=float, default=30.0, help="mean number of impacts per point")
    p.add_argument("--seed", type=int, default=0, help="random seed (analysis and noise)")


def _add_filter_options(p: argparse.ArgumentParser, default: str) -> None:
    from .filtering import FADE_ENERGY, FILTERS, MAX_ANISO, SUPERSAMPLE

    p.add_argument("--filter", choices=FILTERS, default=default,
                   help="anti-aliasing for each pixel's footprint: MIP-mapped or anisotropic lookups "
                        "of the texton, or the supersampled reference")
    p.add_argument("--supersample", type=int, default=SUPERSAMPLE,
                   help="samples per pixel side for --filter supersample")
    p.add_argument("--max-aniso", type=int, default=MAX_ANISO,
                   help="most lookups along a footprint's major axis for --filter anisotropic")
    p.add_argument("--fade-energy", type=float, default=FADE_ENERGY,
                   help="end the MIP pyramid at the first level keeping less than this fraction of the "
                        "variance; larger footprints fade to the mean (0 keeps every level)")


def _filter_options(args):
    """The FilterOptions of --filter, --supersample, --max-aniso and --fade-energy."""
    from .filtering import FilterOptions

    return FilterOptions(args.filter, max_aniso=args.max_aniso, supersample=args.supersample,
                         fade_energy=args.fade_energy)


def build_parser() -> argparse.ArgumentParser:
    fmt = _Formatter
    parser = _Parser(
        prog="warp-texton",
        description=(
            "Texton noise by example. 'analyze' learns a small texton from an example of a "
            "Gaussian texture (fabric, wood, stone, sand...); 'synthesize' evaluates texton noise "
            "on a raster of any size; 'render-plane' shows it on a ground plane in perspective, anti-aliased; 'mix' blends two textures; 'gaussian' samples the texture's Gaussian model by FFT; "
            "'demo' runs everything on a texture shipped with the package."
        ),
        formatter_class=fmt,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    p = sub.add_parser("analyze", help="compute the texton of an example image",
                       description="Compute the texton of an example image (EUSIPCO Alg. 2 / CGF Alg. 1) "
                                   "and save it as EXR or as a reference-viewer .texton file.",
                       epilog=EPILOG_ANALYZE, formatter_class=fmt)
    p.add_argument("input", help="example image (PNG, JPEG, EXR...)")
    p.add_argument("-o", "--output", required=True, help="output texton: OUT.exr or OUT.texton")
    _add_analyze_options(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")

    p = sub.add_parser("gaussian", help="sample the Gaussian model of an image (FFT)",
                       description="Sample the Gaussian texture model of an image by FFT (ADSN). At the "
                                   "input's own size the result tiles seamlessly.",
                       epilog=EPILOG_GAUSSIAN, formatter_class=fmt)
    p.add_argument("input", help="example image")
    p.add_argument("-o", "--output", required=True, help="output image: .png, .jpg or .exr")
    p.add_argument("--width", type=int, help="output width (default: the input's)")
    p.add_argument("--height", type=int, help="output height (default: the input's)")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("--no-periodic", dest="periodic", action="store_false",
                   help="model the image itself, not its periodic component")

    p = sub.add_parser("synthesize", help="texton noise on a raster (Warp kernels)",
                       description="Evaluate texton noise on a raster with the Warp kernels. INPUT is a "
                                   "texton (.texton, or an EXR written by 'analyze') or an example image, "
                                   "which is analysed first with the analysis options.",
                       epilog=EPILOG_SYNTHESIZE, formatter_class=fmt)
    _add_noise_image_options(p, "raster")
    p.add_argument("--scale", type=float, default=1.0, help="pixels per texel")
    p.add_argument("--rotation", type=float, default=0.0, help="rotation of the noise, degrees")
    p.add_argument("--offset", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"),
                   help="noise position of the raster's top-left corner, texels")
    p.add_argument("--period", type=float, nargs=2, metavar=("PX", "PY"),
                   help="make the noise periodic (texels): a seamless tile")
    _add_filter_options(p, default="none")
    p.add_argument("--device", help="cpu, cuda or cuda:N (default: CUDA when available)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress or summary")
    _add_analyze_options(p, seed=False)

    p = sub.add_parser("render-plane", help="an infinite textured ground plane in perspective",
                       description="Render an infinite ground plane covered with texton noise, seen in "
                                   "perspective (CGF Fig. 3), with the texton filtered for each pixel's "
                                   "footprint (CGF section 5). INPUT is a texton file or an example image.",
                       epilog=EPILOG_PLANE, formatter_class=fmt)
    _add_noise_image_options(p, "image")
    p.add_argument("--camera-height", type=float, default=1.0, help="camera height above the plane, world units")
    p.add_argument("--tilt", type=float, default=70.0,
                   help="degrees between the view direction and straight down (0: straight down)")
    p.add_argument("--fov", type=float, default=40.0, help="vertical field of view, degrees")
    p.add_argument("--texel-size", type=float, default=0.002, help="world units per texel")
    _add_filter_options(p, default="anisotropic")
    p.add_argument("--device", help="cpu, cuda or cuda:N (default: CUDA when available)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress or summary")
    _add_analyze_options(p, seed=False)

    p = sub.add_parser("mix", help="progressive mix of two textures (texton noise)",
                       description="Mix two textures along the optimal-transport path between their Gaussian "
                                   "models (CGF §7): textons for --steps values of rho from A to B, then "
                                   "spatially varying texton noise, across the width in strips or driven "
                                   "by a grey map (black = A, white = B). A and B are images or textons.",
                       epilog=EPILOG_MIX, formatter_class=fmt)
    p.add_argument("a", metavar="A", help="first texture: image or texton")
    p.add_argument("b", metavar="B", help="second texture: image or texton")
    p.add_argument("-o", "--output", required=True, help="output image: .png, .jpg or .exr")
    p.add_argument("--steps", type=int, default=21, help="number of textons from A to B (>= 2)")
    p.add_argument("--map", help="grey image of rho in [0, 1] (black = A, white = B); default: strips")
    p.add_argument("--width", type=int, help="raster width (default: the map's, else 1024)")
    p.add_argument("--height", type=int, help="raster height (default: the map's, else 256)")
    p.add_argument("--mni", type=float, default=30.0, help="mean number of impacts per point")
    p.add_argument("--seed", type=int, default=0, help="random seed (analysis and noise)")
    p.add_argument("--device", help="cpu, cuda or cuda:N (default: CUDA when available)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress or summary")
    _add_analyze_options(p, seed=False)

    p = sub.add_parser("surface", help="texture meshes with surface noise (batch)",
                       description="Colour the vertices of meshes with surface texton noise (CGF §6), no UVs "
                                   "needed, and optionally render each one. Outputs are named after each "
                                   "input's stem; finished outputs are skipped unless --overwrite. One bad "
                                   "mesh is reported and the others still finish; the exit status is 1 if any "
                                   "failed.",
                       epilog=EPILOG_SURFACE, formatter_class=fmt)
    p.add_argument("meshes", nargs="+", metavar="MESH", help="mesh files, glob patterns, or @list.txt")
    p.add_argument("--texton", required=True, help="texton file (.exr or .texton)")
    p.add_argument("--out-dir", required=True, help="folder for the outputs (created if missing)")
    p.add_argument("--texel-size", type=float, help="world units per texel (default: bounding-box diagonal / 256)")
    p.add_argument("--mni", type=float, default=60.0, help="mean number of impacts per point")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("--max-edge", type=float, help="subdivide until no edge is longer than this many texels")
    p.add_argument("--render", metavar="WxH", help="also write a PNG render of this size, e.g. 512x512")
    p.add_argument("--format", choices=("ply", "obj", "glb"), default="ply", help="mesh output format")
    p.add_argument("--overwrite", action="store_true", help="redo meshes whose outputs exist")
    p.add_argument("--jobs", type=int, default=1, help="meshes processed at once")
    p.add_argument("--device", help="cpu, cuda or cuda:N (default: CUDA when available)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")

    p = sub.add_parser("view", help="interactive explorer in a web browser",
                       description="Serve an interactive viewer of the texton noise of INPUT (an example image, "
                                   "analysed at start and again when the page changes the analysis settings, or "
                                   "a texton file): an infinite, zoomable canvas, live controls, a ground plane, "
                                   "mixing, and exports with the commands that reproduce them. Ctrl-C stops it.",
                       epilog=EPILOG_VIEW, formatter_class=fmt)
    p.add_argument("input", help="example image or texton file")
    p.add_argument("--port", type=int, default=8000, help="TCP port (0: any free port)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to bind; anything but 127.0.0.1 lets others on the network use it (with a warning)")
    p.add_argument("--device", help="cpu, cuda or cuda:N (default: CUDA when available)")
    p.add_argument("--open", action="store_true", help="open the page in the default web browser")
    p.add_argument("--mix", metavar="B", help="second image or texton for the mixing mode (the page can also upload one)")
    p.add_argument("--size", type=int, default=64, help="start texton size, texels")
    p.add_argument("--order", type=int, default=1, choices=(0, 1, 3, 5), help="start interpolation order")
    p.add_argument("--no-color-correction", dest="color_correction", action="store_false",
                   help="start without the colour-covariance correction")
    p.add_argument("--seed", type=int, default=0, help="start noise seed")
    p.add_argument("--mni", type=float, default=30.0, help="start mean number of impacts per point")
    p.add_argument("--filter", choices=("none", "mip", "anisotropic"), default="anisotropic",
                   help="start filter for zoomed-out views")
    p.add_argument("--png-level", type=int, default=0, choices=range(10), metavar="0-9",
                   help="zlib level of the tiles: 0 is the fastest to make, 1-9 save bandwidth over a slow link")
    p.add_argument("-v", "--verbose", action="store_true", help="log every request")

    p = sub.add_parser("demo", help="analyse the bundled texture and write pictures",
                       description="Analyse a small CC0 texture shipped with the package and write the "
                                   "input, its Gaussian version, the texton (and the noise) as PNG and EXR.",
                       formatter_class=fmt)
    p.add_argument("-o", "--out-dir", default="demo_out", help="folder to write into")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    return parser


def _cmd_analyze(args) -> None:
    from .analysis import analyze
    from .io import read_image

    out = Path(args.output)
    if out.suffix.lower() not in (".exr", ".texton"):
        raise TextonError(f"{out}: unsupported texton extension {out.suffix or '(none)'!r}; use .exr or .texton")
    u = read_image(args.input)
    t0 = time.perf_counter()
    texton = analyze(u, size=args.size, order=args.order, iterations=args.iterations, seed=args.seed,
                     periodic=args.periodic, color_correction=args.color_correction,
                     support=args.support, progress=not args.quiet)
    texton.metadata["source"] = Path(args.input).name
    texton.save(out)
    if not args.quiet:
        print(f"{out}: {texton.size[0]}x{texton.size[1]} texton, order {texton.order}, "
              f"model error {texton.metadata['model_error']:.3f} ({time.perf_counter() - t0:.2f} s)")


def _cmd_gaussian(args) -> None:
    from .gaussian import gaussian_texture
    from .io import check_image_path, read_image, write_image

    out = check_image_path(args.output)
    u = read_image(args.input)
    shape = (u.shape[0] if args.height is None else args.height, u.shape[1] if args.width is None else args.width)
    write_image(out, gaussian_texture(u, shape=shape, seed=args.seed, periodic=args.periodic))


def _texton_of(args):
    """The texton file named by args.input, or the texton of that example image."""
    from .analysis import analyze
    from .io import read_image
    from .texton import is_texton_path, load_texton

    if is_texton_path(args.input):
        return load_texton(args.input)
    return analyze(read_image(args.input), size=args.size, order=args.order, iterations=args.iterations,
                   seed=args.seed, periodic=args.periodic, color_correction=args.color_correction,
                   support=args.support, progress=not args.quiet)


def _cmd_synthesize(args) -> None:
    from .io import check_image_path, write_image
    from .synthesis import synthesize

    out = check_image_path(args.output)
    options = _filter_options(args)
    t0 = time.perf_counter()
    texton = _texton_of(args)
    noise = synthesize(texton, shape=(args.height, args.width), mni=args.mni, seed=args.seed, scale=args.scale,
                       rotation=args.rotation, offset=tuple(args.offset), period=args.period, device=args.device,
                       filter=options)
    write_image(out, noise)
    if not args.quiet:
        print(f"{out}: {args.width}x{args.height} texton noise, MNI {args.mni:g} "
              f"({time.perf_counter() - t0:.2f} s)")


def _cmd_render_plane(args) -> None:
    from .io import check_image_path, write_image
    from .plane import render_plane

    out = check_image_path(args.output)
    options = _filter_options(args)
    t0 = time.perf_counter()
    texton = _texton_of(args)
    image = render_plane(texton, (args.height, args.width), height=args.camera_height, tilt=args.tilt,
                         fov=args.fov, texel_size=args.texel_size, mni=args.mni, seed=args.seed,
                         filter=options, device=args.device, progress=not args.quiet)
    write_image(out, image)
    if not args.quiet:
        print(f"{out}: {args.width}x{args.height} plane, filter {args.filter}, MNI {args.mni:g} "
              f"({time.perf_counter() - t0:.2f} s)")


def _load_texture(path):
    from .io import read_image
    from .texton import is_texton_path, load_texton

    return load_texton(path) if is_texton_path(path) else read_image(path)


def _cmd_mix(args) -> None:
    from .io import check_image_path, read_image, write_image
    from .limits import check_memory
    from .mixing import mix_textons, synthesize_mixed

    out = check_image_path(args.output)
    if args.steps < 2:
        raise TextonError(f"--steps must be at least 2, got {args.steps}")
    check_memory(16.0 * args.steps, f"--steps {args.steps}", "use fewer --steps")  # before the list of rhos
    weights = "strips"
    if args.map is not None:
        rho = read_image(args.map)
        weights = rho.mean(axis=2)
        shape = (weights.shape[0] if args.height is None else args.height,
                 weights.shape[1] if args.width is None else args.width)
        if shape != weights.shape:
            raise TextonError(f"--map is {weights.shape[1]}x{weights.shape[0]}; --width/--height must match it "
                              f"(got {shape[1]}x{shape[0]})")
    else:
        shape = (256 if args.height is None else args.height, 1024 if args.width is None else args.width)
    t0 = time.perf_counter()
    textons = mix_textons(_load_texture(args.a), _load_texture(args.b), np.linspace(0.0, 1.0, args.steps),
                          size=args.size, order=args.order, seed=args.seed, iterations=args.iterations,
                          periodic=args.periodic, color_correction=args.color_correction,
                          support=args.support, progress=not args.quiet)
    noise = synthesize_mixed(textons, weights, shape, mni=args.mni, seed=args.seed, device=args.device)
    write_image(out, noise)
    if not args.quiet:
        print(f"{out}: {shape[1]}x{shape[0]} mix of {args.steps} textons ({time.perf_counter() - t0:.2f} s)")


def _cmd_surface(args) -> int:
    from ._checks import check_positive, check_seed, check_shape
    from .batch import SurfaceJob, check_unique_outputs, expand_meshes, run_batch
    from ._runtime import resolve_device
    from .texton import load_texton

    load_texton(args.texton)  # a bad texton fails the whole batch, once
    render = None
    if args.render is not None:
        try:
            w, h = (int(v) for v in args.render.lower().split("x"))
        except ValueError:
            raise TextonError(f"--render must be WIDTHxHEIGHT, e.g. 512x512, got {args.render!r}") from None
        render = (h, w)
    if args.jobs < 1:
        raise TextonError(f"--jobs must be at least 1, got {args.jobs}")
    # options are checked once, here, rather than failing every mesh
    if render is not None:
        check_shape(render, "--render")
    check_positive(args.mni, "--mni")
    check_seed(args.seed)
    if args.texel_size is not None:
        check_positive(args.texel_size, "--texel-size")
    if args.max_edge is not None:
        check_positive(args.max_edge, "--max-edge")
    device = resolve_device(args.device)
    meshes = expand_meshes(args.meshes)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [SurfaceJob(m, args.texton, str(out), args.texel_size, args.mni, args.seed, args.max_edge, render,
                       args.format, args.overwrite, device) for m in meshes]
    check_unique_outputs(jobs)
    results = run_batch(jobs, jobs_in_parallel=args.jobs, progress=not args.quiet)
    counts = {s: sum(r.status == s for r in results) for s in ("done", "skipped", "failed")}
    for r in results:
        if r.status == "failed" and args.quiet:
            print(f"warp-texton: error: {r.message}", file=sys.stderr)
    print(f"{counts['done']} done, {counts['skipped']} skipped, {counts['failed']} failed", file=sys.stderr)
    return 1 if counts["failed"] else 0


def _cmd_demo(args) -> None:
    from .demo import run_demo

    for path in run_demo(args.out_dir, seed=args.seed, progress=not args.quiet):
        if not args.quiet:
            print(path)


def _cmd_view(args) -> int:
    from .view import serve

    try:
        handle = serve(args.input, port=args.port, host=args.host, device=args.device, mix=args.mix,
                       size=args.size, order=args.order, color_correction=args.color_correction, seed=args.seed,
                       mni=args.mni, filter=args.filter, png_level=args.png_level, open_browser=args.open,
                       verbose=args.verbose)
    except KeyboardInterrupt:
        return 130
    try:  # the line is inside: a Ctrl-C right after it (the page may already be open) still stops cleanly
        print(f"warp-texton view: serving {args.input} at {handle.url} (Ctrl-C to stop)", flush=True)
        handle.wait()
    except KeyboardInterrupt:
        print("\nwarp-texton view: stopped", file=sys.stderr)
    finally:
        handle.close()
    return 0


COMMANDS = {
    "analyze": _cmd_analyze,
    "gaussian": _cmd_gaussian,
    "synthesize": _cmd_synthesize,
    "render-plane": _cmd_render_plane,
    "mix": _cmd_mix,
    "surface": _cmd_surface,
    "demo": _cmd_demo,
    "view": _cmd_view,
}


#: Parameter names of the library (as its messages spell them) -> the options that set them.
OPTION_NAMES = {
    "shape[0] (height)": "--height", "shape[1] (width)": "--width", "shape": "--width/--height",
    "height (the camera's height above the plane)": "--camera-height",
    "offset[0]": "--offset X", "offset[1]": "--offset Y", "offset": "--offset",
    "period[0]": "--period PX", "period[1]": "--period PY", "period": "--period",
    "size": "--size", "order": "--order", "iterations": "--iterations", "seed": "--seed", "support": "--support",
    "mni": "--mni", "scale": "--scale", "rotation": "--rotation", "filter": "--filter",
    "supersample": "--supersample", "max_aniso": "--max-aniso", "fade_energy": "--fade-energy",
    "device": "--device", "tilt": "--tilt", "fov": "--fov", "texel_size": "--texel-size",
    "max_edge": "--max-edge", "weights map": "--map", "weights": "--map", "rhos": "--steps",
    "port": "--port", "host": "--host", "png_level": "--png-level", "mix": "--mix",
}
_AFTER_WORDS = "|".join(f"(?<={w} )" for w in ("lower", "higher", "smaller", "larger", "fewer", "more"))


def _file_names(args) -> dict:
    """The library's names of the inputs (u, v, texton) -> the files given for them."""
    if args.command == "mix":
        return {"u, v": f"{args.a}, {args.b}", "u": args.a, "v": args.b}
    if getattr(args, "input", None) is not None:
        return {"u": args.input, "texton": args.input}
    return {}


def cli_message(message: str, args) -> str:
    """A library message in the command line's words: the parameter it starts with, the
    values it quotes ("for size 33", "size <= 32") and the changes it suggests ("a lower
    mni") name the option that sets them, and an input (``u``) the file given for it."""
    files = _file_names(args)
    names = {**OPTION_NAMES, **files}
    for name in sorted(names, key=len, reverse=True):
        if message.startswith(name) and not re.match(r"[\w]", message[len(name):len(name) + 1]):
            message = names[name] + message[len(name):]
            break
    for name in sorted(OPTION_NAMES, key=len, reverse=True):
        if name.startswith("shape") or " " in name:
            continue
        word = re.escape(name)
        message = re.sub(rf"(?<![\w\-.'])({word})(?= (?:<=|>=|<|>|=|-?\d))", OPTION_NAMES[name], message)
        message = re.sub(rf"(?:{_AFTER_WORDS})({word})(?![\w\[])", OPTION_NAMES[name], message)
    return message


def _terminated(signum, frame):
    # SIGTERM as SystemExit: every atomic write in progress removes its temporary file
    raise SystemExit(128 + signum)


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    saved_format = warnings.formatwarning
    warnings.formatwarning = lambda msg, *a, **k: f"warp-texton: warning: {msg}\n"
    saved_term = None
    if threading.current_thread() is threading.main_thread():
        saved_term = signal.signal(signal.SIGTERM, _terminated)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            status = COMMANDS[args.command](args)
    except TextonError as exc:
        print(f"warp-texton: error: {cli_message(str(exc), args)}", file=sys.stderr)
        return 2
    except OSError as exc:  # disk full, permission denied... still one line
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"warp-texton: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print("warp-texton: error: out of memory; the request fits the memory budget but not the memory free now: "
              "lower WARP_TEXTON_MEMORY_BUDGET or ask for less (docs/limits.md)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\nwarp-texton: interrupted; nothing was written for the unfinished output", file=sys.stderr)
        return 130
    finally:
        warnings.formatwarning = saved_format
        if saved_term is not None:
            signal.signal(signal.SIGTERM, saved_term)
    return status or 0


if __name__ == "__main__":
    sys.exit(main())
