"""``warp-texton surface``: surface noise on a batch of meshes.

The options are checked once, here, rather than failing every mesh; then the
jobs run on threads or a Dask cluster (:mod:`warp_texton.surface.jobs`), and one bad
mesh is reported while the others finish.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from .options import ANALYSIS_NAMES, Command, add_analysis_options, add_run_options, show_progress, texton_of
from ..core.errors import TextonError


def _arguments(p: argparse.ArgumentParser) -> None:
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
    p.add_argument("--charts", choices=("normals", "xatlas"), default="normals",
                   help="with --bake, for a new atlas: charts of clustered normals packed by xatlas (seconds), or "
                        "xatlas's own charts (fewer seams, minutes for 100k faces)")
    p.add_argument("--texture", choices=("png", "png16", "exr"),
                   help="with --bake: also write the texture alone as NAME_texture.png (8-bit sRGB) or .exr; "
                        "png16: every PNG texture in 16 bits (the GLB's, the OBJ's and NAME_texture.png)")
    p.add_argument("--exr-linear", action="store_true",
                   help="an EXR texture holds linear values (the sRGB decoding) instead of the noise's own values")
    p.add_argument("--supersample", type=int, metavar="N",
                   help="with --bake: N x N samples per texel (default: by each texel's footprint)")
    p.add_argument("--max-edge", type=float, help="subdivide until no edge is longer than this many texels")
    p.add_argument("--normals", choices=("angle", "smooth", "flat", "mesh"), default="angle",
                   help="normals of the noise, renders and outputs: split at edges sharper than --crease-angle "
                        "(angle: Blender's auto smooth; flat faces stay flat, curved ones smooth), never (smooth), "
                        "always (flat), or the vertex normals the file holds (mesh)")
    p.add_argument("--crease-angle", type=float, metavar="DEG",
                   help="with --normals angle: edges sharper than this split the normals (default 30)")
    p.add_argument("--render", metavar="WxH", help="also write a PNG render of this size, e.g. 512x512")
    p.add_argument("--up", choices=("auto", "x", "y", "z"), default="auto",
                   help="the meshes' up axis: auto is the format's convention "
                        "(y for .glb/.gltf/.obj, z for .ply/.stl and others)")
    p.add_argument("--orbit", metavar="AZ,EL",
                   help="render camera azimuth and elevation in degrees (default -55,25: front left, above; "
                        "a negative azimuth as --orbit=-30,20)")
    p.add_argument("--fov", type=float, help="render vertical field of view, degrees (default 35)")
    p.add_argument("--format", choices=("ply", "obj", "glb"),
                   help="mesh output format (default: glb with --bake, else ply)")
    p.add_argument("--overwrite", action="store_true", help="redo meshes whose outputs exist")
    p.add_argument("--jobs", type=int, default=1, help="meshes processed at once")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the batch on this dask.distributed scheduler (paths must be visible to its workers)")
    add_run_options(p, quiet="no progress bar")
    add_analysis_options(p, seed=False)


# ------------------------------------------------------------------ options
def _render_size(text):
    """--render WxH -> (H, W), or None."""
    if text is None:
        return None
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise TextonError(f"--render must be WIDTHxHEIGHT, e.g. 512x512, got {text!r}") from None
    return h, w


def _check_bake_options(args) -> None:
    """--bake and the options that apply to baked textures only."""
    from ..core.checks import check_int
    from ..surface.bake import MAX_RESOLUTION

    if args.bake is None:
        for name, value in (("--texture", args.texture), ("--supersample", args.supersample),
                            ("--exr-linear", args.exr_linear or None), ("--uv", None if args.uv == "auto" else 1),
                            ("--charts", None if args.charts == "normals" else 1)):
            if value is not None:
                raise TextonError(f"{name} applies to baked textures: add --bake RES")
        return
    check_int(args.bake, "--bake", minimum=1)
    if args.bake > MAX_RESOLUTION:
        raise TextonError(f"--bake must be at most {MAX_RESOLUTION} texels per side, got {args.bake}")
    if args.format == "ply":
        raise TextonError("--bake writes --format glb or obj (a PLY file cannot carry a texture)")
    if args.max_edge is not None:
        raise TextonError("--max-edge subdivides for vertex colours; a --bake texture does not need it")


def _orbit_angles(text):
    """--orbit AZ,EL -> (azimuth, elevation), or None."""
    from ..surface.render import orbit_direction

    if text is None:
        return None
    try:
        orbit = tuple(float(v) for v in text.split(","))
        if len(orbit) != 2:
            raise ValueError
    except ValueError:
        raise TextonError(f"--orbit must be AZIMUTH,ELEVATION in degrees, e.g. 30,20, got {text!r}") from None
    try:
        orbit_direction(orbit)
    except TextonError as exc:
        raise TextonError(f"--orbit: {exc}") from None
    return orbit


def _check_options(args):
    """(render shape, orbit angles), every option checked once for the whole batch."""
    from ..core.checks import check_int, check_positive, check_seed, check_shape

    render = _render_size(args.render)
    if args.jobs < 1:
        raise TextonError(f"--jobs must be at least 1, got {args.jobs}")
    if render is not None:
        check_shape(render, "--render")
    check_positive(args.mni, "--mni")
    check_seed(args.seed)
    for value, option in ((args.texel_size, "--texel-size"), (args.max_edge, "--max-edge")):
        if value is not None:
            check_positive(value, option)
    _check_bake_options(args)
    if args.supersample is not None:
        check_int(args.supersample, "--supersample", minimum=1)
    if args.exr_linear and args.texture != "exr":
        raise TextonError("--exr-linear applies to --texture exr")
    if args.crease_angle is not None and args.normals != "angle":
        raise TextonError(f"--crease-angle applies to --normals angle, not {args.normals}")
    from ..surface.mesh import CREASE_ANGLE, check_normals

    check_normals(args.normals, CREASE_ANGLE if args.crease_angle is None else args.crease_angle)
    orbit = _orbit_angles(args.orbit)
    if args.fov is not None:
        check_positive(args.fov, "--fov")
        if args.fov >= 180:
            raise TextonError(f"--fov must be below 180 degrees, got {args.fov}")
    return render, orbit


# ------------------------------------------------------------------ the batch
@contextlib.contextmanager
def _executor(scheduler):
    """The executor of a dask.distributed scheduler (closed on the way out), or None: local threads."""
    if scheduler is None:
        yield None
        return
    try:
        from dask.distributed import Client
    except ImportError:
        raise TextonError("--scheduler needs dask.distributed: pip install 'warp-texton[dask]'") from None
    try:
        client = Client(scheduler, timeout=10)
    except Exception as exc:
        raise TextonError(f"--scheduler {scheduler}: cannot connect ({type(exc).__name__}: {exc})") from None
    try:
        yield client.get_executor()
    finally:
        client.close()


def _surface_texton(args):
    """The batch's texton: a texton file, or an example image analysed once (a bad one fails the batch)."""
    from ..model.texton import is_texton_path, load_texton
    from ..surface.tiling import SURFACE_MNI, check_surface_model

    if is_texton_path(args.texton):
        # checked once here (a tiling model's options too); the jobs read it themselves
        check_surface_model(load_texton(args.texton), mni=(args.mni, SURFACE_MNI))
        return args.texton
    try:
        texton = texton_of(args, args.texton)
        check_surface_model(texton, mni=(args.mni, SURFACE_MNI))
        return texton
    except TextonError as exc:
        if exc.param == "u" or "u" in exc.mentions or args.texton in str(exc):
            raise  # it names the image (as the file, in the command line's words)
        raise TextonError(f"--texton {args.texton}: {exc}", exc.param, mentions=exc.mentions) from None


