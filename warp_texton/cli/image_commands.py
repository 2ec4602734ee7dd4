"""The commands of ``warp-texton`` that write images: ``analyze``, ``gaussian``,
``synthesize``, ``render-plane``, ``mix`` and ``demo``.

Each command's arguments and handler stand together, then its :class:`Command`
record; the library modules are imported inside the handlers, so that
``--help`` does not start Warp.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

from .options import (ANALYSIS_NAMES, FILTER_NAMES, NOISE_IMAGE_NAMES, SHAPE_NAMES, Command,
                          add_analysis_options, add_filter_options, add_format_options, add_noise_image_options,
                          add_placement_options, add_run_options, analysis_options, dtype_of, filter_options,
                          input_file, noise_options, seconds_since, show_progress, texton_of)
from ..core.errors import OverBudget, TextonError


# ------------------------------------------------------------------ analyze
def _analyze_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", help="example image (PNG, JPEG, EXR...)")
    p.add_argument("-o", "--output", required=True, help="output texton: OUT.exr or OUT.texton")
    add_analysis_options(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")


def _analyze(args) -> None:
    from ..model.analysis import analyze
    from .info import structure_lines, summary
    from .options import analysis_kwargs, read_example
    from ..model.structure import scorable, structure_score
    from ..model.tiling import TilingModel, suggest_method

    out = Path(args.output)
    if out.suffix.lower() not in (".exr", ".texton"):
        raise TextonError(f"{out}: unsupported texton extension {out.suffix or '(none)'!r}; use .exr or .texton")
    if args.histogram == "preserve" and out.suffix.lower() == ".texton":
        raise TextonError(f"{out}: the .texton format cannot hold a histogram transform; save it as .exr",
                          param="histogram")
    if args.method == "tiling" and out.suffix.lower() != ".exr":
        raise TextonError(f"{out}: a tiling model is saved as .exr only", param="output")
    note = ""
    if args.method == "auto" and out.suffix.lower() == ".texton":
        args.method, note = "texton", " (--method texton: a .texton file holds no tiling model)"
    kwargs = analysis_kwargs(args)  # options that do not apply are refused before the image is read
    u = read_example(args.input, args.iterations, args.crop, args.downscale, histogram=args.histogram,
                     method=args.method)
    t0 = time.perf_counter()
    texton = analyze(u, **kwargs, progress=show_progress(args))
    texton.metadata["source"] = Path(args.input).name
    texton.save(out)
    if args.quiet:
        return
    if isinstance(texton, TilingModel):
        h, w = texton.example.shape[:2]
        print(f"{out}: tiling model of a {w}x{h} example, triangle side {texton.side:g} ({seconds_since(t0)})")
    else:
        print(f"{out}: {texton.size[1]}x{texton.size[0]} texton, order {texton.order}, "
              f"model error {texton.metadata['model_error']:.3f} ({seconds_since(t0)}){note}")
    facts = summary(texton)
    if "structure" not in facts["metadata"] and scorable(u.shape):
        try:  # a hint only: skipped when it is over the budgets the texton was within
            facts["metadata"]["structure"] = structure_score(u, seed=args.seed)
            facts["suggested_method"] = suggest_method(facts["metadata"]["structure"])
        except OverBudget:
            pass
    for line in structure_lines(facts, args.method):
        print(line.strip())


ANALYZE = Command(
    "analyze", "compute the texton of an example image",
    "Compute the texton of an example image (EUSIPCO Alg. 2 / CGF Alg. 1) and save it as EXR or as a "
    "reference-viewer .texton file.",
    _analyze_arguments, _analyze, ANALYSIS_NAMES, input_file,
    epilog="""examples:
  warp-texton analyze wood.png -o wood.exr
  warp-texton analyze wood.png -o wood.texton --size 32 --order 1
  warp-texton analyze grass.png -o grass.exr --histogram preserve
