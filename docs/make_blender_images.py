"""Render the pictures of docs/blender.md: the extension installed in Blender, its operator run on the
default cube with the demo photograph, rendered by Cycles (the OSL node) and by EEVEE (the bake and its
normal map).

The same run as the tests (tests/blender/test_extension.py): the zip built by ``build_extension``, installed
by Blender (``bpy``, tests/clients.py: ``.blender-venv`` or ``$WARP_TEXTON_BLENDER_PYTHON``) into a user
folder of its own, and rendered by tests/blender_extension.py. EEVEE renders on the CPU through Mesa's
software OpenGL where there is no GPU (slow: about a minute).

    python docs/make_blender_images.py [--wheels-dir DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from warp_texton.blender import build_extension
from warp_texton.blender.manifest import this_platform
from warp_texton.blender.wheels import dependency_wheels
from warp_texton.demo import demo_texture_path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from clients import run_blender  # noqa: E402  (the tests' Blender runner)

OUT = ROOT / "docs" / "images" / "blender"
SIZE = 640


def crop(src: Path, dst: Path, margin: int = 12) -> None:
    """The render cut to the cube (its opaque pixels) and a margin: the default camera sees it small."""
    rgba = np.asarray(Image.open(src))
    rows, cols = np.nonzero(rgba[..., 3])
    top, left = max(rows.min() - margin, 0), max(cols.min() - margin, 0)
    Image.fromarray(rgba[top:rows.max() + margin + 1, left:cols.max() + margin + 1]).save(dst, optimize=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--wheels-dir", help="the dependencies' wheels, downloaded before (default: download them)")
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        wheels = Path(args.wheels_dir) if args.wheels_dir else d / "wheels"
        if not args.wheels_dir:
            wheels.mkdir()
            dependency_wheels(this_platform(), wheels, None)
        build_extension(d / "warp_texton.zip", wheels_dir=wheels)
        (d / "user").mkdir()
        renders = [{"out": str(d / "cycles.png"), "branch": "material", "width": SIZE, "height": SIZE,
                    "samples": 32},
                   {"out": str(d / "eevee.png"), "branch": "material", "engine": "EEVEE", "width": SIZE,
                    "height": SIZE, "samples": 16}]
        spec = {"zip": str(d / "warp_texton.zip"), "image": str(demo_texture_path()),
                "runs": [{"operator": {"resolution": 1024}, "renders": renders}], "report": str(d / "report.json")}
        (d / "spec.json").write_text(json.dumps(spec))
        run_blender(ROOT / "tests" / "blender_extension.py", d / "spec.json", timeout=1200, cwd=d,
                    env={"BLENDER_USER_RESOURCES": str(d / "user")})
        report = json.loads((d / "report.json").read_text())
        for name in ("cycles", "eevee"):
            crop(d / f"{name}.png", OUT / f"cube_{name}.png")
    run = report["runs"][0]
    print(f"install {report['install_s']:.1f} s, operator {run['operator_s']:.1f} s, renders",
          [round(r["seconds"], 1) for r in run["renders"]])
    return 0


if __name__ == "__main__":
    sys.exit(main())
