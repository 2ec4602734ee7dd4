"""``warp-texton view``: the interactive viewer (:mod:`warp_texton.view.server`) served until Ctrl-C."""

from __future__ import annotations

import argparse
import sys

from .options import Command, filter_help, input_file
from ..noise.filter_options import FILTERS
from ..view.queries import VIEW_FILTERS


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", help="example image or texton file")
    p.add_argument("--port", type=int, default=8000, help="TCP port (0: any free port)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to bind; anything but 127.0.0.1 lets others on the network use it (with a warning)")
    p.add_argument("--device", help="cpu, cuda or cuda:N (default: CUDA when available)")
    p.add_argument("--open", action="store_true", help="open the page in the default web browser")
    p.add_argument("--mix", metavar="B",
                   help="second image or texton for the mixing mode (the page can also upload one)")
    p.add_argument("--size", type=int, default=64, help="start texton size, texels")
    p.add_argument("--order", type=int, default=1, choices=(0, 1, 3, 5), help="start interpolation order")
    p.add_argument("--no-color-correction", dest="color_correction", action="store_false",
                   help="start without the colour-covariance correction")
    p.add_argument("--seed", type=int, default=0, help="start noise seed")
    p.add_argument("--mni", type=float, default=30.0, help="start mean number of impacts per point")
    p.add_argument("--filter", choices=VIEW_FILTERS, default="anisotropic",
                   help="start filter for zoomed-out views. " + filter_help({k: FILTERS[k] for k in VIEW_FILTERS}))
    p.add_argument("--png-level", type=int, default=0, choices=range(10), metavar="0-9",
                   help="zlib level of the tiles: 0 is the fastest to make, 1-9 save bandwidth over a slow link")
    p.add_argument("-v", "--verbose", action="store_true", help="log every request")


def _view(args) -> int:
    from ..view.server import serve

    try:
        handle = serve(args.input, port=args.port, host=args.host, device=args.device, mix=args.mix,
                       size=args.size, order=args.order, color_correction=args.color_correction, seed=args.seed,
                       mni=args.mni, filter=args.filter, png_level=args.png_level, open_browser=args.open,
                       verbose=args.verbose)
    except KeyboardInterrupt:
        return 130
    try:  # the line is inside: a Ctrl-C right after it (the page may already be open) still stops cleanly
        print(f"warp-texton view: serving {args.input} at {handle.url} (Ctrl-C to stop)", flush=True)
        handle.wait()
    except KeyboardInterrupt:
        print("\nwarp-texton view: stopped", file=sys.stderr)
    finally:
        handle.close()
    return 0


VIEW = Command(
    "view", "interactive explorer in a web browser",
    "Serve an interactive viewer of the texton noise of INPUT (an example image, analysed at start and again "
    "when the page changes the analysis settings, or a texton file): an infinite, zoomable canvas, live "
    "controls, a ground plane, mixing, and exports with the commands that reproduce them. Ctrl-C stops it.",
    _arguments, _view,
    {"size": "--size", "order": "--order", "seed": "--seed", "mni": "--mni", "filter": "--filter",
     "device": "--device", "port": "--port", "host": "--host", "png_level": "--png-level", "mix": "--mix"},
    input_file,
    epilog="""examples:
  warp-texton view wood.png                      # then open http://127.0.0.1:8000/
  warp-texton view wood.exr --port 8080 --open --device cpu
  warp-texton view wood.png --mix marble.png --size 32
on a remote GPU machine: run it there, then on your laptop
  ssh -L 8000:127.0.0.1:8000 gpu-host            # and open http://127.0.0.1:8000/
""")
