"""``warp-texton info``: what a model file holds (a texton, or a tiling model), in a few lines or as JSON."""

from __future__ import annotations

import argparse
import json

from .options import Command, input_file


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", help="model file: a texton (.texton or .exr) or a tiling model (.exr)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")


def summary(model) -> dict:
    """The facts of a :class:`~warp_texton.Texton` or :class:`~warp_texton.model.tiling.TilingModel`, JSON values."""
    from ..model.tiling import TilingModel, suggest_method

    meta = {k: v for k, v in model.metadata.items() if isinstance(v, (str, int, float, bool)) or v is None}
    out: dict = {"kind": "tiling" if isinstance(model, TilingModel) else "texton", "channels": model.channels,
                 "histogram": "preserve" if model.histogram is not None else "gaussian"}
    if isinstance(model, TilingModel):
        h, w, _ = model.example.shape
        out.update(example=[w, h], side=model.side, margin=model.margin, sharpness=model.sharpness,
                   guide_weight=model.guide_weight, blend=model.blend,
                   mean=[float(v) for v in model.colours().mean(axis=(0, 1), dtype="float64")])
    else:
        out.update(size=[model.size[1], model.size[0]], order=model.order, mean=[float(v) for v in model.mean],
                   support_area=float(model.support_area))
        judged = model.metadata.get("histogram_zero_sum_spectrum_errors")
        if isinstance(judged, list):
            out["histogram_judge"] = {"kept": "zero-sum" if model.metadata.get("zero_sum") else "plain",
                                   "marginal_errors": model.metadata.get("histogram_marginal_errors")}
    score = meta.get("structure")
    if isinstance(score, (int, float)) and not isinstance(score, bool):
        out["suggested_method"] = suggest_method(float(score))
    out["metadata"] = meta
    return out


def _text(path: str, s: dict) -> list[str]:
    from ..model.tiling import STRUCTURE_THRESHOLD

    colours = "grey" if s["channels"] == 1 else "RGB"
    mean = ", ".join(f"{v:.4f}" for v in s["mean"])
    hist = ", histogram preserved" if s["histogram"] == "preserve" else ""
    if s["kind"] == "tiling":
        lines = [f"{path}: tiling model (method 'tiling') of a {s['example'][0]}x{s['example'][1]} {colours} example{hist}",
                 f"  blend: triangles of side {s['side']:g} texels, sharpness {s['sharpness']}, {s['blend']} blend, "
                 f"guide weight {s['guide_weight']:g}",
                 f"  mean colour {mean}"]
    else:
        lines = [f"{path}: texton (method 'texton') of {s['size'][0]}x{s['size'][1]}, order {s['order']}, {colours}{hist}",
                 f"  mean {mean}, support area {s['support_area']:.6g} texels"]
        if isinstance(s["metadata"].get("model_error"), (int, float)):
            lines.append(f"  model error {s['metadata']['model_error']:.3f}")
        if "histogram_judge" in s:
            kept, marginals = s["histogram_judge"]["kept"], s["histogram_judge"]["marginal_errors"]
            why = ("its spectrum past its bound" if not marginals else
                   f"marginal W1 on samples {marginals[0]:.4g} (plain), {marginals[1]:.4g} (zero-sum)")
            kept = "zero-sum (no power at frequency 0)" if kept == "zero-sum" else "plain"
            lines.append(f"  histogram judge: kept the {kept} texton; zero-sum: {why}")
    if "suggested_method" in s:
        lines.append(f"  structure score {s['metadata']['structure']:.2f} (above {STRUCTURE_THRESHOLD:g}: shapes that "
                     f"texton noise loses): method {s['suggested_method']!r} fits the example")
    if "source" in s["metadata"]:
        lines.append(f"  analysed from {s['metadata']['source']}")
    return lines


def _info(args) -> None:
    from ..model.texton import load_texton

    s = summary(load_texton(args.input))
    print(json.dumps(s) if args.json else "\n".join(_text(args.input, s)))


INFO = Command(
    "info", "what a texton or tiling model file holds",
    "Print what a model file holds: for a texton its size, order, mean and model error; for a tiling model "
    "(analyze --method tiling) its example, triangle side, sharpness and blend; for either the histogram "
    "transform and the structure score measured at analysis, with the method it suggests.",
    _arguments, _info, {}, input_file,
    epilog="""examples:
  warp-texton info wood.exr
  warp-texton info bricks_tiling.exr --json
""")
