"""Batch surface texturing: many meshes, one texton, any executor.

Each mesh is one :class:`SurfaceJob`, a small picklable record run by
:func:`run_surface_job` (a top-level function), so the same batch runs on a
thread pool, a process pool, or a Dask cluster (``Client.get_executor()``
returns a ``concurrent.futures``-style executor). A job never raises: it
returns a :class:`JobResult` saying done, skipped or failed, so one bad mesh
does not stop the others.
"""

from __future__ import annotations

import glob
import os
import sys
import uuid
from typing import cast
from concurrent.futures import Executor, ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

from .mesh_files import bake_outputs
from ..core.errors import TextonError
from ..model.texton import Texton
from ..model.tiling import TilingModel

FORMATS = ("ply", "obj", "glb")
#: ``up`` of a job: "auto" takes the convention of the file's format (AUTO_UP), or a world axis.
UP_CHOICES = ("auto", "x", "y", "z")
#: ``up="auto"`` by extension, from the conventions of the tools that write each format
#: (docs/cli.md, "Up axis and camera"): glTF is Y-up by definition; OBJ exporters
#: (Blender, Maya, 3ds Max, ZBrush) write Y up; PLY (range scanners, the Stanford
#: models as trimesh and pymeshfix ship them) and STL (CAD, 3-D printing) Z up.
AUTO_UP = {".glb": "y", ".gltf": "y", ".obj": "y", ".ply": "z", ".stl": "z"}
#: ``up="auto"`` for the other extensions (OFF, ...), which have no convention.
DEFAULT_UP = "z"


def resolve_up(up: str, mesh_path: str) -> str:
    """The up axis of a job: "auto" → the format's convention (``AUTO_UP``: Y for
    .glb, .gltf and .obj, Z for .ply, .stl and the others); "x", "y", "z" as given."""
    if up not in UP_CHOICES:
        raise TextonError(f"up must be one of {', '.join(UP_CHOICES)}, got {up!r}")
    if up == "auto":
        return AUTO_UP.get(Path(mesh_path).suffix.lower(), DEFAULT_UP)
    return up


def describe_up(up: str, mesh_path: str) -> str:
    """The axis a job uses and why, for its report: "y, auto for .obj" or "x, given"."""
    axis = resolve_up(up, mesh_path)
    return f"{axis}, auto for {Path(mesh_path).suffix.lower() or 'a file without extension'}" if up == "auto" \
        else f"{axis}, given"


#: The formats of a job's vertex-coloured mesh (``fmt`` without ``bake``).
VERTEX_COLOUR_FORMATS = ("ply", "obj", "glb")