def _price_bake(args, texton) -> None:
    """A --bake priced from the options alone, before any mesh is read or any job starts:
    one line and exit 2 for a bake no mesh could make within the budgets."""
    from ..surface.bake import check_bake_arguments
    from ..model.texton import Texton, load_texton
    from ..model.tiling import TilingModel

    if args.bake is None:
        return
    t = texton if isinstance(texton, (Texton, TilingModel)) else load_texton(texton)
    check_bake_arguments(t, args.bake, mni=args.mni, supersample=args.supersample, uv=args.uv)


def _run_jobs(args, executor, device, render, orbit):
    """(results, interrupted) of the batch's jobs."""
    from ..surface.jobs import JobsInterrupted, SurfaceJob, check_unique_outputs, expand_meshes, run_jobs
    from ..surface.mesh import CREASE_ANGLE

    texton = _surface_texton(args)
    _price_bake(args, texton)
    meshes = expand_meshes(args.meshes)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [SurfaceJob(m, texton, str(out), args.texel_size, args.mni, args.seed, args.max_edge, render,
                       args.format, args.overwrite, device, bake=args.bake, uv=args.uv,
                       texture="png" if args.texture == "png16" else args.texture,
                       dtype="uint16" if args.texture == "png16" else "uint8",
                       exr_linear=args.exr_linear, supersample=args.supersample, up=args.up, orbit=orbit,
                       fov=args.fov, words=tuple(SURFACE.names.items()), charts=args.charts, normals=args.normals,
                       crease_angle=CREASE_ANGLE if args.crease_angle is None else args.crease_angle,
                       progress=show_progress(args) and args.jobs == 1 and args.scheduler is None) for m in meshes]
    check_unique_outputs(jobs)
    try:
        return run_jobs(jobs, executor=executor, jobs_in_parallel=args.jobs, progress=show_progress(args)), False
    except JobsInterrupted as exc:
        return exc.results, True