""")


# ------------------------------------------------------------------ gaussian
def _gaussian_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", help="example image")
    p.add_argument("-o", "--output", required=True, help="output image: .png, .jpg or .exr")
    p.add_argument("--width", type=int, help="output width (default: the input's)")
    p.add_argument("--height", type=int, help="output height (default: the input's)")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("--no-periodic", dest="periodic", action="store_false",
                   help="model the image itself, not its periodic component")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary")


def _gaussian(args) -> None:
    from ..model.gaussian import gaussian_texture
    from ..files.images import check_image_path, read_image, write_image

    out = check_image_path(args.output)
    t0 = time.perf_counter()
    u = read_image(args.input)
    shape = (u.shape[0] if args.height is None else args.height, u.shape[1] if args.width is None else args.width)
    write_image(out, gaussian_texture(u, shape=shape, seed=args.seed, periodic=args.periodic))
    if not args.quiet:
        print(f"{out}: {shape[1]}x{shape[0]} Gaussian texture of a {u.shape[1]}x{u.shape[0]} example "
              f"({seconds_since(t0)})")


GAUSSIAN = Command(
    "gaussian", "sample the Gaussian model of an image (FFT)",
    "Sample the Gaussian texture model of an image by FFT (ADSN). At the input's own size the result tiles "
    "seamlessly.",
    _gaussian_arguments, _gaussian, {**SHAPE_NAMES, "seed": "--seed"}, input_file,
    epilog="""examples:
  warp-texton gaussian wood.png -o wood_gaussian.png
  warp-texton gaussian wood.png -o big.exr --width 1024 --height 768 --seed 3
""")


# ------------------------------------------------------------------ synthesize
def _synthesize_arguments(p: argparse.ArgumentParser) -> None:
    add_noise_image_options(p, "raster", zarr=True)
    add_placement_options(p)
    add_filter_options(p, default=None)
    add_run_options(p)
    add_format_options(p, zarr=True)
    add_analysis_options(p, seed=False)
    g = p.add_argument_group("relief")
    g.add_argument("--normal-map", metavar="FILE", help="also write the tangent-space normal map of the same raster "
                   "(PNG, 8-bit by default, or EXR), from the exact gradient of the luminance")
    g.add_argument("--normal-strength", type=float, default=1.0,
                   help="height of one standard deviation of the luminance, in pixels")
    g.add_argument("--normal-convention", choices=("opengl", "directx"), default="opengl",
                   help="opengl (glTF, Blender: green up the image) or directx (green down)")


def _synthesize(args) -> None:
    from ..core.progress import NamedSteps
    from ..core.runtime import progress_bar
    from ..files.images import check_dtype, check_image_path, write_image
    from ..model.texton import is_texton_path
    from ..noise.synthesis import synthesize

    out = Path(args.output)
    dtype = dtype_of(args)
    _default_filter(args)
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
    options = filter_options(args)
    normal_out = None if args.normal_map is None else check_image_path(Path(args.normal_map))
    if normal_out is not None:
        from ..core.checks import check_positive

        check_positive(args.normal_strength, "strength")
        if options.kind != "none":
            raise TextonError(f"--normal-map takes the unfiltered noise's gradient: give --filter none, not "
                              f"{options.kind}")
    noise = noise_options(args)
    t0 = time.perf_counter()
    # one bar over the command's steps (on a terminal, after 2 s), drawn while a step runs: the
    # write of a large PNG is one call that takes seconds and reports nothing
    show = show_progress(args)
    names = ([] if is_texton_path(args.input) else ["analysis"]) + ["noise", f"writing {out.name}"]
    if normal_out is not None:
        names.append(f"normal map {normal_out.name}")
    steps = NamedSteps(progress_bar(show, len(names), f"synthesize: {names[0]}", "step"), names, "synthesize",
                       tick=show)
    try:
        texton = texton_of(args)
        if names[0] == "analysis":
            steps.step()
        texton_only: dict = {}
        if getattr(texton, "kind", "texton") == "texton" or args.period is not None or options.kind != "none":
            texton_only = {"noise": noise, "filter": options}
        if not texton_only:
            texton_only = {"seed": args.seed}
        values = synthesize(texton, shape=(args.height, args.width), scale=args.scale,
                            rotation=args.rotation, offset=tuple(args.offset), device=args.device,
                            progress=show, **texton_only)
        steps.step()
        write_image(out, values, dtype=dtype, compression=args.compression)
        steps.step()
        if normal_out is not None:
            from ..noise.relief import normal_map

            normals = normal_map(texton, (args.height, args.width), strength=args.normal_strength,
                                 convention=args.normal_convention, scale=args.scale, rotation=args.rotation,
                                 offset=tuple(args.offset), device=args.device, **texton_only)
            write_image(normal_out, normals, compression=args.compression)
            steps.step()
    finally:
        steps.close()
    if not args.quiet:
        what = f"texton noise, MNI {args.mni:g}" if "noise" in texton_only or getattr(texton, "kind", "") != "tiling" \
            else "tiling and blending"
        print(f"{out}: {args.width}x{args.height} {what} ({seconds_since(t0)})")
        if normal_out is not None:
            print(f"{normal_out}: its normal map ({args.normal_convention}, strength {args.normal_strength:g})")


#: Below this --scale (pixels per texel) an unfiltered raster aliases visibly.
ALIAS_SCALE = 0.5


def _default_filter(args) -> None:
    """--filter of synthesize: none unless given (outputs as before), with a warning when
    --scale zooms out so far that the noise aliases."""
    if args.filter is not None:
        return
    args.filter = "none"
    if isinstance(args.scale, float) and 0 < args.scale < ALIAS_SCALE:
        warnings.warn(f"--scale {args.scale:g} puts {1 / args.scale:.3g} texels in a pixel and --filter is none: "
                      "the noise aliases (grain, moire); add --filter anisotropic (render-plane's default) or "
                      "--filter mip, or give --filter none to keep it", stacklevel=2)


def _zarr_chunk(args, h: int, w: int, default: int) -> tuple[int, int]:
    """The (rows, columns) of a chunk: --chunk, or ``default``, at most the raster's."""
    if args.chunk is None:
        return min(default, h), min(default, w)
    if args.chunk < 1:
        raise TextonError(f"--chunk must be a positive number of pixels, got {args.chunk}")
    if args.chunk > max(h, w):
        raise TextonError(f"--chunk {args.chunk} exceeds the {w}x{h} raster; use at most {max(h, w)}")
    return min(args.chunk, h), min(args.chunk, w)


