"""The memory budget: how much memory one call may ask for.

Every function that allocates in proportion to its arguments (rasters, impact
buffers, batches, textons read from files, renders) estimates its peak
allocation before allocating and refuses with a :class:`TextonError` naming the
estimate, the budget and what to change, rather than failing half-way or
swapping. The budget is ``WARP_TEXTON_MEMORY_BUDGET`` (bytes, or with a unit:
``512M``, ``8G``, ``1.5T``) when set, else half of the machine's physical
memory; :func:`set_memory_budget` changes it for the running process.
"""

from __future__ import annotations

import math
import os
import re

from .errors import TextonError

#: The environment variable that sets the budget.
BUDGET_ENV = "WARP_TEXTON_MEMORY_BUDGET"
#: Used when the physical memory cannot be read.
FALLBACK_BUDGET = 4 << 30
_UNITS = {"": 1, "B": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
_override: int | None = None


def parse_bytes(text: str, name: str = BUDGET_ENV) -> int:
    """``"8G"`` → 8·2³⁰: a positive size in bytes, with an optional unit K, M, G or T (powers of 1024).

    >>> parse_bytes("512M")
    536870912
    """
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([KMGT]?)(?:I?B)?\s*", str(text), re.IGNORECASE)
    if not m:
        raise TextonError(f"{name}: {text!r} is not a size; use bytes or a number with K, M, G or T, e.g. 8G")
    value = float(m.group(1)) * _UNITS[m.group(2).upper()]
    if not math.isfinite(value) or value < 1:
        raise TextonError(f"{name}: {text!r} must be at least 1 byte")
    return int(value)


def physical_memory() -> int | None:
    """The machine's physical memory in bytes, or None where it cannot be read."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None


def memory_budget() -> int:
    """The budget in bytes: :func:`set_memory_budget`'s value, else the environment
    variable, else half of the physical memory."""
    if _override is not None:
        return _override
    env = os.environ.get(BUDGET_ENV)
    if env:
        return parse_bytes(env)
    total = physical_memory()
    return total // 2 if total else FALLBACK_BUDGET


def set_memory_budget(nbytes) -> None:
    """Set the budget for this process (bytes, or a size string such as ``"2G"``);
    ``None`` goes back to the environment variable or the default."""
    global _override
    if nbytes is None:
        _override = None
    elif isinstance(nbytes, str):
        _override = parse_bytes(nbytes, "memory budget")
    elif isinstance(nbytes, bool) or not isinstance(nbytes, (int, float)) or not nbytes >= 1:
        raise TextonError(f"memory budget must be a number of bytes >= 1 or a size such as '2G', got {nbytes!r}")
    else:
        _override = int(nbytes)


def format_bytes(n: float) -> str:
    """``3.2 GiB``-style sizes for messages."""
    for unit, size in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{int(n)} bytes"


def check_memory(nbytes: float, what: str, hint: str) -> None:
    """Refuse work whose peak allocation ``nbytes`` exceeds the budget.

    ``what`` names the request (``"a 16384x16384 raster at MNI 16000"``),
    ``hint`` says what to change (``"use a lower mni or a smaller raster"``).
    """
    budget = memory_budget()
    if not nbytes <= budget:  # NaN and inf are refused too
        size = format_bytes(nbytes) if math.isfinite(nbytes) else "an unbounded amount of memory"
        raise TextonError(
            f"{what} needs about {size}, over the memory budget of {format_bytes(budget)}; "
            f"{hint} (or raise the budget with {BUDGET_ENV}, e.g. {BUDGET_ENV}=16G)"
        )
