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
  warp-texton synthesize wood.texton -o wood16.png --dtype uint16
  warp-texton synthesize wood.texton -o big.zarr --width 65536 --height 65536 --chunk 4096 --dtype uint8
  warp-texton synthesize wood.texton -o big.zarr --width 65536 --height 65536 --scheduler tcp://10.0.0.5:8786
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
  warp-texton surface scans/*.ply --texton wood.png --out-dir baked --bake 2048 --texture png
  warp-texton surface model.glb --texton wood.exr --out-dir out --bake 1024 --format obj --render 800x600 --view 30,20
  warp-texton surface @meshes.txt --texton wood.texton --out-dir out --texel-size 0.002 --format glb --jobs 2
  warp-texton surface 'scans/*.ply' --texton wood.exr --out-dir out --bake 2048 --scheduler tcp://head:8786
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


def _add_noise_image_options(p: argparse.ArgumentParser, what: str, zarr: bool = False) -> None:
    """INPUT, -o, the image size, MNI and seed of the commands that write noise images."""
    p.add_argument("input", help="texton file or example image")
    p.add_argument("-o", "--output", required=True,
                   help="output image: .png, .jpg, .exr or .tif" + (", or a .zarr store" if zarr else ""))
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


def _add_format_options(p: argparse.ArgumentParser, zarr: bool = False) -> None:
    """How the output stores its pixels (and, with ``zarr``, how a .zarr store is written)."""
    from .io import EXR_COMPRESSIONS, TIFF_COMPRESSIONS

    g = p.add_argument_group("output format")
    g.add_argument("--dtype", choices=("uint8", "uint16", "float16", "float32"),
                   help="stored pixel type: PNG uint8 (default) or uint16; EXR float32 (default) or float16; TIFF "
                        "any, default float32" + ("; Zarr any, default float16" if zarr else "")
                        + ". Integer types clip to [0, 1] and say how many pixels were clipped")
    g.add_argument("--half", action="store_true", help="short for --dtype float16")
    g.add_argument("--compression", choices=sorted(set(EXR_COMPRESSIONS) | set(TIFF_COMPRESSIONS)),
                   help=f"EXR: {', '.join(EXR_COMPRESSIONS)} (default zip; pxr24, b44, b44a, dwaa, dwab are lossy); "
                        f"TIFF: {', '.join(TIFF_COMPRESSIONS)} (default zlib)")
    if zarr:
        g = p.add_argument_group("Zarr output (-o NAME.zarr): chunk by chunk, larger than memory")
        g.add_argument("--chunk", type=int, help="chunk side in pixels (default 4096, at most the raster's)")
        g.add_argument("--scheduler", default="threads",
                       help="threads, processes, or the address of a dask.distributed scheduler (tcp://HOST:8786), "
                            "whose workers must see the output path")
        g.add_argument("--workers", type=int, help="local threads or processes (default: the cores)")
        g.add_argument("--overwrite", action="store_true", help="replace an existing store once the new one is done")


def _dtype_of(args):
    """--dtype, or float16 for --half."""
    if args.half and args.dtype not in (None, "float16"):
        raise TextonError(f"--half and --dtype {args.dtype} disagree; give one of them")
    return "float16" if args.half else args.dtype


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
    _add_noise_image_options(p, "raster", zarr=True)
    p.add_argument("--scale", type=float, default=1.0, help="pixels per texel")
    p.add_argument("--rotation", type=float, default=0.0, help="rotation of the noise, degrees")
    p.add_argument("--offset", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"),
                   help="noise position of the raster's top-left corner, texels")
    p.add_argument("--period", type=float, nargs=2, metavar=("PX", "PY"),
                   help="make the noise periodic (texels): a seamless tile")
    _add_filter_options(p, default="none")
    p.add_argument("--device", help="cpu, cuda or cuda:N (default: CUDA when available)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress or summary")
    _add_format_options(p, zarr=True)
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
    _add_format_options(p)
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
                       description="Put surface texton noise (CGF §6) on meshes: baked into a texture on UVs "
                                   "(--bake RES: the mesh's own UVs, or an atlas made by xatlas) or as vertex "
                                   "colours, and optionally render each one. Outputs are named after each "
                                   "input's stem; finished outputs are skipped unless --overwrite. One bad "
                                   "mesh is reported and the others still finish; the exit status is 1 if any "
                                   "failed, 130 if interrupted.",
                       epilog=EPILOG_SURFACE, formatter_class=fmt)
    p.add_argument("meshes", nargs="+", metavar="MESH", help="mesh files, glob patterns, or @list.txt")
    p.add_argument("--texton", required=True,
                   help="texton file (.exr or .texton) or example image (analysed once for the batch)")
    p.add_argument("--out-dir", required=True, help="folder for the outputs (created if missing)")
    p.add_argument("--texel-size", type=float, help="world units per texel (default: bounding-box diagonal / 256)")
    p.add_argument("--mni", type=float, default=60.0, help="mean number of impacts per point")
    p.add_argument("--seed", type=int, default=0, help="random seed (analysis and noise)")
    p.add_argument("--bake", type=int, metavar="RES",
                   help="bake the noise into a RES x RES texture on UVs (GLB or OBJ+MTL+PNG)")
    p.add_argument("--uv", choices=("auto", "mesh", "atlas"), default="auto",
                   help="with --bake: the mesh's UVs when it has them (auto), only them (mesh), or a new atlas")
    p.add_argument("--texture", choices=("png", "exr"),
                   help="with --bake: also write the texture alone as NAME_texture.png (8-bit sRGB) or .exr")
    p.add_argument("--exr-linear", action="store_true",
                   help="an EXR texture holds linear values (the sRGB decoding) instead of the noise's own values")
    p.add_argument("--supersample", type=int, metavar="N",
                   help="with --bake: N x N samples per texel (default: by each texel's footprint)")
    p.add_argument("--max-edge", type=float, help="subdivide until no edge is longer than this many texels")
    p.add_argument("--render", metavar="WxH", help="also write a PNG render of this size, e.g. 512x512")
    p.add_argument("--up", choices=("auto", "x", "y", "z"), default="auto",
                   help="the meshes' up axis: auto is y for .glb/.gltf (Y-up by definition), z otherwise")
    p.add_argument("--view", metavar="AZ,EL",
                   help="render camera azimuth and elevation in degrees (default -55,25: front left, above; "
                        "a negative azimuth as --view=-30,20)")
    p.add_argument("--fov", type=float, help="render vertical field of view, degrees (default 35)")
    p.add_argument("--format", choices=("ply", "obj", "glb"),
                   help="mesh output format (default: glb with --bake, else ply)")
    p.add_argument("--overwrite", action="store_true", help="redo meshes whose outputs exist")
    p.add_argument("--jobs", type=int, default=1, help="meshes processed at once")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the batch on this dask.distributed scheduler (paths must be visible to its workers)")
    p.add_argument("--device", help="cpu, cuda or cuda:N (default: CUDA when available)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    _add_analyze_options(p, seed=False)

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
    from .io import check_dtype, check_image_path, write_image
    from .synthesis import synthesize

    out = Path(args.output)
    dtype = _dtype_of(args)
    if out.suffix.lower() == ".zarr":
        return _synthesize_zarr(args, out, dtype)
    zarr_only = [name for name, value in (("--chunk", args.chunk), ("--workers", args.workers),
                                          ("--overwrite", args.overwrite or None),
                                          ("--scheduler", None if args.scheduler == "threads" else args.scheduler))
                 if value is not None]
    if zarr_only:
        raise TextonError(f"{', '.join(zarr_only)} apply to .zarr outputs only")
    out = check_image_path(out)
    check_dtype(out, dtype)
    options = _filter_options(args)
    t0 = time.perf_counter()
    texton = _texton_of(args)
    noise = synthesize(texton, shape=(args.height, args.width), mni=args.mni, seed=args.seed, scale=args.scale,
                       rotation=args.rotation, offset=tuple(args.offset), period=args.period, device=args.device,
                       filter=options, progress=not args.quiet)
    write_image(out, noise, dtype=dtype, compression=args.compression)
    if not args.quiet:
        print(f"{out}: {args.width}x{args.height} texton noise, MNI {args.mni:g} "
              f"({time.perf_counter() - t0:.2f} s)")


def _synthesize_zarr(args, out: Path, dtype) -> None:
    """synthesize -o NAME.zarr: the raster written chunk by chunk (warp_texton.dask)."""
    try:
        from .dask import CHUNK, ZARR_DTYPE, ZARR_DTYPES, check_big_shape, check_scheduler, write_zarr
    except ImportError:
        raise TextonError('.zarr outputs need Dask and Zarr: pip install "warp-texton[dask]"') from None
    check_scheduler(args.scheduler)
    if dtype is not None and dtype not in ZARR_DTYPES:
        raise TextonError(f"--dtype for a Zarr store must be one of {', '.join(ZARR_DTYPES)}, got {dtype}")
    if args.workers is not None and args.workers < 1:
        raise TextonError(f"--workers must be at least 1, got {args.workers}")
    if args.compression is not None:
        raise TextonError("--compression applies to .exr and .tif outputs; Zarr chunks are zstd-compressed")
    if out.exists() and not args.overwrite:
        raise TextonError(f"{out}: exists; give --overwrite to replace it")
    h, w = check_big_shape((args.height, args.width))
    chunk = args.chunk if args.chunk is not None else (min(CHUNK, h), min(CHUNK, w))
    if args.chunk is not None and args.chunk < 1:
        raise TextonError(f"--chunk must be a positive number of pixels, got {args.chunk}")
    if args.chunk is not None and args.chunk > max(h, w):
        raise TextonError(f"--chunk {args.chunk} exceeds the {w}x{h} raster; use at most {max(h, w)}")
    if isinstance(chunk, int):
        chunk = (min(chunk, h), min(chunk, w))
    t0 = time.perf_counter()
    texton = _texton_of(args)
    report = write_zarr(out, texton, (h, w), chunk, dtype or ZARR_DTYPE, scheduler=args.scheduler,
                        workers=args.workers, overwrite=args.overwrite, progress=not args.quiet,
                        mni=args.mni, seed=args.seed, scale=args.scale, rotation=args.rotation,
                        offset=tuple(args.offset), period=args.period, device=args.device,
                        filter=_filter_options(args))
    if not args.quiet:
        print(f"{out}: {w}x{h} texton noise, MNI {args.mni:g}, {report['dtype']} Zarr in chunks of "
              f"{chunk[0]}x{chunk[1]} ({time.perf_counter() - t0:.2f} s)")


def _cmd_render_plane(args) -> None:
    from .io import check_dtype, check_image_path, write_image
    from .plane import render_plane

    out = check_image_path(args.output)
    dtype = check_dtype(out, _dtype_of(args))
    options = _filter_options(args)
    t0 = time.perf_counter()
    texton = _texton_of(args)
    image = render_plane(texton, (args.height, args.width), height=args.camera_height, tilt=args.tilt,
                         fov=args.fov, texel_size=args.texel_size, mni=args.mni, seed=args.seed,
                         filter=options, device=args.device, progress=not args.quiet)
    write_image(out, image, dtype=dtype, compression=args.compression)
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


def _surface_texton(args):
    """The batch's texton: a texton file, or an example image analysed once (a bad one fails the batch)."""
    from .texton import is_texton_path, load_texton

    if is_texton_path(args.texton):
        load_texton(args.texton)  # checked once here; the jobs read it themselves
        return args.texton
    try:
        return _texton_of(argparse.Namespace(**{**vars(args), "input": args.texton}))
    except TextonError as exc:
        message = str(exc)
        raise TextonError(message if args.texton in message else f"--texton {args.texton}: {message}") from None


def _cmd_surface(args) -> int:
    try:
        return _run_surface(args)
    except KeyboardInterrupt:  # before or after the batch itself (which reports its own)
        print("warp-texton: interrupted", file=sys.stderr)
        return 130


def _run_surface(args) -> int:
    from ._checks import check_int, check_positive, check_seed, check_shape
    from .batch import BatchInterrupted, SurfaceJob, check_unique_outputs, expand_meshes, run_batch
    from ._runtime import resolve_device
    from .bake import MAX_RESOLUTION
    from .render import view_direction

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
    if args.bake is not None:
        check_int(args.bake, "--bake", minimum=1)
        if args.bake > MAX_RESOLUTION:
            raise TextonError(f"--bake must be at most {MAX_RESOLUTION} texels per side, got {args.bake}")
        if args.format == "ply":
            raise TextonError("--bake writes --format glb or obj (a PLY file cannot carry a texture)")
        if args.max_edge is not None:
            raise TextonError("--max-edge subdivides for vertex colours; a --bake texture does not need it")
    else:
        for name, value in (("--texture", args.texture), ("--supersample", args.supersample),
                            ("--exr-linear", args.exr_linear or None), ("--uv", None if args.uv == "auto" else 1)):
            if value is not None:
                raise TextonError(f"{name} applies to baked textures: add --bake RES")
    if args.supersample is not None:
        check_int(args.supersample, "--supersample", minimum=1)
    if args.exr_linear and args.texture != "exr":
        raise TextonError("--exr-linear applies to --texture exr")
    view = None
    if args.view is not None:
        try:
            view = tuple(float(v) for v in args.view.split(","))
            if len(view) != 2:
                raise ValueError
        except ValueError:
            raise TextonError(f"--view must be AZIMUTH,ELEVATION in degrees, e.g. 30,20, got {args.view!r}") from None
        try:
            view_direction(view)
        except TextonError as exc:
            raise TextonError(f"--view: {exc}") from None
    if args.fov is not None:
        check_positive(args.fov, "--fov")
        if args.fov >= 180:
            raise TextonError(f"--fov must be below 180 degrees, got {args.fov}")
    device = resolve_device(args.device)
    executor = client = None
    if args.scheduler is not None:
        try:
            from dask.distributed import Client
        except ImportError:
            raise TextonError("--scheduler needs dask.distributed: pip install 'warp-texton[dask]'") from None
        try:
            client = Client(args.scheduler, timeout=10)
        except Exception as exc:
            raise TextonError(f"--scheduler {args.scheduler}: cannot connect ({type(exc).__name__}: {exc})") from None
        executor = client.get_executor()
    try:
        texton = _surface_texton(args)
        meshes = expand_meshes(args.meshes)
        out = Path(args.out_dir)
        out.mkdir(parents=True, exist_ok=True)
        jobs = [SurfaceJob(m, texton, str(out), args.texel_size, args.mni, args.seed, args.max_edge, render,
                           args.format, args.overwrite, device, bake=args.bake, uv=args.uv, texture=args.texture,
                           exr_linear=args.exr_linear, supersample=args.supersample, up=args.up, view=view,
                           fov=args.fov) for m in meshes]
        check_unique_outputs(jobs)
        interrupted = False
        try:
            results = run_batch(jobs, executor=executor, jobs_in_parallel=args.jobs, progress=not args.quiet)
        except BatchInterrupted as exc:
            results, interrupted = exc.results, True
    finally:
        if client is not None:
            client.close()
    counts = {s: sum(r.status == s for r in results) for s in ("done", "skipped", "failed", "cancelled")}
    for r in results:
        if r.status == "failed" and (args.quiet or interrupted):
            print(f"warp-texton: error: {r.message}", file=sys.stderr)
        for note in r.warnings:
            if "texels apart" in note or not args.quiet:
                print(f"warp-texton: {'warning' if 'texels apart' in note else 'note'}: {note}", file=sys.stderr)
    line = f"{counts['done']} done, {counts['skipped']} skipped, {counts['failed']} failed"
    if interrupted:
        print(f"warp-texton: interrupted: {line}, {counts['cancelled']} cancelled", file=sys.stderr)
        return 130
    print(line, file=sys.stderr)
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
        print("\nwarp-texton: interrupted; nothing written", file=sys.stderr)
        return 130
    finally:
        warnings.formatwarning = saved_format
        if saved_term is not None:
            signal.signal(signal.SIGTERM, saved_term)
    return status or 0


if __name__ == "__main__":
    sys.exit(main())