def _synthesize_zarr(args, out: Path, dtype) -> None:
    if args.normal_map is not None:
        raise TextonError("--normal-map applies to image outputs (.png, .jpg, .exr, .tif), not .zarr")
    """synthesize -o NAME.zarr: the raster written chunk by chunk (warp_texton.noise.dask_arrays)."""
    try:
        from ..noise.dask_arrays import CHUNK, ZARR_DTYPE, ZARR_DTYPES, check_big_shape, check_scheduler, write_zarr
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
    chunk = _zarr_chunk(args, h, w, CHUNK)
    noise = noise_options(args)
    t0 = time.perf_counter()
    texton = texton_of(args)
    options = filter_options(args)
    texton_only: dict = {"noise": noise, "filter": options}
    tiling = getattr(texton, "kind", "texton") == "tiling"
    if tiling and args.period is None and options.kind == "none":
        texton_only = {"seed": args.seed}  # as synthesize to an image: the options a tiling model takes
    report = write_zarr(out, texton, (h, w), chunks=chunk, dtype=dtype or ZARR_DTYPE, scheduler=args.scheduler,
                        workers=args.workers, overwrite=args.overwrite, progress=show_progress(args),
                        scale=args.scale, rotation=args.rotation, offset=tuple(args.offset), device=args.device,
                        **texton_only)
    if not args.quiet:
        what = "tiling and blending" if tiling and "seed" in texton_only else f"texton noise, MNI {args.mni:g}"
        print(f"{out}: {w}x{h} {what}, {report['dtype']} Zarr in chunks of "
              f"{chunk[1]}x{chunk[0]} ({seconds_since(t0)})")


SYNTHESIZE = Command(
    "synthesize", "texton noise on a raster (Warp kernels)",
    "Evaluate texton noise on a raster with the Warp kernels. INPUT is a texton (.texton, or an EXR written by "
    "'analyze') or an example image, which is analysed first with the analysis options.",
    _synthesize_arguments, _synthesize,
    {**NOISE_IMAGE_NAMES, **FILTER_NAMES, **ANALYSIS_NAMES, "scale": "--scale", "rotation": "--rotation",
     "offset[0]": "--offset X", "offset[1]": "--offset Y", "offset": "--offset",
     "period[0]": "--period PX", "period[1]": "--period PY", "period": "--period", "chunks": "--chunk",
     "overwrite": "--overwrite", "strength": "--normal-strength", "convention": "--normal-convention"},
    input_file,
    epilog="""examples:
  warp-texton synthesize wood.exr -o noise.png --width 1920 --height 1080
  warp-texton synthesize wood.png -o tile.exr --width 512 --height 512 --period 512 512
  warp-texton synthesize wood.texton -o far.png --scale 0.25 --rotation 30 --mni 10
  warp-texton synthesize wood.texton -o far_aa.png --scale 0.1 --filter anisotropic
  warp-texton synthesize wood.texton -o wood16.png --dtype uint16
  warp-texton synthesize wood.texton -o wood.png --normal-map wood_normal.png --normal-strength 2
  warp-texton synthesize wood.texton -o big.zarr --width 65536 --height 65536 --chunk 4096 --dtype uint8
  warp-texton synthesize wood.texton -o big.zarr --width 65536 --height 65536 --scheduler tcp://10.0.0.5:8786
""")