def _report(results, interrupted: bool, quiet: bool) -> int:
    """Print what the batch did (errors, warnings, counts) and return the exit status."""
    for r in results:
        if r.status == "failed" and (quiet or interrupted):
            print(f"warp-texton: error: {r.message}", file=sys.stderr)
        if r.status == "done" and r.up and not quiet:  # the axis used, so a sideways render says what to change
            print(f"warp-texton: note: done {r.mesh} (up {r.up})", file=sys.stderr)
        for note in r.warnings:
            warning = "texels apart" in note
            if warning or not quiet:
                print(f"warp-texton: {'warning' if warning else 'note'}: {note}", file=sys.stderr)
    counts = {s: sum(r.status == s for r in results) for s in ("done", "skipped", "failed", "cancelled")}
    line = f"{counts['done']} done, {counts['skipped']} skipped, {counts['failed']} failed"
    if interrupted:
        print(f"warp-texton: interrupted: {line}, {counts['cancelled']} cancelled", file=sys.stderr)
        return 130
    print(line, file=sys.stderr)
    return 1 if counts["failed"] else 0


def _surface(args) -> int:
    from ..core.runtime import resolve_device

    try:
        render, orbit = _check_options(args)
        device = resolve_device(args.device)
        with _executor(args.scheduler) as executor:
            results, interrupted = _run_jobs(args, executor, device, render, orbit)
    except KeyboardInterrupt:  # before or after the batch itself (which reports its own)
        print("warp-texton: interrupted", file=sys.stderr)
        return 130
    return _report(results, interrupted, args.quiet)


SURFACE = Command(
    "surface", "texture meshes with surface noise (batch)",
    "Put surface texton noise (CGF §6) on meshes: baked into a texture on UVs (--bake RES: the mesh's own UVs, "
    "or an atlas made by xatlas) or as vertex colours, and optionally render each one. Outputs are named after "
    "each input's stem; finished outputs are skipped unless --overwrite. One bad mesh is reported and the "
    "others still finish; the exit status is 1 if any failed, 130 if interrupted.",
    _arguments, _surface,
    {**ANALYSIS_NAMES, "mni": "--mni", "texel_size": "--texel-size", "max_edge": "--max-edge", "fov": "--fov",
     "device": "--device", "supersample": "--supersample", "resolution": "--bake", "shape": "--render",
     "normals": "--normals", "crease_angle": "--crease-angle"},
    lambda args: {"u": args.texton},
    epilog="""examples:
  warp-texton surface scans/*.ply --texton wood.exr --out-dir textured --render 512x512
  warp-texton surface scans/*.ply --texton wood.png --out-dir baked --bake 2048 --texture png
  warp-texton surface model.glb --texton wood.exr --out-dir out --bake 1024 --format obj --render 800x600 --orbit 30,20
  warp-texton surface @meshes.txt --texton wood.texton --out-dir out --texel-size 0.002 --format glb --jobs 2
  warp-texton surface part.stl --texton wood.exr --out-dir out --render 800x600 --crease-angle 45
  warp-texton surface 'scans/*.ply' --texton wood.exr --out-dir out --bake 2048 --scheduler tcp://head:8786
""")
