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
                   mean=[float(v) for v in model.colours().mean(axis=(0, 1), dtype="float64")],
                   wrap=[bool(model.wrap[0]), bool(model.wrap[1])],
                   lattice=None if model.lattice is None else {
                       "vectors": [list(v) for v in model.lattice.vectors], "strength": model.lattice.strength})
        fit = model.metadata.get("fit")
        if isinstance(fit, dict):
            out["fit"] = fit
    else:
        out.update(size=[model.size[1], model.size[0]], order=model.order, mean=[float(v) for v in model.mean],
                   support_area=float(model.support_area))
        judged = model.metadata.get("histogram_zero_sum_spectrum_errors")
        if isinstance(judged, list):
            out["histogram_judge"] = {"kept": "zero-sum" if model.metadata.get("zero_sum") else "plain",
                                   "marginal_errors": model.metadata.get("histogram_marginal_errors")}
    score = meta.get("structure")
    choice = model.metadata.get("method_choice")
    if choice is None and isinstance(model.metadata.get("tiling_distance"), (int, float)):
        texton = model.metadata.get("texton_distance_blended", model.metadata.get("texton_distance"))
        choice = {"tiling": model.metadata["tiling_distance"], "texton": texton}
    if isinstance(choice, dict) and all(isinstance(choice.get(k), (int, float)) for k in ("tiling", "texton")):
        from ..model.analysis import AUTO_TILING_FRACTION

        out["method_choice"] = {k: float(choice[k]) for k in ("tiling", "texton")}
        if isinstance(choice.get("texton_measure"), str):
            meta["method_measure"] = choice["texton_measure"]
        closer = choice["tiling"] < AUTO_TILING_FRACTION * choice["texton"]
        out["suggested_method"] = "tiling" if closer else "texton"
    elif isinstance(score, (int, float)) and not isinstance(score, bool):
        out["suggested_method"] = suggest_method(float(score))
    out["metadata"] = meta
    return out


def structure_lines(s: dict, method: str | None = None) -> list[str]:
    """What the analysis found, for people: seamless or not, the lattice, the side chosen, the structure
    score and the method that fits (``summary``'s facts; ``method``: the one asked for, to advise)."""
    from ..model.tiling import STRUCTURE_THRESHOLD

    lines = []
    if s["kind"] == "tiling":
        fit = s.get("fit") or {}
        wrap = s["wrap"]
        seams = fit.get("seams")
        how = {(True, True): "yes (read wrapped)", (False, False): "no (a crop: read inside its borders)",
               (True, False): "across x only", (False, True): "across y only"}[tuple(wrap)]
        ratios = f" (seam ratios x {seams[0]:.2f}, y {seams[1]:.2f}; seamless at most 2.5)" if seams else ""
        lines.append(f"  seamless: {how}{ratios}")
        lat = s.get("lattice")
        if lat is None:
            found = fit.get("lattices")
            lines.append("  lattice: none" + (" found" if found == [] else " kept (the probes were closer without "
                                                                            "one)" if found else ""))
        else:
            vecs = "; ".join(f"({v[0]:.2f}, {v[1]:.2f})" for v in lat["vectors"])
            kind = "courses" if len(lat["vectors"]) == 1 else "tiles"
            strength = "" if lat["strength"] is None else f", strength {lat['strength']:.2f}"
            lines.append(f"  lattice: {kind}, vectors (dy, dx) {vecs} texels{strength}")
        cands = fit.get("candidates") or []
        if cands:
            lines.append(f"  side {s['side']:g} texels, chosen among {len(cands)} candidates by their probes' "
                         f"patch distance")
    score = s["metadata"].get("structure")
    choice = s.get("method_choice")
    if isinstance(score, (int, float)):
        fits = s.get("suggested_method", s["kind"])
        advice = "" if method in (None, "auto") else ("; fits" if fits == method else f"; try --method {fits}")
        measure = s["metadata"].get("method_measure", "the phase-randomised example")
        why = (f"; patch distance to the example: tiling {choice['tiling']:.4f}, texton {choice['texton']:.4f} "
               f"({measure})") if choice else ""
        lines.append(f"  structure score {score:.2f} (1: Gaussian-like; above {STRUCTURE_THRESHOLD:g}: shapes that "
                     f"texton noise loses): method {fits!r} fits the example{why}{advice}")
    return lines


def _text(path: str, s: dict) -> list[str]:

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
    lines.extend(structure_lines(s))
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
