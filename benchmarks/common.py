"""Helpers shared by the benchmark scripts: machine description, git state,
atomic result files, the colour test texture and a reader of GIMP patterns."""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import struct
import subprocess
from pathlib import Path

import numpy as np
import scipy

import warp_texton
from warp_texton.files.images import atomic_path

HERE = Path(__file__).resolve().parent
#: Debian's gimp-data (GPL-3+): small seamless patterns, read by read_gpat
GIMP_PATTERNS = Path("/usr/share/gimp/2.0/patterns")
#: GIMP patterns are small; refuse files that claim absurd sizes.
GPAT_MAX_SIDE = 8192
#: Debian's openarena-081-textures (GPL-2+, see its copyright file): colour photographs of
#: ground, rock, wood and tiles, 512² JPEG/TGA files inside one zip archive (a Quake-3 .pk3).
#: Found installed, at $WARP_TEXTON_OPENARENA_PK3, or unpacked by .ci/run into .ci-data/
#: (``apt-get download openarena-081-textures`` and ``dpkg-deb -x``; nothing installed).
OPENARENA_PK3 = "usr/share/games/openarena/baseoa/pak4-textures.pk3"
#: Largest archive member read (the textures are at most a few MB).
PK3_MAX_BYTES = 32 << 20

# Channels of the test texture: grass, gravel and brick mixed so that they correlate.
MIX = np.array([
    [0.60, 0.30, 0.10],
    [0.35, 0.45, 0.20],
    [0.20, 0.30, 0.50],
])


def openarena_pk3() -> Path:
    """The archive of openarena-081-textures, or OSError saying where it was looked for."""
    import os

    places = [os.environ.get("WARP_TEXTON_OPENARENA_PK3"), "/" + OPENARENA_PK3,
              str(HERE.parent / ".ci-data" / "openarena" / OPENARENA_PK3)]
    for p in places:
        if p and Path(p).is_file():
            return Path(p)
    raise OSError("openarena-081-textures not found (apt-get download openarena-081-textures && "
                  "dpkg-deb -x openarena-081-textures_*.deb .ci-data/openarena, or set WARP_TEXTON_OPENARENA_PK3)")


def read_openarena(member: str) -> np.ndarray:
    """A texture of openarena-081-textures as a float32 (H, W, 3) image in [0, 1]."""
    import io
    import zipfile

    from PIL import Image

    try:
        with zipfile.ZipFile(openarena_pk3()) as z:
            try:
                info = z.getinfo(member)
            except KeyError:
                raise OSError(f"{member}: not in the openarena textures archive") from None
            if info.file_size > PK3_MAX_BYTES:
                raise ValueError(f"{member}: {info.file_size} bytes, more than {PK3_MAX_BYTES}")
            data = z.read(info)
    except zipfile.BadZipFile as exc:
        raise ValueError(f"the openarena textures archive is not a zip file: {exc}") from None
    with Image.open(io.BytesIO(data)) as im:
        return np.asarray(im.convert("RGB"), np.float32) / 255.0


def make_texture(side: int) -> np.ndarray:
    """A side × side RGB texture: grass, gravel and brick (CC0) mixed linearly."""
    from skimage import data

    sources = [getattr(data, name)() for name in ("grass", "gravel", "brick")]
    y0 = (sources[0].shape[0] - side) // 2
    x0 = (sources[0].shape[1] - side) // 2
    stack = np.stack([s[y0:y0 + side, x0:x0 + side] for s in sources], axis=-1) / 255.0
    return np.ascontiguousarray(stack @ MIX.T, dtype=np.float32)


