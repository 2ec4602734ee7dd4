"""``warp-texton shader``: texton noise as shader code (:mod:`warp_texton.runtimes.export`), and its HTML preview."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from .options import (ANALYSIS_NAMES, FILTER_NAMES, SHAPE_NAMES, Command, add_analysis_options,
                          add_placement_options, input_file, noise_options, seconds_since, texton_of)
from ..core.errors import TextonError
from ..runtimes.languages import LANGUAGES, WEBGL


#: The languages' names (0.2's name; the registry is ``runtimes.languages.LANGUAGES``).
LANGS = tuple(LANGUAGES)

def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", help="texton file or example image")
    p.add_argument("--lang", required=True, choices=tuple(LANGUAGES),
                   help="shader language: " + "; ".join(f"{k}, {v.summary}" for k, v in LANGUAGES.items()))
    p.add_argument("-o", "--output", help="export folder to create (the shader, its textures, a description)")
    p.add_argument("--html", help=f"self-contained HTML page drawing a window of the noise with WebGL2 ({WEBGL})")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an export folder an earlier run wrote, and an existing --html page")
    p.add_argument("--width", type=int, default=512, help="preview width in pixels (--html)")
    p.add_argument("--height", type=int, default=512, help="preview height in pixels (--html)")
    p.add_argument("--mni", type=float, default=30.0, help="mean number of impacts per point")
    p.add_argument("--seed", type=int, default=0, help="random seed (analysis and noise)")
    add_placement_options(p)  # the preview's window (--html) and the noise's period
    p.add_argument("--filter", choices=("none", "mip", "anisotropic"),
                   help="glsl: the filter of the shader's filtered variant (default anisotropic)")
    p.add_argument("--texel-size", type=float,
                   help="osl: the default of the shaders' texel_size, shading-space units per texel (default 0.01)")
    p.add_argument("--up", choices=("x", "y", "z"), default="z",
                   help="the surface variant's up axis, for its frame rule (default z; glTF scenes are y up)")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary")
    add_analysis_options(p, seed=False)


def _check_page(page, output, overwrite: bool) -> None:
    """The --html page: a name the file system can hold, in a folder that exists, not an
    existing file unless --overwrite, and outside the export folder (which --overwrite may
    rewrite). Checked before any output is written, so that a bad page leaves no export behind."""
    from ..files.images import check_output_name

    given = Path(page)
    if (given.is_symlink() or given.exists()) and not given.is_dir() and not overwrite:  # replaced only when asked
        raise TextonError(f"--html {page}: exists; give --overwrite to replace it", param="--html")
    path = check_output_name(page, "--html")
    parent = (path.parent if str(path.parent) else Path(".")).resolve()
    if not parent.is_dir():
        raise TextonError(f"{page}: the output folder {path.parent} does not exist", param="--html")
    if output is None:
        return
    folder = Path(output).resolve()
    if path.resolve() == folder or parent == folder or folder in parent.parents:
        raise TextonError(f"--html {page}: inside the export folder {output}; write the page beside it",
                          param="--html")


def _shader(args) -> None:
    from ..files.images import atomic_path
    from ..runtimes.export import export_shader, preview_page

    if args.output is None and args.html is None:
        raise TextonError("give -o DIR (the export folder), --html PAGE (the preview), or both")
    if args.html is not None and not LANGUAGES[args.lang].page:
        raise TextonError(f"--html previews the {WEBGL} export (WebGL2); it is not available with --lang {args.lang}")
    if args.html is not None:
        _check_page(args.html, args.output, args.overwrite)
    t0 = time.perf_counter()
    texton = texton_of(args)
    noise = noise_options(args)
    what = "a tiling model" if getattr(texton, "kind", "texton") == "tiling" else "texton noise"
    # the page is made (and its options checked) before the folder is written: all outputs or none
    html = None if args.html is None else preview_page(
        texton, (args.height, args.width), scale=args.scale, rotation=args.rotation, offset=tuple(args.offset),
        noise=noise)
    if args.output is not None:
        out = export_shader(texton, args.lang, args.output, up=args.up, overwrite=args.overwrite,
                            filter=args.filter, texel_size=args.texel_size, noise=noise)
        if not args.quiet:
            print(f"{out}: {args.lang} export of {what}" + ("" if what != "texton noise" else f", MNI {args.mni:g}")
                  + f" ({seconds_since(t0)})")
    if html is not None:
        with atomic_path(args.html) as tmp:
            Path(tmp).write_text(html, encoding="utf-8")
        if not args.quiet:
            print(f"{args.html}: {args.width}x{args.height} WebGL2 preview of {what}"
                  + ("" if what != "texton noise" else f", MNI {args.mni:g}"))


SHADER = Command(
    "shader", "texton noise as GLSL or OSL shader code, and a WebGL2 preview page",
    "Export the texton noise of INPUT (a texton file, or an example image analysed first with the analysis "
    "options) as shader code that draws the same impacts as the Warp kernels: -o DIR writes the shader, the "
    "texton as textures and a description (the shaders carry the noise's exact gradient: GLSL texton_noise_grad, "
    "OSL GradientX, GradientY, NormalMap and BumpNormal outputs); --html PAGE writes one self-contained page that "
    "draws the window "
    "'synthesize' gives with the same --width, --height, --scale, --rotation, --offset, --period, --mni and "
    "--seed, with WebGL2.",
    _arguments, _shader,
    {**SHAPE_NAMES, **ANALYSIS_NAMES, "mni": "--mni", "seed": "--seed", "lang": "--lang", "out_dir": "-o",
     "overwrite": "--overwrite", "texel_size": "--texel-size", "up": "--up", "filter": FILTER_NAMES["filter"], "scale": "--scale", "rotation": "--rotation",
     "offset[0]": "--offset X", "offset[1]": "--offset Y", "offset": "--offset",
     "period[0]": "--period PX", "period[1]": "--period PY", "period": "--period"},
    input_file,
    epilog="""examples:
  warp-texton shader wood.texton --lang glsl -o wood_glsl
  warp-texton shader wood.texton --lang osl -o wood_osl --texel-size 0.02 --mni 60
  warp-texton shader wood.png --lang glsl --html wood.html --width 640 --height 480 --seed 3
  warp-texton shader wood.texton --lang glsl --html far.html --scale 0.5 --rotation 30 --offset 1e6 0
""")
