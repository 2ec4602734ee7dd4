"""The ``warp-texton`` command line: the parser made from the commands, and ``main``.

The commands live in :mod:`~warp_texton.cli.image_commands`, :mod:`~warp_texton.cli.surface`
and :mod:`~warp_texton.cli.view`, each a :class:`~warp_texton.cli.options.Command`
(its arguments, its handler, and the library arguments its options set); a new
command is one more record in :data:`COMMANDS`. Nothing is imported from the
library before a handler runs, so ``--version``, ``--help`` and usage errors do
not start Warp.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import warnings

from .._version import __version__
from .blender import BLENDER_EXTENSION
from .image_commands import ANALYZE, DEMO, GAUSSIAN, MIX, RENDER_PLANE, SYNTHESIZE
from .info import INFO
from .options import Command, start_clock
from .shader import SHADER
from .surface import SURFACE
from .view import VIEW
from ..core.errors import ExampleWarning, TextonError

#: The commands, in the order ``--help`` lists them.
COMMANDS: dict[str, Command] = {c.name: c for c in (ANALYZE, GAUSSIAN, SYNTHESIZE, RENDER_PLANE, MIX, SURFACE,
                                                     VIEW, DEMO, SHADER, BLENDER_EXTENSION, INFO)}


class _Formatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """Keeps the hand-wrapped descriptions and examples, and shows each option's default."""

    def _get_help_string(self, action):
        if action.default is None or isinstance(action.default, bool):
            return action.help  # nothing useful to show
        return super()._get_help_string(action)


class _Parser(argparse.ArgumentParser):
    """argparse whose usage errors follow the project's one-line, exit-2 rule."""

    def error(self, message):
        self.exit(2, f"warp-texton: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="warp-texton",
        description=(
            "Texton noise by example. 'analyze' learns a small texton from an example of a "
            "Gaussian texture (fabric, wood, stone, sand...); 'synthesize' evaluates texton noise "
            "on a raster of any size; 'render-plane' shows it on a ground plane in perspective, anti-aliased; "
            "'mix' blends two textures; 'gaussian' samples the texture's Gaussian model by FFT; "
            "'demo' runs everything on a texture shipped with the package."
        ),
        formatter_class=_Formatter,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for command in COMMANDS.values():
        p = sub.add_parser(command.name, help=command.help, description=command.description,
                           epilog=command.epilog, formatter_class=_Formatter)
        command.arguments(p)
    return parser


def cli_message(error: TextonError, args: argparse.Namespace) -> str:
    """A library error in the words of the command ``args`` ran: the options and
    files that set the arguments it names."""
    command = COMMANDS[args.command]
    return error.in_words({**command.names, **command.files(args)})


def warning_words(warning, args: argparse.Namespace) -> str:
    """A library warning in the words of the command ``args`` ran: an
    :class:`~warp_texton.core.errors.ExampleWarning` with its options and files, others as they are."""
    if isinstance(warning, ExampleWarning):
        command = COMMANDS[args.command]
        return warning.in_words({**command.names, **command.files(args)})
    return str(warning)


class _Terminated(SystemExit):
    """SIGTERM, raised as SystemExit: every atomic write in progress removes its temporary file."""


def _terminated(signum, frame):
    raise _Terminated(128 + signum)


def _run(args: argparse.Namespace) -> int:
    """Run the command of ``args``: its exit status, with user errors as one line on stderr."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            return COMMANDS[args.command].run(args) or 0
    except TextonError as exc:
        print(f"warp-texton: error: {cli_message(exc, args)}", file=sys.stderr)
    except OSError as exc:  # disk full, permission denied... still one line
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"warp-texton: error: {where}{exc.strerror or exc}", file=sys.stderr)
    except MemoryError:
        print("warp-texton: error: out of memory; the request fits the memory budget but not the memory free now: "
              "lower WARP_TEXTON_MEMORY_BUDGET or ask for less (docs/limits.md)", file=sys.stderr)
    except KeyboardInterrupt:
        print("\nwarp-texton: interrupted; nothing written", file=sys.stderr)
        return 130
    except _Terminated as exc:
        print("\nwarp-texton: terminated; nothing written", file=sys.stderr)
        return exc.code if isinstance(exc.code, int) else 143
    return 2


def main(argv=None) -> int:
    start_clock(startup=argv is None)
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    saved_format = warnings.formatwarning
    warnings.formatwarning = lambda msg, *a, **k: f"warp-texton: warning: {warning_words(msg, args)}\n"
    saved_term = None
    if threading.current_thread() is threading.main_thread():
        saved_term = signal.signal(signal.SIGTERM, _terminated)
    try:
        return _run(args)
    finally:
        warnings.formatwarning = saved_format
        if saved_term is not None:
            signal.signal(signal.SIGTERM, saved_term)


if __name__ == "__main__":
    sys.exit(main())