def read_gpat(path: Path) -> np.ndarray:
    """A GIMP pattern (``.pat``) as a float32 (H, W, C) image in [0, 1], C = 1 or 3.

    Format: big-endian uint32 header_size, version (1), width, height,
    bytes_per_pixel (1 grey, 2 grey + alpha, 3 RGB, 4 RGBA), the magic
    ``GPAT``, a NUL-terminated UTF-8 name up to header_size, then the rows of
    raw 8-bit pixels. Alpha is dropped.
    """
    data = Path(path).read_bytes()
    if len(data) < 24:
        raise ValueError(f"{path}: too short for a GIMP pattern header")
    header_size, version, width, height, bpp = struct.unpack(">5I", data[:20])
    if data[20:24] != b"GPAT" or version != 1:
        raise ValueError(f"{path}: not a GIMP pattern (magic {data[20:24]!r}, version {version})")
    if bpp not in (1, 2, 3, 4) or not (0 < width <= GPAT_MAX_SIDE and 0 < height <= GPAT_MAX_SIDE):
        raise ValueError(f"{path}: unsupported pattern {width}x{height} with {bpp} bytes per pixel")
    if header_size < 24 or header_size + width * height * bpp > len(data):
        raise ValueError(f"{path}: header size {header_size} or pixel data do not fit the file")
    pixels = np.frombuffer(data, np.uint8, count=width * height * bpp, offset=header_size)
    pixels = pixels.reshape(height, width, bpp)[:, :, : 1 if bpp <= 2 else 3]
    return pixels.astype(np.float32) / 255.0


def processor_name() -> str:
    name = platform.processor()
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return name or "unknown"


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", *args], cwd=HERE, capture_output=True,
                             text=True, timeout=10, check=True)
        return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


def git_commit() -> str | None:
    """HEAD of the checkout, or None outside a git checkout."""
    return _git("rev-parse", "HEAD") or None


def git_dirty() -> bool | None:
    """Whether tracked files differ from HEAD (the commit alone does not say what ran).

    Result files are left out: a run that rewrites benchmarks/results/ does not
    make the code it measures any different.
    """
    status = _git("status", "--porcelain", "--untracked-files=no", "--", ":(top)", ":(top,exclude)benchmarks/results")
    return None if status is None else bool(status)


def machine_info() -> dict:
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    return {
        "platform": platform.platform(),
        "processor": processor_name(),
        "cpu_count": os.cpu_count(),
        "usable_cpus": usable,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "warp_texton": warp_texton.__version__,
    }


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (the package's ``atomic_path``)."""
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")


def run_main(doc: str, name: str, run, markdown, argv=None, *, repeat: int = 7, mni: float = 30.0,
             extra_args=None) -> int:
    """The command line shared by the bench_*.py scripts.

    Options --quick (smoke run: at most 2 repeats, nothing written unless --out
    is given), --repeat, --mni, --size, --device and --out, plus whatever
    ``extra_args(parser)`` adds; then ``run(args)`` makes the report and
    ``markdown(report)`` its table, printed and written as ``name``.json/.md
    (suffixed with the device when it is not the CPU).
    """
    parser = argparse.ArgumentParser(description=doc.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="small smoke run (CI)")
    parser.add_argument("--repeat", type=int, default=repeat, help="runs per measurement")
    parser.add_argument("--mni", type=float, default=mni, help="mean number of impacts")
    parser.add_argument("--size", type=int, default=64, help="texton side")
    parser.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N")
    parser.add_argument("--out", type=Path, default=HERE / "results", help="folder for JSON and Markdown")
    if extra_args is not None:
        extra_args(parser)
    args = parser.parse_args(argv)
    if args.quick:
        args.repeat = min(args.repeat, 2)
    report = run(args)
    text = markdown(report)
    print(text)
    if not args.quick or args.out != HERE / "results":
        args.out.mkdir(parents=True, exist_ok=True)
        stem = name if report["device"] == "cpu" else f"{name}_" + report["device"].replace(":", "")
        write_atomic(args.out / f"{stem}.json", json.dumps(report, indent=2) + "\n")
        write_atomic(args.out / f"{stem}.md", text)
    return 0


def report_header(benchmark: str, device: str) -> dict:
    """The fields every result file starts with: what ran, where, when, from which commit."""
    import warp

    return {
        "benchmark": benchmark,
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "git_commit": git_commit(),
        "git_dirty": git_dirty(),
        "machine": machine_info(),
        "device": device,
        "warp": warp.config.version,
    }


def machine_line(report: dict) -> str:
    """The Markdown sentence naming the machine, software and commit of a report."""
    m = report["machine"]
    dirty = " (uncommitted changes)" if report.get("git_dirty") else ""
    return (f"Machine: {m['processor']}, {m['usable_cpus']} usable cores, Python {m['python']}, "
            f"Warp {report['warp']}, device `{report['device']}`, commit `{(report['git_commit'] or '?')[:10]}`{dirty}.")