# ------------------------------------------------------------------ render-plane
def _render_plane_arguments(p: argparse.ArgumentParser) -> None:
    add_noise_image_options(p, "image")
    p.add_argument("--camera-height", type=float, default=1.0, help="camera height above the plane, world units")
    p.add_argument("--tilt", type=float, default=70.0,
                   help="degrees between the view direction and straight down (0: straight down)")
    p.add_argument("--fov", type=float, default=40.0, help="vertical field of view, degrees")
    p.add_argument("--texel-size", type=float, default=0.002, help="world units per texel")
    add_filter_options(p, default="anisotropic")
    add_run_options(p)
    add_format_options(p)
    add_analysis_options(p, seed=False)


def _render_plane(args) -> None:
    from ..files.images import check_dtype, check_image_path, write_image
    from ..model.tiling import TilingModel
    from ..noise.ground_plane import render_plane

    out = check_image_path(args.output)
    dtype = check_dtype(out, dtype_of(args))
    options = filter_options(args)
    t0 = time.perf_counter()
    texton = texton_of(args)
    image = render_plane(texton, (args.height, args.width), height=args.camera_height, tilt=args.tilt,
                         fov=args.fov, texel_size=args.texel_size, mni=args.mni, seed=args.seed,
                         filter=options, device=args.device, progress=show_progress(args))
    write_image(out, image, dtype=dtype, compression=args.compression)
    if not args.quiet:
        noise = "tiling model" if isinstance(texton, TilingModel) else f"MNI {args.mni:g}"
        print(f"{out}: {args.width}x{args.height} plane, filter {args.filter}, {noise} ({seconds_since(t0)})")


RENDER_PLANE = Command(
    "render-plane", "an infinite textured ground plane in perspective",
    "Render an infinite ground plane covered with texton noise, seen in perspective (CGF Fig. 3), with the "
    "texton filtered for each pixel's footprint (CGF section 5). INPUT is a texton file or an example image.",
    _render_plane_arguments, _render_plane,
    {**NOISE_IMAGE_NAMES, **FILTER_NAMES, **ANALYSIS_NAMES,
     "height (the camera's height above the plane)": "--camera-height", "tilt": "--tilt", "fov": "--fov",
     "texel_size": "--texel-size"},
    input_file,
    epilog="""examples:
  warp-texton render-plane wood.exr -o plane.png --width 1024 --height 1024
  warp-texton render-plane wood.texton -o plane_mip.png --filter mip --tilt 80 --texel-size 0.002
  warp-texton render-plane wood.exr -o reference.exr --filter supersample --supersample 20
""")


# ------------------------------------------------------------------ mix
def _mix_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("a", metavar="A", help="first texture: image or texton")
    p.add_argument("b", metavar="B", help="second texture: image or texton")
    p.add_argument("-o", "--output", required=True, help="output image: .png, .jpg or .exr")
    p.add_argument("--steps", type=int, default=21, help="number of textons from A to B (>= 2)")
    p.add_argument("--map", help="grey image of rho in [0, 1] (black = A, white = B); default: strips")
    p.add_argument("--width", type=int, help="raster width (default: the map's, else 1024)")
    p.add_argument("--height", type=int, help="raster height (default: the map's, else 256)")
    p.add_argument("--mni", type=float, default=30.0, help="mean number of impacts per point")
    p.add_argument("--seed", type=int, default=0, help="random seed (analysis and noise)")
    add_run_options(p)
    add_analysis_options(p, seed=False)


def _load_texture(path):
    from ..files.images import read_image
    from ..model.texton import is_texton_path, load_texton

    return load_texton(path) if is_texton_path(path) else read_image(path)