@dataclass(frozen=True)
class SurfaceJob:
    """Texture one mesh file; outputs go to ``out_dir`` named after its stem.

    A frozen dataclass; every field is a plain value (or a :class:`Texton`),
    so a job pickles to any worker. ``texton`` is a texton file or a
    :class:`Texton` (a batch analyses an example image once and hands the
    texton to every job). With ``bake`` (a texture side), the noise goes into
    a texture on UVs (see :func:`warp_texton.bake_mesh`) and ``fmt`` is "glb"
    (default) or "obj"; without it, into vertex colours, ``fmt`` "ply"
    (default), "obj" or "glb".

    Parameters
    ----------
    mesh : str
        Path of a mesh file trimesh reads (PLY, OBJ, STL, GLB, OFF...).
    texton : str or Texton
        Path of a texton file (``.exr`` from :func:`analyze`, or ``.texton``),
        or a :class:`Texton`.
    out_dir : str
        Folder for the outputs, created when missing (on the worker).
    texel_size : float, optional
        World units per texel; ``None``: the mesh's bounding-box diagonal / 256.
    mni : float
        As in :func:`warp_texton.texture_mesh`.
    seed : int
        As in :func:`warp_texton.texture_mesh`.
    max_edge : float, optional
        As in :func:`warp_texton.texture_mesh`.
    render : (height, width), optional
        Size of a PNG render by :func:`warp_texton.render_mesh` (default
        camera), or ``None``.
    fmt : {"ply", "obj", "glb"}, optional
        The format of the textured mesh: "ply" (default), "obj" or "glb" for
        vertex colours (glTF's ``COLOR_0`` is written linear); "glb"
        (default) or "obj" with ``bake``.
    overwrite : bool
        Redo the job even when its outputs exist.
    device : str, optional
        As in :func:`warp_texton.synthesize`; ``None``: CUDA when available,
        else the CPU, on the machine that runs the job.
    bake : int, optional
        A texture side: bake the noise into a texture on UVs
        (:func:`warp_texton.bake_mesh`, :func:`warp_texton.write_baked`)
        instead of vertex colours.
    uv : {"auto", "mesh", "atlas"}
        As in :func:`warp_texton.bake_mesh`.
    charts : {"normals", "xatlas"}
        As in :func:`warp_texton.bake_mesh`.
    dtype : {"uint8", "uint16"}
        With ``bake``: the sample type of the PNG textures written, as in
        :func:`warp_texton.bake_mesh`.
    progress : bool
        A progress bar over a bake's atlas and rounds, as in
        :func:`warp_texton.bake_mesh` (for one job at a time: bars of jobs
        side by side would mix).
    supersample : int, optional
        As in :func:`warp_texton.bake_mesh`.
    texture : {"png", "exr"}, optional
        With ``bake``: also write the texture alone.
    exr_linear : bool
        An EXR texture holds the sRGB-decoded (linear) values instead of the
        values themselves.
    up : {"auto", "x", "y", "z"}
        The mesh's up axis ("auto": its format's convention, ``AUTO_UP``: Y
        for ``.glb``/``.gltf`` and ``.obj``, Z for ``.ply``, ``.stl`` and the
        others): the frame rule, the render's camera and light, and the axis a
        GLB output turns to glTF's +Y (OBJ and PLY outputs keep the input's
        coordinates).
    orbit : (azimuth, elevation), optional
        The render's camera angles, as in :func:`warp_texton.render_mesh`.
    fov : float, optional
        The render's field of view, as in :func:`warp_texton.render_mesh`.
    normals : {"angle", "smooth", "flat", "mesh"}
        The normals of the noise, the render and the outputs, as in
        :func:`warp_texton.render_mesh` (default "angle").
    crease_angle : float
        Degrees, with ``normals="angle"``, as in :func:`warp_texton.render_mesh`.

    Notes
    -----
    ``job.outputs()`` lists the output paths: ``out_dir/<stem>.<fmt>`` (with
    ``bake`` and ``fmt="obj"``: ``.obj``, ``.mtl``, ``.png``; with
    ``texture``: ``<stem>_texture.png`` or ``.exr``) and, with ``render``,
    ``out_dir/<stem>.png`` (``<stem>_render.png`` when the OBJ's texture
    already takes ``<stem>.png``), where ``<stem>`` is the mesh file's name
    without its extension. Two meshes with the same stem write to the same
    outputs: give them different output folders.
    """

    mesh: str
    texton: str | Texton | TilingModel
    out_dir: str
    texel_size: float | None = None  # world units per texel; None: mesh.default_texel_size
    mni: float = 60.0
    seed: int = 0
    max_edge: float | None = None
    render: tuple[int, int] | None = None  # (height, width) of a PNG render, or None
    fmt: str | None = None  # None: "glb" with bake, else "ply"
    overwrite: bool = False
    device: str | None = None
    bake: int | None = None  # texture side, or None for vertex colours
    uv: str = "auto"  # "auto", "mesh" or "atlas" (see bake_mesh)
    texture: str | None = None  # also write the texture alone: "png" or "exr"
    exr_linear: bool = False  # an EXR texture holds the sRGB-decoded (linear) values
    supersample: int | None = None  # samples per texel side of a bake; None: by the footprint
    up: str = "auto"  # the mesh's up axis: "auto", "x", "y" or "z"
    orbit: tuple[float, float] | None = None  # (azimuth, elevation) of the render, degrees
    fov: float | None = None  # vertical field of view of the render, degrees
    #: (library name, command-line name) pairs: the words a failure's message uses for the
    #: arguments it names (the surface command's options: "supersample" -> "--supersample")
    words: tuple[tuple[str, str], ...] = ()
    charts: str = "normals"  # how a bake's new atlas is charted (see bake_mesh)
    progress: bool = False  # a progress bar over a bake's steps (one job at a time)
    dtype: str = "uint8"  # PNG sample type of a bake's textures: "uint8" or "uint16"
    normals: str = "angle"  # how corner normals are made (see mesh.corner_normals)
    crease_angle: float = 30.0  # degrees, with normals="angle" (mesh.CREASE_ANGLE)

    def __post_init__(self):
        # the formats documented above, refused when the job is made rather than written in another
        formats = ("glb", "obj") if self.bake is not None else VERTEX_COLOUR_FORMATS
        if self.fmt is not None and (not isinstance(self.fmt, str) or self.fmt not in formats):
            raise TextonError(f"fmt must be one of {', '.join(formats)}"
                              f"{' with bake' if self.bake is not None else ''}, got {self.fmt!r:.40}", param="fmt")

    @property
    def format(self) -> str:
        """The format written: ``fmt``, or its default ("glb" with ``bake``, else "ply")."""
        return self.fmt or ("glb" if self.bake is not None else "ply")

    def outputs(self) -> list[Path]:
        """The paths the job writes (see the Notes above), textured mesh first."""
        stem = Path(self.out_dir) / Path(self.mesh).stem
        if self.bake is not None:
            out = bake_outputs(stem, self.format, self.texture)
        else:
            out = [stem.with_name(f"{stem.name}.{self.format}")]
        if self.render is not None:
            out.append(stem.with_name(f"{stem.name}_render.png" if self.bake is not None and self.format == "obj"
                                      else f"{stem.name}.png"))
        return out


