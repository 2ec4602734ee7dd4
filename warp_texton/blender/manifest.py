"""The extension's manifest (``blender_manifest.toml``, schema 1.0.0) and Blender's platforms.

Blender (4.2 and later) installs an extension from a zip whose top holds the manifest, the add-on's
``__init__.py`` and the wheels the manifest lists; it installs the wheels of the running platform
into its own site-packages. The platforms here are Blender's names, each with the wheel platform tags
``pip download`` is asked for (the first is the one the package's own wheels are built for).
"""

from __future__ import annotations

import json
import platform
from collections.abc import Sequence

from .._version import __version__
from ..core.errors import TextonError

#: The extension's id: its Python module inside Blender is ``bl_ext.<repository>.warp_texton``.
EXTENSION_ID = "warp_texton"
#: Blender's Python (4.2 to 5.0): the version the bundled wheels are downloaded for.
BLENDER_PYTHON = "3.11"
#: The first Blender with extensions (and with Python 3.11 up to 5.0).
BLENDER_MIN = "4.2.0"
#: Blender's platform names, each with the wheel platform tags accepted for it (best first): those for which
#: every dependency has a wheel (not linux-arm64 nor windows-arm64: no xatlas, no warp-lang wheel there).
PLATFORMS: dict[str, tuple[str, ...]] = {
    "linux-x64": ("manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64",
                  "manylinux2014_x86_64"),
    "windows-x64": ("win_amd64",),
    "macos-arm64": ("macosx_11_0_arm64", "macosx_12_0_arm64", "macosx_13_0_arm64", "macosx_14_0_arm64",
                    "macosx_10_9_universal2"),
}
#: What the extension does with the machine, as the manifest declares it.
PERMISSIONS = {"files": "Reads the image a material is made from"}


def this_platform() -> str:
    """Blender's name for the platform this runs on (``linux-x64``, ``windows-x64``, ``macos-arm64``...)."""
    system = {"darwin": "macos"}.get(platform.system().lower(), platform.system().lower())
    machine = platform.machine().lower()
    machine = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64"}.get(machine, machine)
    return f"{system}-{machine}"


def check_platforms(platforms) -> tuple[str, ...]:
    """``platforms`` (None: this machine's; a name or a sequence of names) as a tuple of known names.

    >>> check_platforms(["windows-x64", "linux-x64", "windows-x64"])
    ('windows-x64', 'linux-x64')
    >>> check_platforms("linux-386")
    Traceback (most recent call last):
    ...
    warp_texton.core.errors.TextonError: platforms: linux-386; Blender platforms with wheels of the package's dependencies are linux-x64, windows-x64, macos-arm64
    """
    if platforms is None:
        platforms = (this_platform(),)
    elif isinstance(platforms, str):
        platforms = (platforms,)
    names = tuple(dict.fromkeys(platforms))
    unknown = [p for p in names if p not in PLATFORMS]
    if unknown or not names:
        raise TextonError(f"platforms: {', '.join(map(str, unknown)) or 'none given'}; Blender platforms with "
                          f"wheels of the package's dependencies are {', '.join(PLATFORMS)}", param="platforms")
    return names


def _toml(value) -> str:
    """A TOML value: strings (JSON's escapes are TOML's basic-string escapes) and lists of them."""
    if isinstance(value, str):
        return json.dumps(value)
    return "[" + ", ".join(_toml(v) for v in value) + "]"


def manifest_text(platforms: Sequence[str], wheels: Sequence[str], version: str = __version__) -> str:
    """``blender_manifest.toml`` of the extension: every required field of schema 1.0.0, the
    ``platforms`` it was built for, its ``wheels`` (paths inside the zip) and its permissions.

    >>> import tomllib
    >>> m = tomllib.loads(manifest_text(["linux-x64"], ["./wheels/tqdm-4.70.1-py3-none-any.whl"]))
    >>> m["schema_version"], m["id"], m["type"], m["platforms"], sorted(m["permissions"])
    ('1.0.0', 'warp_texton', 'add-on', ['linux-x64'], ['files'])
    """
    fields = {
        "schema_version": "1.0.0",
        "id": EXTENSION_ID,
        "version": version,
        "name": "Warp Texton",
        "tagline": "Materials from a photograph: texton noise or tiling",
        "maintainer": "warp-texton developers",
        "type": "add-on",
        "tags": ["Material"],
        "blender_version_min": BLENDER_MIN,
        "license": ["SPDX:MIT"],
        "platforms": list(platforms),
        "wheels": list(wheels),
    }
    lines = ["# Made by warp-texton's `warp-texton blender-extension`; Blender's extension manifest."]
    lines += [f"{k} = {_toml(v)}" for k, v in fields.items()]
    lines += ["", "[permissions]"] + [f"{k} = {_toml(v)}" for k, v in PERMISSIONS.items()]
    return "\n".join(lines) + "\n"