def _mix_input(args, path):
    """A texture of ``mix``: an image, or with --histogram preserve its histogram-preserving texton."""
    import numpy as np

    x = _load_texture(path)
    if getattr(x, "kind", None) == "tiling":
        raise TextonError(f"{path}: a tiling model (method 'tiling') cannot be mixed: mix follows the path "
                          "between Gaussian texton models; give images or textons")
    if not isinstance(x, np.ndarray):
        return x
    if args.crop is not None or args.downscale != 1:
        from .options import read_example

        x = read_example(path, args.iterations, args.crop, args.downscale, histogram=args.histogram)
    if args.histogram == "gaussian":
        return x
    from ..model.analysis import analyze

    return analyze(x, options=analysis_options(args))  # with --histogram preserve


def _mix_weights(args):
    """(weights, shape): the --map's grey values and its shape, or strips."""
    from ..files.images import read_image

    if args.map is None:
        return "strips", (256 if args.height is None else args.height, 1024 if args.width is None else args.width)
    weights = read_image(args.map).mean(axis=2)
    shape = (weights.shape[0] if args.height is None else args.height,
             weights.shape[1] if args.width is None else args.width)
    if shape != weights.shape:
        raise TextonError(f"--map is {weights.shape[1]}x{weights.shape[0]}; --width/--height must match it "
                          f"(got {shape[1]}x{shape[0]})")
    return weights, shape


def _mix(args) -> None:
    import numpy as np

    from ..core.checks import check_int, check_mni, check_shape
    from ..files.images import check_image_path, write_image
    from ..core.limits import check_memory
    from ..noise.mixing import mix_bytes, mix_textons, synthesize_mixed
    from ..model.texton import MAX_TEXTON_SIDE

    # every argument before the first image is read or analysed
    out = check_image_path(args.output)
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise TextonError(f"{out}: the folder {out.parent} does not exist", param="output")
    if args.steps < 2:
        raise TextonError(f"--steps must be at least 2, got {args.steps}")
    size = check_int(args.size, "size", minimum=2, maximum=MAX_TEXTON_SIDE)
    for name, value in (("--width", args.width), ("--height", args.height)):
        if value is not None:
            check_int(value, name, minimum=1)
    check_shape((args.height or 1, args.width or 1))
    check_mni(args.mni)
    # the rhos (np.linspace) and the textons, before either is made
    check_memory(mix_bytes(args.steps, size), f"mixing {args.steps} textons of {size}x{size}",
                 "use fewer --steps or a smaller --size", param="steps", mentions=("size",))
    weights, shape = _mix_weights(args)
    t0 = time.perf_counter()
    textons = mix_textons(_mix_input(args, args.a), _mix_input(args, args.b), np.linspace(0.0, 1.0, args.steps),
                          options=analysis_options(args).replace(histogram="gaussian"), progress=show_progress(args))
    noise = synthesize_mixed(textons, weights, shape, mni=args.mni, seed=args.seed, device=args.device)
    write_image(out, noise)
    if not args.quiet:
        print(f"{out}: {shape[1]}x{shape[0]} mix of {args.steps} textons ({seconds_since(t0)})")


def _mix_files(args) -> dict[str, str]:
    return {"u, v": f"{args.a}, {args.b}", "u": args.a, "v": args.b}


MIX = Command(
    "mix", "progressive mix of two textures (texton noise)",
    "Mix two textures along the optimal-transport path between their Gaussian models (CGF §7): textons for "
    "--steps values of rho from A to B, then spatially varying texton noise, across the width in strips or "
    "driven by a grey map (black = A, white = B). A and B are images or textons.",
    _mix_arguments, _mix,
    {**NOISE_IMAGE_NAMES, **ANALYSIS_NAMES, "weights map": "--map", "weights": "--map", "rhos": "--steps"},
    _mix_files,
    epilog="""examples:
  warp-texton mix wood.png marble.png -o mix.png --steps 21 --width 2048 --height 256
  warp-texton mix wood.exr marble.texton -o mix.exr --map mask.png
""")


# ------------------------------------------------------------------ demo
def _demo_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--out-dir", default="demo_out", help="folder to write into")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def _demo(args) -> None:
    from ..demo import run_demo

    for path in run_demo(args.out_dir, seed=args.seed, progress=show_progress(args)):
        if not args.quiet:
            print(path)


DEMO = Command(
    "demo", "analyse the bundled texture and write pictures",
    "Analyse a small CC0 texture shipped with the package and write the input, its Gaussian version, the "
    "texton (and the noise) as PNG and EXR.",
    _demo_arguments, _demo, {"seed": "--seed"})