@dataclass(frozen=True)
class JobResult:
    """What a job did (a frozen dataclass).

    Attributes
    ----------
    mesh : str
        The job's mesh path.
    status : {"done", "skipped", "failed", "cancelled"}
    message : str
        Why a job failed or was skipped: the one-line :class:`TextonError`
        message for user errors, starting with the mesh's path.
    outputs : list of str
        The output paths of a done or skipped job.
    warnings : list of str
        Notes of a done job: vertices further apart than a texel, or the
        bake's texels per texton texel.
    up : str
        The up axis a done job used and why: "y, auto for .obj" or "x, given".
    """

    mesh: str
    status: str  # "done", "skipped", "failed" or "cancelled"
    message: str = ""
    outputs: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    up: str = ""


class JobsInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`run_jobs`: queued jobs were cancelled, running ones
    finished; ``results`` says what each job did ("cancelled" for the queued)."""

    def __init__(self, results):
        super().__init__("interrupted")
        self.results = results


def expand_meshes(args) -> list[str]:
    """Mesh arguments to paths: plain paths, glob patterns, and ``@list.txt`` files.

    A plain path is kept; a glob pattern (``*``, ``?``, ``[...]``, ``**``
    recursive) is replaced by its sorted matches; ``@list.txt`` by the paths
    and patterns listed in that file, one per line (blank lines and lines
    starting with ``#`` skipped). Order is kept and duplicates dropped; a
    pattern that matches nothing stays as is, so that its job fails with "no
    such file" instead of vanishing.

    Parameters
    ----------
    args : sequence of str or PathLike
        One path alone is taken as a list of one.

    Returns
    -------
    list of str

    Raises
    ------
    TextonError
        When a list file cannot be read, is not UTF-8 text or includes
        itself, and for arguments that are not paths.

    Examples
    --------
    See :func:`run_jobs`.
    """
    return _expand(args, ())


def _expand(args, lists: tuple) -> list[str]:
    """``expand_meshes`` inside the ``@lists`` being read (their resolved paths)."""
    if isinstance(args, (str, os.PathLike)):
        args = [args]
    try:
        args = list(args)
    except TypeError:
        raise TextonError(f"args must be a list of mesh paths, got {args!r:.60}") from None
    out: list[str] = []
    for arg in args:
        if isinstance(arg, os.PathLike):
            arg = os.fspath(arg)
        if not isinstance(arg, str):
            raise TextonError(f"args: {arg!r:.60} is not a path; give file names, glob patterns or @list.txt")
        if arg.startswith("@"):
            listing = Path(arg[1:])
            key = listing.resolve()
            if key in lists:
                raise TextonError(f"{listing}: the mesh list includes itself (through @{listing})")
            try:
                lines = listing.read_bytes().decode("utf-8").splitlines()
            except OSError as exc:
                raise TextonError(f"{listing}: cannot read the mesh list ({exc.strerror})") from None
            except UnicodeDecodeError:
                raise TextonError(f"{listing}: not a text list of mesh paths (one path or pattern per line, "
                                  "UTF-8)") from None
            entries = [ln.strip() for ln in lines if ln.strip() and not ln.strip().startswith("#")]
            out.extend(_expand(entries, (*lists, key)))
        elif glob.has_magic(arg):
            out.extend(sorted(glob.glob(arg, recursive=True)) or [arg])
        else:
            out.append(arg)
    return list(dict.fromkeys(out))  # first occurrences, in order


def _load_mesh(path: str):
    import numpy as np
    import trimesh

    p = Path(path)
    if not p.is_file():
        raise TextonError(f"{path}: no such file")
    from .mesh_files import scene_mesh

    try:
        # a glTF scene's nodes joined by hand: trimesh's force="mesh" drops the file's normals
        mesh = scene_mesh(trimesh.load(str(p), process=False))
    except Exception as exc:
        raise TextonError(f"{path}: not a mesh that trimesh can read ({exc})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise TextonError(f"{path}: the file holds no triangles")
    faces = np.asarray(mesh.faces)
    if faces.min() < 0 or faces.max() >= len(mesh.vertices):
        raise TextonError(f"{path}: faces index vertices that do not exist (indices up to {int(faces.max())}, "
                          f"{len(mesh.vertices)} vertices)")
    bad = ~np.isfinite(np.asarray(mesh.vertices, dtype=np.float64)).all(axis=1)
    if bad.any():
        raise TextonError(f"{path}: {int(bad.sum())} vertices have NaN or infinite coordinates")
    return mesh


def run_surface_job(job: SurfaceJob, token: str | None = None) -> JobResult:
    """Run one job; never raises for a bad mesh (the result says why).

    Loads the texton and the mesh, textures it (:func:`warp_texton.texture_mesh`,
    or :func:`warp_texton.bake_mesh` with ``bake``), then (with ``render``)
    renders the original mesh (:func:`warp_texton.render_mesh`); the render
    is computed before any file is written, and each file is written
    atomically, so a failed or interrupted job leaves no partial file. If
    every output exists and ``overwrite`` is false the job is "skipped"
    without loading anything.

    Parameters
    ----------
    job : SurfaceJob
    token : str, optional
        Ignored: :func:`run_jobs` passes a fresh one with every submission
        so that executors that cache results of equal calls (Dask's pure
        tasks) always run the job, whose inputs may have changed on disk.

    Returns
    -------
    JobResult
        "done", "skipped", or "failed" with a message naming the mesh and the
        problem: a missing or unreadable mesh or texton, a file without
        triangles, vertices with NaN coordinates, faces that index missing
        vertices, a mesh too far from the origin for its texel size, a mesh
        without area (degenerate), unusable UVs, a missing xatlas, a bad option (``mni`` ≤ 0, a subdivision over
        the face limit...) and any other error, including file-system errors.

    Examples
    --------
    See :func:`run_jobs`.
    """
    outputs = job.outputs()
    if not job.overwrite and all(p.exists() for p in outputs):
        return JobResult(job.mesh, "skipped", "outputs exist (use --overwrite)", [str(p) for p in outputs])
    notes: list[str] = []
    try:
        _run(job, outputs, notes)
    except TextonError as exc:
        message = exc.in_words(dict(job.words))
        return JobResult(job.mesh, "failed", message if message.startswith(job.mesh) else f"{job.mesh}: {message}")
    except OSError as exc:
        return JobResult(job.mesh, "failed", f"{exc.filename or job.mesh}: {exc.strerror or exc}")
    except Exception as exc:  # a broken file must not stop the batch
        return JobResult(job.mesh, "failed", f"{job.mesh}: {type(exc).__name__}: {exc}")
    return JobResult(job.mesh, "done", "", [str(p) for p in outputs], notes, describe_up(job.up, job.mesh))


def _run(job: SurfaceJob, outputs: list[Path], notes: list[str]) -> None:
    from .bake import bake_mesh
    from ..files.images import write_image
    from .mesh import default_texel_size, texture_mesh, vertex_spacing
    from ..files.images import check_output_name
    from .mesh_files import check_surface, export_mesh, write_baked, write_set
    from .render import render_mesh
    from ..model.texton import load_texton

    Path(job.out_dir).mkdir(parents=True, exist_ok=True)  # on a cluster worker too
    for path in outputs:  # names that cannot be written are refused before any work
        check_output_name(path)
    texton = job.texton if isinstance(job.texton, (Texton, TilingModel)) else load_texton(job.texton)
    up = resolve_up(job.up, job.mesh)
    mesh = _load_mesh(job.mesh)
    check_surface(mesh, job.mesh)
    texel = default_texel_size(mesh) if job.texel_size is None else job.texel_size
    stem = Path(job.out_dir) / Path(job.mesh).stem
    img = None
    if job.render is not None:  # computed before anything is written: all outputs or none
        img = render_mesh(mesh, texton, job.render, texel_size=texel, mni=job.mni, seed=job.seed,
                          device=job.device, up=up, orbit=job.orbit, fov=job.fov, normals=job.normals,
                          crease_angle=job.crease_angle)
    # the render is written with the mesh's files, all renamed at the end: all files or none
    render = {} if img is None else {outputs[-1]: lambda tmp: write_image(tmp, img)}
    if job.bake is not None:
        baked = bake_mesh(mesh, texton, texel, resolution=job.bake, mni=job.mni, seed=job.seed, uv=job.uv,
                          supersample=job.supersample, device=job.device, up=up, name=job.mesh, charts=job.charts,
                          progress=job.progress, dtype=job.dtype, normals=job.normals,
                          crease_angle=job.crease_angle)
        write_baked(baked, stem, fmt=job.format, texture=job.texture, linear=job.exr_linear, also=render)
        notes.append(f"{job.mesh}: {job.bake}x{job.bake} texture, {baked.texels_per_texton_texel:.3g} texels per "
                     f"texton texel (median), noise samples per texel: {baked.samples:.3g} (mean), UVs from the "
                     f"{baked.uv_source}, covering {100 * baked.covered:.0f} % of the texture")
    else:
        # glTF's COLOR_0 is linear by definition; PLY and OBJ keep the noise's sRGB-coded values
        textured = texture_mesh(mesh, texton, texel, mni=job.mni, seed=job.seed, max_edge=job.max_edge,
                                device=job.device, up=up, linear=job.format == "glb", warn=False,
                                normals=job.normals, crease_angle=job.crease_angle)
        spacing = vertex_spacing(textured, texel)
        if spacing > 1.0:
            notes.append(f"{job.mesh}: vertices are {spacing:.3g} texels apart (median edge), so vertex colours "
                         "blur the texture; bake a texture (--bake RES) or subdivide (--max-edge 1)")
        data = export_mesh(textured, job.format, up)  # a GLB turned to +Y from the mesh's up
        write_set({outputs[0]: data, **render})


def check_unique_outputs(jobs) -> None:
    """Refuse batches where two meshes would write the same output file
    (same file name in different folders)."""
    seen: dict[Path, str] = {}
    for job in jobs:
        for out in job.outputs():
            if out in seen and seen[out] != job.mesh:
                raise TextonError(
                    f"{seen[out]} and {job.mesh} would both write {out}; rename one or use separate --out-dir runs"
                )
            seen[out] = job.mesh


def run_jobs(jobs, *, executor: Executor | None = None, jobs_in_parallel: int = 1,
             progress: bool = False) -> list[JobResult]:
    """Run jobs on ``executor`` (default: a pool of ``jobs_in_parallel`` threads).

    Submits :func:`run_surface_job` for every job. Any ``concurrent.futures``
    executor works, e.g. ``dask.distributed.Client(...).get_executor()``.
    Without an executor, a pool of ``jobs_in_parallel`` threads runs the jobs
    (Warp releases the GIL during its launches) and is shut down afterwards;
    a given executor is left running.

    Parameters
    ----------
    jobs : iterable of SurfaceJob
    executor : concurrent.futures.Executor, optional
    jobs_in_parallel : int
        Threads of the default pool.
    progress : bool
        A progress bar, with a line for each failure.

    Returns
    -------
    list of JobResult
        In the order of ``jobs``. If the executor itself fails a job (a lost
        worker...), that job's result is "failed" with the exception as
        message.

    Raises
    ------
    JobsInterrupted
        On Ctrl-C: the jobs still queued are cancelled, the running ones
        finish (their files are written whole, or not at all), and the
        exception's ``results`` hold every job's result ("cancelled" for
        those that did not run).

    Notes
    -----
    With Dask (``pip install "warp-texton[dask]"``) the same jobs run on a
    cluster: ``Client.get_executor()`` is a ``concurrent.futures`` executor.
    The paths must be readable and writable by the workers (a shared file
    system on a real cluster), and each worker process initialises Warp and
    loads the kernels on its first job. A script that starts a
    ``LocalCluster`` needs the ``if __name__ == "__main__":`` guard, since
    the workers are new processes (docs/api.md, "batch surface texturing",
    runs such a script).

    Examples
    --------
    >>> from pathlib import Path
    >>> import trimesh
    >>> from warp_texton import read_image, analyze
    >>> from warp_texton.surface.jobs import SurfaceJob, expand_meshes, run_jobs, run_surface_job
    >>> from warp_texton.demo import demo_texture_path
    >>> analyze(read_image(demo_texture_path()), size=32, iterations=30).save("grass32.exr")
    >>> Path("meshes").mkdir()
    >>> _ = trimesh.creation.icosphere(subdivisions=2).export("meshes/sphere.ply")
    >>> _ = trimesh.creation.box(extents=(2, 1, 1)).export("meshes/box.obj")
    >>> _ = Path("meshes/broken.ply").write_text("not a mesh\\n")
    >>> _ = Path("meshes.txt").write_text("# one path or pattern per line\\nmeshes/box.obj\\nmeshes/missing.ply\\n")
    >>> paths = expand_meshes(["meshes/*.ply", "@meshes.txt"])
    >>> paths
    ['meshes/broken.ply', 'meshes/sphere.ply', 'meshes/box.obj', 'meshes/missing.ply']
    >>> jobs = [SurfaceJob(p, "grass32.exr", "textured", render=(48, 64), overwrite=True, device="cpu")
    ...         for p in paths]
    >>> for r in run_jobs(jobs, jobs_in_parallel=2):
    ...     print(r.status, r.message or r.mesh)
    failed meshes/broken.ply: not a mesh that trimesh can read (Not a ply file!)
    done meshes/sphere.ply
    done meshes/box.obj
    failed meshes/missing.ply: no such file
    >>> jobs[1].outputs()
    [PosixPath('textured/sphere.ply'), PosixPath('textured/sphere.png')]

    Its outputs exist and ``overwrite`` is False:

    >>> run_surface_job(SurfaceJob("meshes/sphere.ply", "grass32.exr", "textured", render=(48, 64))).status
    'skipped'
    """
    if not hasattr(jobs, "__iter__") or isinstance(jobs, (str, bytes, SurfaceJob)):
        raise TextonError(f"jobs must be an iterable of SurfaceJob, got {type(jobs).__name__}", param="jobs")
    jobs = list(jobs)
    own = executor is None
    if executor is None:
        executor = ThreadPoolExecutor(max(1, jobs_in_parallel))
    bar = None
    if progress:
        from ..core.progress import bar as progress_bar

        bar = progress_bar(total=len(jobs), desc="surface", unit="mesh", leave=True)
    results: list[JobResult | None] = [None] * len(jobs)
    futures = {}

    def collect(fut, k):
        try:
            results[k] = fut.result()
        except Exception as exc:  # the executor itself failed (e.g. a lost worker)
            results[k] = JobResult(jobs[k].mesh, "failed", f"{jobs[k].mesh}: {type(exc).__name__}: {exc}")
        if bar is not None:
            bar.update()
            if results[k].status == "failed":
                bar.write(f"warp-texton: error: {results[k].message}", file=sys.stderr)

    try:
        for k, job in enumerate(jobs):
            futures[executor.submit(run_surface_job, job, uuid.uuid4().hex)] = k
        for fut in as_completed(futures):
            collect(fut, futures[fut])
    except KeyboardInterrupt:
        _settle_interrupted(jobs, futures, results, collect)
        raise JobsInterrupted(results) from None
    finally:
        if bar is not None:
            bar.close()
        if own:
            executor.shutdown(wait=True, cancel_futures=True)
    return cast("list[JobResult]", results)  # as_completed collected every job


def _settle_interrupted(jobs, futures: dict, results: list, collect) -> None:
    """After Ctrl-C: cancel what has not started, let running jobs finish (their
    outputs are then complete or absent), and give every job a result."""
    for fut in futures:
        fut.cancel()
    for fut, k in futures.items():
        if results[k] is not None:
            continue
        if fut.cancelled():
            results[k] = JobResult(jobs[k].mesh, "cancelled", "interrupted before it started")
            continue
        try:
            fut.result()
            collect(fut, k)
        except BaseException:
            results[k] = JobResult(jobs[k].mesh, "cancelled", "interrupted")
    for k, job in enumerate(jobs[len(futures):], start=len(futures)):
        results[k] = JobResult(job.mesh, "cancelled", "interrupted before it started")
