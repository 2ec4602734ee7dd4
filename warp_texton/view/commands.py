"""The commands and Python calls that reproduce what the viewer exports.

Each export comes with the ``warp-texton`` lines and the Python snippet that
make the same file: the analysis of the input (with :data:`ANALYSIS_SEED`), then
the noise with every setting of the view, numbers written as the shortest text
that reads back as the same double.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np

from .inputs import Source
from .queries import ANALYSIS_SEED, Analysis, Mix, Noise, Plane, Window


def _num(v: float) -> str:
    """A float as the shortest positional text that reads back as the same double
    (argparse takes "-0.000015" for a number but "-1.5e-05" for an option)."""
    return np.format_float_positional(float(v), unique=True, trim="0")


def _arg(v) -> str:
    return shlex.quote(_num(v) if isinstance(v, float) else str(v))


def _py(v) -> str:
    if isinstance(v, float):
        return _num(v)
    if isinstance(v, tuple):
        return "(" + ", ".join(_py(x) for x in v) + ")"
    return repr(v)


def _python(lines: list[str]) -> str:
    """The lines of a Python snippet with its ``from warp_texton import`` lines merged on top."""
    prefix = "from warp_texton import "
    names = sorted({n.strip() for ln in lines if ln.startswith(prefix) for n in ln[len(prefix):].split(",")})
    head = [ln for ln in lines if ln.startswith("import ")]
    body = [ln for ln in lines if not ln.startswith((prefix, "import "))]
    return "\n".join(head + [prefix + ", ".join(names)] + body)


def _load_expr(kind: str, path: str) -> str:
    return f"load_texton({path!r})" if kind == "texton" else f"read_image({path!r})"


def _pycall(fn: str, *args, **kwargs) -> str:
    parts = [*args, *(f"{k}={v}" for k, v in kwargs.items())]
    return f"{fn}({', '.join(parts)})"


def texton_steps(src: Source, analysis: Analysis) -> tuple[list[str], list[str], str]:
    """(CLI lines, Python lines, the CLI's texton argument) that give the texton."""
    path = src.path or ("INPUT.exr" if src.kind in ("texton", "tiling") else "INPUT.png")
    if src.kind in ("texton", "tiling"):  # a model file: loaded as it is
        return [], ["from warp_texton import load_texton", f"texton = load_texton({path!r})"], shlex.quote(path)
    stem = Path(src.name).stem or "input"
    cc = "" if analysis.color_correction else "_nocc"
    texton_file = f"{stem}_texton_{analysis.size}_o{analysis.order}{cc}.exr"
    cli = ["warp-texton", "analyze", shlex.quote(path), "-o", shlex.quote(texton_file),
           "--size", str(analysis.size), "--order", str(analysis.order), "--seed", str(ANALYSIS_SEED)]
    if not analysis.color_correction:
        cli.append("--no-color-correction")
    call = _pycall("analyze", f"read_image({path!r})", size=analysis.size, order=analysis.order,
                   seed=ANALYSIS_SEED, color_correction=analysis.color_correction)
    py = ["from warp_texton import analyze, read_image", f"texton = {call}"]
    return [" ".join(cli)], py, shlex.quote(texton_file)


def device_args(device) -> tuple[list[str], dict]:
    """The --device option and the device= argument of the commands (none: the default device)."""
    if device is None:
        return [], {}
    return ["--device", shlex.quote(str(device))], {"device": repr(str(device))}


def plan_noise(name: str, w: Window, analysis: Analysis, noise: Noise, src: Source, device) -> dict:
    """The commands of a noise export: ``synthesize`` of window ``w``."""
    cli, py, texton_arg = texton_steps(src, analysis)
    dev_cli, dev_py = device_args(device)
    h, wd = w.shape
    tiling = src.kind == "tiling"  # no MNI (texton noise's); the filter only when there is one
    mni_cli = [] if tiling else ["--mni", _arg(noise.mni)]
    line = ["warp-texton", "synthesize", texton_arg, "-o", shlex.quote(name), "--width", str(wd),
            "--height", str(h), *mni_cli, "--seed", str(noise.seed), "--scale", _arg(w.scale),
            "--rotation", _arg(w.rotation), "--offset", _arg(w.offset[0]), _arg(w.offset[1])]
    if w.period is not None:
        line += ["--period", _arg(w.period[0]), _arg(w.period[1])]
    line += ([] if tiling and noise.filter == "none" else ["--filter", noise.filter]) + dev_cli
    kwargs: dict = {} if tiling else dict(mni=_py(noise.mni))
    kwargs.update(seed=noise.seed, scale=_py(w.scale), rotation=_py(w.rotation), offset=_py(w.offset))
    if w.period is not None:
        kwargs["period"] = _py(w.period)
    if not (tiling and noise.filter == "none"):
        kwargs["filter"] = repr(noise.filter)
    kwargs.update(**dev_py)
    py = py + ["from warp_texton import synthesize, write_image",
               f"image = {_pycall('synthesize', 'texton', _py(w.shape), **kwargs)}",
               f"write_image({name!r}, image)"]
    return {"file": name, "width": wd, "height": h, "cli": cli + [" ".join(line)], "python": _python(py)}


def plan_plane(name: str, p: Plane, analysis: Analysis, noise: Noise, src: Source, device) -> dict:
    """The commands of a plane view export: ``render-plane``."""
    cli, py, texton_arg = texton_steps(src, analysis)
    dev_cli, dev_py = device_args(device)
    line = ["warp-texton", "render-plane", texton_arg, "-o", shlex.quote(name), "--width", str(p.width),
            "--height", str(p.height), "--mni", _arg(noise.mni), "--seed", str(noise.seed),
            "--camera-height", _arg(p.camera_height), "--tilt", _arg(p.tilt), "--fov", _arg(p.fov),
            "--texel-size", _arg(p.texel_size), "--filter", noise.filter, *dev_cli]
    call = _pycall("render_plane", "texton", _py((p.height, p.width)), height=_py(p.camera_height),
                   tilt=_py(p.tilt), fov=_py(p.fov), texel_size=_py(p.texel_size), mni=_py(noise.mni),
                   seed=noise.seed, filter=repr(noise.filter), **dev_py)
    py = py + ["from warp_texton import render_plane, write_image", f"image = {call}",
               f"write_image({name!r}, image)"]
    return {"file": name, "width": p.width, "height": p.height, "cli": cli + [" ".join(line)],
            "python": _python(py)}


def plan_mix(name: str, shape, scale: float, corner, analysis: Analysis, noise: Noise, mix: Mix,
             a: Source, b: Source, device) -> dict:
    """The Python call of a mix export (a ramp in noise space, which no single command takes)."""
    a_expr = _load_expr(a.kind, a.path or ("A.exr" if a.kind == "texton" else "A.png"))
    b_expr = _load_expr(b.kind, b.path or b.name)
    dev_py = device_args(device)[1]
    h, w = shape
    x0, start, end = _py(corner[0]), _py(mix.start), _py(mix.end)
    textons = _pycall("mix_textons", a_expr, b_expr, f"np.linspace(0.0, 1.0, {mix.steps})", size=analysis.size,
                      order=analysis.order, seed=ANALYSIS_SEED, color_correction=analysis.color_correction)
    image = _pycall("synthesize_mixed", "textons", "rho", _py((h, w)), mni=_py(noise.mni), seed=noise.seed,
                    scale=_py(scale), offset=_py(tuple(corner)), **dev_py)
    py = ["import numpy as np",
          "from warp_texton import load_texton, mix_textons, read_image, synthesize_mixed, write_image",
          f"textons = {textons}",
          f"# rho in noise space: 0 left of x = {start}, 1 right of x = {end}",
          f"x = {x0} + (np.arange({w}) + 0.5) / {_py(scale)}",
          f"rho = np.broadcast_to(np.clip((x - {start}) / ({end} - {start}), 0, 1), ({h}, {w}))",
          f"image = {image}",
          f"write_image({name!r}, image)"]
    return {"file": name, "width": w, "height": h,
            "cli": ["# no single warp-texton command: 'mix' takes its rho map from an image in the raster's "
                    "frame, this ramp lives in noise space; use the Python call"],
            "python": _python(py)}
