"""``warp-texton blender-extension``: the Blender extension zip (:mod:`warp_texton.blender`)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .options import Command, seconds_since
from ..blender.manifest import PLATFORMS, this_platform


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--output", required=True, help="the extension's .zip to write")
    p.add_argument("--platform", action="append", dest="platforms", metavar="PLATFORM",
                   help=f"a Blender platform to bundle wheels for, repeatable: {', '.join(PLATFORMS)} "
                        f"(default: this machine's, {this_platform()})")
    p.add_argument("--wheels-dir", help="a folder of wheels downloaded before: the dependencies are taken from it, "
                                        "none fetched")
    p.add_argument("--overwrite", action="store_true", help="replace an existing -o file")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress, no summary")


def _blender_extension(args) -> None:
    from ..blender.extension import build_extension

    t0 = time.perf_counter()
    say = None if args.quiet else (lambda line: print(line, file=sys.stderr))
    out = build_extension(args.output, platforms=args.platforms, wheels_dir=args.wheels_dir,
                          overwrite=args.overwrite, progress=say)
    if not args.quiet:
        size = Path(out).stat().st_size / 2**20
        print(f"{out}: Blender extension, {size:.0f} MiB ({seconds_since(t0)}); install it in Blender from "
              "Edit > Preferences > Get Extensions > Install from Disk")


BLENDER_EXTENSION = Command(
    "blender-extension", "a Blender extension (zip) whose operator makes a material from an image",
    "Write a Blender extension (Blender 4.2 or later): blender_manifest.toml, the add-on, and the wheels of "
    "the package and of its dependencies for Blender's Python, for each --platform. Installed in Blender, it "
    "adds the operator warp_texton.material_from_image and a panel in the Shader editor's sidebar "
    "(docs/blender.md).",
    _arguments, _blender_extension,
    {"out": "-o", "platforms": "--platform", "wheels_dir": "--wheels-dir", "overwrite": "--overwrite"},
    epilog="""examples:
  warp-texton blender-extension -o warp_texton_extension.zip
  warp-texton blender-extension -o all.zip --platform linux-x64 --platform windows-x64 --platform macos-arm64
  warp-texton blender-extension -o offline.zip --wheels-dir ./wheels
""")
