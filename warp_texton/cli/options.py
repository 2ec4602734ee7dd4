"""What the commands of ``warp-texton`` share: the command record, the option
groups several commands take (each with the library arguments its options
set), and the library's errors in the command line's words.

A command (:class:`Command`) is its arguments and its handler side by side,
plus ``names``: the library arguments its options set (``"mni"`` ->
``"--mni"``). A :class:`~warp_texton.TextonError` says which argument it is
about (``param``) and which others its message speaks of (``mentions``); the
command line puts the option, or the file given for an input, in their place
(:meth:`~warp_texton.TextonError.in_words`). Nothing here imports Warp: ``--help`` and usage errors
stay quick.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from ..core.errors import TextonError
from ..noise.filter_options import FADE_ENERGY, FILTERS, MAX_ANISO, SUPERSAMPLE, FilterKind


def no_files(args: argparse.Namespace) -> dict[str, str]:
    return {}


def input_file(args: argparse.Namespace) -> dict[str, str]:
    """The library's names of a command's one input (an image, or a texton) -> the file given."""
    return {"u": args.input, "texton": args.input}


@dataclass(frozen=True)
class Command:
    """One ``warp-texton`` command.

    ``arguments(parser)`` adds its arguments, ``run(args)`` does the work and
    returns the exit status (None: 0). ``names`` maps the library arguments
    its options set to those options, and ``files(args)`` the library's names
    of its inputs to the files given for them: together they put an error in
    the command line's words.
    """

    name: str
    help: str
    description: str
    arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int | None]
    names: Mapping[str, str] = field(default_factory=dict)
    files: Callable[[argparse.Namespace], dict[str, str]] = no_files
    epilog: str | None = None


# ------------------------------------------------------------------ option groups
#: The options of the analysis of an example image, by the argument they set.
ANALYSIS_NAMES = {"size": "--size", "order": "--order", "iterations": "--iterations", "seed": "--seed",
                  "support": "--support", "histogram": "--histogram", "downscale": "--downscale",
                  "factor": "--downscale", "crop": "--crop", "crop x": "--crop X", "crop y": "--crop Y",
                  "crop width": "--crop W", "crop height": "--crop H", "method": "--method",
                  "side": "--side", "lattice": "--lattice", "periodic": "--periodic"}


def add_analysis_options(p: argparse.ArgumentParser, seed: bool = True) -> None:
    g = p.add_argument_group("analysis options" + ("" if seed else " (when INPUT is an image)"))
    g.add_argument("--method", choices=("auto", "texton", "tiling"), default="auto",
                   help="auto (default): the method whose output is closer to the example (tiling where the "
                        "example has shapes, texton where it is Gaussian-like); texton: Gaussian texton noise; "
                        "tiling: tiling and blending of the example, for structured textures (bricks, tiles; "
                        "docs/tiling.md)")
    g.add_argument("--size", type=int, default=64, help="texton side (square) or diameter (disk), in texels")
    g.add_argument("--side", type=int, default=None,
                   help="with --method tiling (or auto): the side of the blend triangles, in texels (default: "
                        "chosen by the fit, up to half the example's smaller side where it is seamless)")
    g.add_argument("--lattice", default="auto", metavar="auto|none|DY,DX[;DY,DX]",
                   help="with --method tiling (or auto): the example's lattice, detected (auto, default), none, or "
                        "one or two vectors in texels (courses; tiles and bonds), e.g. '32,32;32,-32'")
    g.add_argument("--order", type=int, default=1, choices=(0, 1, 3, 5),
                   help="interpolation order: 0 nearest (EUSIPCO SOT), 1 bilinear (CGF), 3/5 B-spline")
    g.add_argument("--iterations", type=int, default=50, help="alternating projections")
    if seed:
        g.add_argument("--seed", type=int, default=0, help="random seed")
    g.add_argument("--support", choices=("square", "disk"), default="square", help="shape of the texton support")
    g.add_argument("--periodic", choices=("auto", "yes", "no"), default="auto",
                   help="tiling: read the example wrapped across its borders (yes), not (no), or where it is "
                        "seamless (auto, default); texton: analyse its periodic component (auto, yes) or the "
                        "image itself (no)")
    g.add_argument("--no-periodic", dest="periodic", action="store_const", const="no",
                   help="the same as --periodic no")
    g.add_argument("--no-color-correction", dest="color_correction", action="store_false",
                   help="skip the colour-covariance correction")
    g.add_argument("--histogram", choices=("gaussian", "preserve"), default="gaussian",
                   help="preserve: keep the example's colour histogram (a transform the texton carries; EXR only)")
    g.add_argument("--crop", type=int, nargs=4, metavar=("X", "Y", "W", "H"),
                   help="analyse only the W x H patch whose top-left pixel is (X, Y): an evenly lit part of a photo")
    g.add_argument("--downscale", type=int, default=1, metavar="F",
                   help="shrink the example F times (the mean of F x F blocks) before analysing it, after --crop: "
                        "for a photo whose features are larger than the texton, or too large to analyse quickly")


#: The size of an output raster, by the argument it sets.
SHAPE_NAMES = {"shape[0] (height)": "--height", "shape[1] (width)": "--width", "shape": "--width/--height"}
#: The options of the commands that write noise images (INPUT, the size, MNI, seed, device).
NOISE_IMAGE_NAMES = {**SHAPE_NAMES, "mni": "--mni", "seed": "--seed", "device": "--device"}


def add_noise_image_options(p: argparse.ArgumentParser, what: str, zarr: bool = False) -> None:
    """INPUT, -o, the image size, MNI and seed of the commands that write noise images."""
    p.add_argument("input", help="texton file or example image")
    p.add_argument("-o", "--output", required=True,
                   help="output image: .png, .jpg, .exr or .tif" + (", or a .zarr store" if zarr else ""))
    p.add_argument("--width", type=int, default=512, help=f"{what} width in pixels")
    p.add_argument("--height", type=int, default=512, help=f"{what} height in pixels")
    p.add_argument("--mni", type=float, default=30.0, help="mean number of impacts per point")
    p.add_argument("--seed", type=int, default=0, help="random seed (analysis and noise)")


def add_placement_options(p: argparse.ArgumentParser) -> None:
    """--scale, --rotation, --offset and --period: where a raster samples the noise, as ``synthesize`` takes them."""
    p.add_argument("--scale", type=float, default=1.0, help="pixels per texel")
    p.add_argument("--rotation", type=float, default=0.0, help="rotation of the noise, degrees")
    p.add_argument("--offset", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"),
                   help="noise position of the raster's top-left corner, texels")
    p.add_argument("--period", type=float, nargs=2, metavar=("PX", "PY"),
                   help="make the noise periodic (texels): a seamless tile")


def add_run_options(p: argparse.ArgumentParser, quiet: str = "no progress or summary") -> None:
    """--device and -q."""
    p.add_argument("--device", help="cpu, cuda or cuda:N (default: CUDA when available)")
    p.add_argument("-q", "--quiet", action="store_true", help=quiet)


#: The options of the filters, by the argument they set.
FILTER_NAMES = {"filter": "--filter", "supersample": "--supersample", "max_aniso": "--max-aniso",
                "fade_energy": "--fade-energy"}


def filter_help(kinds: Mapping[str, FilterKind]) -> str:
    """The kinds of a --filter option, one clause each."""
    return "; ".join(f"{k.name}: {k.description}" for k in kinds.values())


def add_filter_options(p: argparse.ArgumentParser, default: str | None) -> None:
    """--filter and its settings; ``default`` None: the command chooses (``synthesize``: none)."""
    p.add_argument("--filter", choices=FILTERS, default=default,
                   help="anti-aliasing for each pixel's footprint. " + filter_help(FILTERS)
                        + ("" if default is not None else ". Default: none (a warning below --scale 0.5)"))
    p.add_argument("--supersample", type=int, default=SUPERSAMPLE,
                   help="samples per pixel side for --filter supersample")
    p.add_argument("--max-aniso", type=int, default=MAX_ANISO,
                   help="most lookups along a footprint's major axis for --filter anisotropic")
    p.add_argument("--fade-energy", type=float, default=FADE_ENERGY,
                   help="end the MIP pyramid at the first level keeping less than this fraction of the "
                        "variance; larger footprints fade to the mean (0 keeps every level)")


def filter_options(args):
    """The FilterOptions of --filter, --supersample, --max-aniso and --fade-energy."""
    from ..noise.filter_options import FilterOptions

    return FilterOptions(args.filter, max_aniso=args.max_aniso, supersample=args.supersample,
                         fade_energy=args.fade_energy)


def noise_options(args):
    """The NoiseOptions of --mni, --seed and, where the command has it, --period."""
    from ..noise.noise_options import NoiseOptions

    return NoiseOptions(mni=args.mni, seed=args.seed, period=getattr(args, "period", None))


def analysis_options(args):
    """The AnalysisOptions of the analysis options (--size, --order, --iterations, --seed,
    --support, --no-periodic, --no-color-correction, --histogram)."""
    from ..model.analysis_options import AnalysisOptions

    return AnalysisOptions(size=args.size, order=args.order, iterations=args.iterations, seed=args.seed,
                           periodic=args.periodic != "no", color_correction=args.color_correction,
                           support=args.support, histogram=args.histogram)


def lattice_argument(text: str):
    """--lattice's value as ``analyze``'s ``lattice``: "auto", None, or one or two (dy, dx) vectors."""
    if text == "auto":
        return "auto"
    if text == "none":
        return None
    try:
        vectors = [tuple(float(v) for v in part.split(",")) for part in text.split(";")]
    except ValueError:
        vectors = []
    if not 1 <= len(vectors) <= 2 or any(len(v) != 2 for v in vectors):
        raise TextonError(f"--lattice must be auto, none, or one or two vectors DY,DX separated by ';', got "
                          f"{text!r:.60}", param="lattice")
    return vectors


def add_format_options(p: argparse.ArgumentParser, zarr: bool = False) -> None:
    """How the output stores its pixels (and, with ``zarr``, how a .zarr store is written)."""
    from ..files.images import EXR_COMPRESSIONS, TIFF_COMPRESSIONS

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


def dtype_of(args):
    """--dtype, or float16 for --half."""
    if args.half and args.dtype not in (None, "float16"):
        raise TextonError(f"--half and --dtype {args.dtype} disagree; give one of them")
    return "float16" if args.half else args.dtype


# ------------------------------------------------------------------ inputs and timing
def read_example(path, iterations: int, crop=None, downscale: int = 1, *, histogram: str = "gaussian",
                 method: str = "texton"):
    """An example image, cut to ``crop`` (x, y, width, height) and shrunk ``downscale``
    times; its analysis (``method``, ``histogram``) priced from the file's header before its
    pixels are decoded (the same estimate as ``analyze``'s)."""
    from ..model.analysis import check_analysis_cost
    from ..model.example_checks import crop_box
    from ..model.example_checks import downscale as shrink
    from ..model.structure import check_tiling_analysis, tiling_affordable
    from ..files.images import image_size, read_image

    size = image_size(path)
    if size is not None:
        h, w, c = size
        if crop is not None:
            _, _, w, h = crop_box(crop, (h, w))
        if isinstance(downscale, int) and 1 <= downscale <= min(h, w):
            h, w = h // downscale, w // downscale
        if method == "tiling":
            check_tiling_analysis((h, w, c), histogram=histogram)
        if method == "auto" and not tiling_affordable((h, w, c), histogram):
            method = "texton"  # auto: an example too large for a tiling model is a texton's
        if method in ("texton", "auto"):
            check_analysis_cost((h, w), c, iterations, f"analysing a {w}x{h} image", histogram=histogram)
    u = read_image(path)
    if crop is not None:
        x, y, w, h = crop_box(crop, u.shape)
        u = u[y:y + h, x:x + w]
    return u if downscale == 1 else shrink(u, downscale)


def analysis_kwargs(args) -> dict:
    """``analyze``'s keyword arguments from the analysis options (``--method tiling``: its own)."""
    method = getattr(args, "method", "texton")
    lattice = getattr(args, "lattice", "auto")
    if method == "texton":
        for flag, given in (("--side", getattr(args, "side", None) is not None), ("--lattice", lattice != "auto")):
            if given:
                raise TextonError(f"{flag} applies to --method tiling (or auto) only", param=flag[2:])
        return {"options": analysis_options(args)}
    periodic = {"auto": "auto", "yes": True, "no": False}[args.periodic]
    tiling = {"method": method, "side": args.side, "seed": args.seed, "histogram": args.histogram,
              "periodic": periodic, "lattice": lattice_argument(lattice)}
    if method == "tiling":
        texton_only = [flag for flag, value, default in (
            ("--size", args.size, 64), ("--order", args.order, 1), ("--iterations", args.iterations, 50),
            ("--support", args.support, "square"), ("--no-color-correction", args.color_correction, True))
            if value != default]
        if texton_only:
            verb = "applies" if len(texton_only) == 1 else "apply"
            raise TextonError(f"{', '.join(texton_only)} {verb} to --method texton only", param="method")
        return tiling
    return {**tiling, "size": args.size, "order": args.order, "iterations": args.iterations,
            "support": args.support, "color_correction": args.color_correction}


def texton_of(args, path=None):
    """The texton file ``path`` (default: args.input), or the texton of that example
    image, analysed with the analysis options."""
    from ..model.texton import is_texton_path, load_texton

    path = args.input if path is None else path
    if is_texton_path(path):
        return load_texton(path)
    kwargs = analysis_kwargs(args)  # options that do not apply are refused before the image is read
    from ..model.analysis import analyze  # SciPy's FFT, only for an image

    u = read_example(path, args.iterations, args.crop, args.downscale, histogram=args.histogram, method=args.method)
    return analyze(u, **kwargs, progress=show_progress(args))


#: perf_counter() minus the seconds the process had run when the command began: set by
#: :func:`start_clock`, so that summaries give the wall time a user waited, start-up included.
_started: list[float] = []


def process_age() -> float:
    """Seconds since this process started (Linux: /proc), else 0."""
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return max(uptime - int(fields[19]) / os.sysconf("SC_CLK_TCK"), 0.0)
    except (OSError, ValueError, IndexError, AttributeError):
        return 0.0


def start_clock(startup: bool) -> None:
    """Start the wall clock of a command: from the process's start when ``startup`` (the
    ``warp-texton`` program), else from now (``main`` called from Python)."""
    _started[:] = [time.perf_counter() - (process_age() if startup else 0.0)]


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars for this command: not with -q, and only on a terminal (no escape codes in logs)."""
    from ..core import progress

    return not getattr(args, "quiet", False) and progress.terminal()


def seconds_since(t0: float) -> str:
    """The work's seconds since ``t0`` and, once :func:`start_clock` ran, the command's wall time."""
    now = time.perf_counter()
    work = f"{now - t0:.2f} s"
    return f"{work}, {now - _started[0]:.2f} s wall" if _started else work


# ------------------------------------------------------------------ errors
