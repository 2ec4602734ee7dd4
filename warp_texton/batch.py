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
import io
import sys
import uuid
from concurrent.futures import Executor, ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

from .errors import TextonError

FORMATS = ("ply", "obj", "glb")


@dataclass(frozen=True)
class SurfaceJob:
    """Texture one mesh file; outputs go to ``out_dir`` named after its stem."""

    mesh: str
    texton: str
    out_dir: str
    texel_size: float | None = None  # world units per texel; None: surface.default_texel_size
    mni: float = 60.0
    seed: int = 0
    max_edge: float | None = None
    render: tuple[int, int] | None = None  # (height, width) of a PNG render, or None
    fmt: str = "ply"
    overwrite: bool = False
    device: str | None = None

    def outputs(self) -> list[Path]:
        stem = Path(self.mesh).stem
        out = [Path(self.out_dir) / f"{stem}.{self.fmt}"]
        if self.render is not None:
            out.append(Path(self.out_dir) / f"{stem}.png")
        return out


@dataclass(frozen=True)
class JobResult:
    mesh: str
    status: str  # "done", "skipped" or "failed"
    message: str = ""
    outputs: list[str] = field(default_factory=list)


def expand_meshes(args) -> list[str]:
    """Mesh arguments to paths: plain paths, glob patterns, and ``@list.txt``
    files holding one path or pattern per line (blank lines and # comments
    skipped). Order is kept and duplicates dropped; a pattern that matches
    nothing stays as is, so that its job reports the missing file."""
    out: list[str] = []
    for arg in args:
        if arg.startswith("@"):
            listing = Path(arg[1:])
            try:
                lines = listing.read_text().splitlines()
            except OSError as exc:
                raise TextonError(f"{listing}: cannot read the mesh list ({exc.strerror})") from None
            entries = [ln.strip() for ln in lines if ln.strip() and not ln.strip().startswith("#")]
            out.extend(expand_meshes(entries))
        elif glob.has_magic(arg):
            out.extend(sorted(glob.glob(arg, recursive=True)) or [arg])
        else:
            out.append(arg)
    seen = set()
    return [p for p in out if not (p in seen or seen.add(p))]


def _load_mesh(path: str):
    import trimesh

    p = Path(path)
    if not p.is_file():
        raise TextonError(f"{path}: no such file")
    try:
        mesh = trimesh.load(str(p), force="mesh", process=False)
    except Exception as exc:
        raise TextonError(f"{path}: not a mesh that trimesh can read ({exc})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise TextonError(f"{path}: the file holds no triangles")
    return mesh


def run_surface_job(job: SurfaceJob, token: str | None = None) -> JobResult:
    """Run one job; never raises for a bad mesh (the result says why).

    ``token`` is ignored: :func:`run_batch` passes a fresh one with every
    submission so that executors that cache results of equal calls (Dask's
    pure tasks) always run the job, whose inputs may have changed on disk.
    """
    from .io import atomic_path, write_image
    from .surface import default_texel_size, render_mesh, texture_mesh
    from .texton import load_texton

    outputs = job.outputs()
    if not job.overwrite and all(p.exists() for p in outputs):
        return JobResult(job.mesh, "skipped", "outputs exist (use --overwrite)", [str(p) for p in outputs])
    try:
        Path(job.out_dir).mkdir(parents=True, exist_ok=True)  # on a cluster worker too
        texton = load_texton(job.texton)
        mesh = _load_mesh(job.mesh)
        texel = default_texel_size(mesh) if job.texel_size is None else job.texel_size
        textured = texture_mesh(mesh, texton, texel, mni=job.mni, seed=job.seed, max_edge=job.max_edge,
                                device=job.device)
        buf = io.BytesIO()
        textured.export(buf, file_type=job.fmt)
        img = None
        if job.render is not None:  # computed before anything is written: all outputs or none
            img = render_mesh(mesh, texton, job.render, texel_size=texel, mni=job.mni, seed=job.seed,
                              device=job.device)
        with atomic_path(outputs[0]) as tmp:
            Path(tmp).write_bytes(buf.getvalue())
        if img is not None:
            write_image(outputs[1], img)
    except TextonError as exc:
        return JobResult(job.mesh, "failed", str(exc))
    except OSError as exc:
        return JobResult(job.mesh, "failed", f"{exc.filename or job.mesh}: {exc.strerror or exc}")
    except Exception as exc:  # a broken file must not stop the batch
        return JobResult(job.mesh, "failed", f"{job.mesh}: {type(exc).__name__}: {exc}")
    return JobResult(job.mesh, "done", "", [str(p) for p in outputs])


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


def run_batch(jobs, executor: Executor | None = None, jobs_in_parallel: int = 1, progress: bool = False):
    """Run jobs on ``executor`` (default: a pool of ``jobs_in_parallel`` threads).

    Returns the results in the order of ``jobs``. Any ``concurrent.futures``
    executor works, e.g. ``dask.distributed.Client(...).get_executor()``.
    """
    jobs = list(jobs)
    own = executor is None
    if own:
        executor = ThreadPoolExecutor(max(1, jobs_in_parallel))
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(jobs), desc="surface", unit="mesh")
    try:
        futures = {executor.submit(run_surface_job, job, uuid.uuid4().hex): k for k, job in enumerate(jobs)}
        results: list[JobResult | None] = [None] * len(jobs)
        for fut in as_completed(futures):
            k = futures[fut]
            try:
                results[k] = fut.result()
            except Exception as exc:  # the executor itself failed (e.g. a lost worker)
                results[k] = JobResult(jobs[k].mesh, "failed", f"{type(exc).__name__}: {exc}")
            if bar is not None:
                bar.update()
                if results[k].status == "failed":
                    bar.write(f"warp-texton: error: {results[k].message}", file=sys.stderr)
    finally:
        if bar is not None:
            bar.close()
        if own:
            executor.shutdown()
    return results
