"""The budgets: how much memory and how much work one call may ask for.

Memory. Every function that allocates in proportion to its arguments (rasters,
impact buffers, batches, textons read from files, renders) estimates its peak
allocation before allocating and refuses with a :class:`TextonError` naming the
estimate, the budget and what to change, rather than failing half-way or
swapping. The budget is ``WARP_TEXTON_MEMORY_BUDGET`` (bytes, or with a unit:
``512M``, ``8G``, ``1.5T``) when set, else half of the machine's physical
memory; :func:`set_memory_budget` changes it for the running process.

Work. The same way, every function whose running time grows with its
arguments (MNI × pixels, analysis iterations × FFT size, mixing steps,
supersamples...) estimates the number of elementary *operations* it will do
and refuses beyond ``WARP_TEXTON_WORK_BUDGET`` (a count: ``1e12``, or with a
unit K, M, G, T as powers of 1000), default :data:`DEFAULT_WORK_BUDGET`;
:func:`set_work_budget` changes it. An operation is one impact visited by a
noise evaluation (its position drawn and its texton looked up) or one element
of one FFT pass (a transform of n values counts n log2 n). The estimates are
within a small factor of the real counts; docs/limits.md gives the formulas
and what the default means in seconds.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import threading
from collections.abc import Iterator

from .errors import OverBudget, TextonError

#: The environment variable that sets the budget.
BUDGET_ENV = "WARP_TEXTON_MEMORY_BUDGET"
#: Used when the physical memory cannot be read.
FALLBACK_BUDGET = 4 << 30
_UNITS = {"": 1, "B": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
_override: int | None = None
#: The environment variable that sets the work budget.
WORK_ENV = "WARP_TEXTON_WORK_BUDGET"
#: Default work budget, operations: about a minute of CPU-bound work on one
#: core of a 2020s CPU for the noise's point paths, seconds for its rasters on
#: a few cores, well under a second on a GPU (docs/limits.md).
DEFAULT_WORK_BUDGET = 1.0e11
_COUNT_UNITS = {"": 1.0, "K": 1e3, "M": 1e6, "G": 1e9, "T": 1e12}
_work_override: float | None = None


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
    scoped = getattr(_scope, "memory", None)
    if scoped is not None:
        return scoped
    return _global_memory_budget()


def _global_memory_budget() -> int:
    if _override is not None:
        return _override
    env = os.environ.get(BUDGET_ENV)
    if env:
        return parse_bytes(env)
    total = physical_memory()
    return total // 2 if total else FALLBACK_BUDGET


def set_memory_budget(nbytes) -> None:
    """Set the budget for this process (bytes, or a size string such as ``"2G"``);
    ``None`` goes back to the environment variable or the default.

    Examples
    --------
    >>> from warp_texton import Texton, TextonError, synthesize
    >>> from warp_texton.core.limits import set_memory_budget
    >>> try:
    ...     set_memory_budget("1M")
    ...     synthesize(Texton([[0.1, 0.2], [0.3, 0.4]], [0.5]), (1024, 1024), device="cpu")
    ... except TextonError as exc:
    ...     print("over the memory budget of 1 MiB" in str(exc))
    ... finally:
    ...     set_memory_budget(None)
    True
    """
    global _override
    if nbytes is None:
        _override = None
    elif isinstance(nbytes, str):
        _override = parse_bytes(nbytes, "memory budget")
    elif isinstance(nbytes, bool) or not isinstance(nbytes, (int, float)) or not nbytes >= 1 \
            or not math.isfinite(nbytes):
        raise TextonError(f"memory budget must be a finite number of bytes >= 1 or a size such as '2G', "
                          f"got {nbytes!r:.60}")
    else:
        _override = int(nbytes)


def format_bytes(n: float) -> str:
    """``3.2 GiB``-style sizes for messages."""
    for unit, size in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{int(n)} bytes"


def check_memory(nbytes: float, what: str, hint: str, *, param: str | None = None,
                 mentions: tuple[str, ...] = ()) -> None:
    """Refuse work whose peak allocation ``nbytes`` exceeds the budget.

    ``what`` names the request (``"a 16384x16384 raster at MNI 16000"``),
    ``hint`` says what to change (``"use a lower mni or a smaller raster"``);
    ``param`` and ``mentions`` name the arguments the two speak of (``mentions=("mni",)``),
    as :class:`TextonError` carries them.
    """
    budget = memory_budget()
    if not nbytes <= budget:  # NaN and inf are refused too
        size = format_bytes(nbytes) if math.isfinite(nbytes) else "an unbounded amount of memory"
        example = f"{math.ceil(nbytes / (1 << 30))}G" if math.isfinite(nbytes) else "16G"
        raise OverBudget(
            f"{what} needs about {size}, over the memory budget of {format_bytes(budget)}; "
            f"{hint} (or raise the budget with {BUDGET_ENV}, e.g. {BUDGET_ENV}={example})",
            param, mentions=mentions,
        )


# ------------------------------------------------------------------- work
def parse_count(text: str, name: str = WORK_ENV) -> float:
    """``"2e11"``, ``"200G"`` → 2·10¹¹: a positive count, with an optional unit K, M, G or T
    (powers of 1000).

    >>> parse_count("5G")
    5000000000.0
    """
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([KMGT]?)\s*", str(text), re.IGNORECASE)
    if not m:
        raise TextonError(f"{name}: {text!r} is not a count; use a number such as 1e12, or one with K, M, G or T")
    value = float(m.group(1)) * _COUNT_UNITS[m.group(2).upper()]
    if not math.isfinite(value) or value < 1:
        raise TextonError(f"{name}: {text!r} must be at least 1")
    return value


def work_budget() -> float:
    """The work budget in operations: :func:`set_work_budget`'s value, else the
    environment variable, else :data:`DEFAULT_WORK_BUDGET`."""
    scoped = getattr(_scope, "work", None)
    if scoped is not None:
        return scoped
    return _global_work_budget()


def _global_work_budget() -> float:
    if _work_override is not None:
        return _work_override
    env = os.environ.get(WORK_ENV)
    return parse_count(env) if env else DEFAULT_WORK_BUDGET


def set_work_budget(operations) -> None:
    """Set the work budget for this process (a count, or a string such as ``"1T"``);
    ``None`` goes back to the environment variable or the default."""
    global _work_override
    if operations is None:
        _work_override = None
    elif isinstance(operations, str):
        _work_override = parse_count(operations, "work budget")
    elif isinstance(operations, bool) or not isinstance(operations, (int, float)) or not operations >= 1 \
            or not math.isfinite(operations):
        raise TextonError(f"work budget must be a finite number of operations >= 1 or a count such as '1T', "
                          f"got {operations!r}")
    else:
        _work_override = float(operations)


_log = threading.local()
# per-thread budgets and cancellation (a server's requests): see scoped_budget, cancellable
_scope = threading.local()


@contextlib.contextmanager
def scoped_budget(memory: float | None = None, work: float | None = None) -> Iterator[None]:
    """Lower the budgets for the calls this thread makes inside the block (to at
    most the process's): a server gives each request its share, so that the same
    estimates that guard a call guard the request, and the requests of all its
    slots together fit the process's budget."""
    saved = getattr(_scope, "memory", None), getattr(_scope, "work", None)
    if memory is not None:
        _scope.memory = int(min(memory, memory_budget()))
    if work is not None:
        _scope.work = float(min(work, work_budget()))
    try:
        yield
    finally:
        _scope.memory, _scope.work = saved


class Cancelled(Exception):
    """The caller of a computation no longer wants it (see :func:`cancellable`)."""


@contextlib.contextmanager
def cancellable(wanted) -> Iterator[None]:
    """Inside the block, :func:`checkpoint` (called between the strips of long
    computations) raises :class:`Cancelled` once ``wanted()`` returns False."""
    saved = getattr(_scope, "wanted", None)
    _scope.wanted = wanted
    try:
        yield
    finally:
        _scope.wanted = saved


def checkpoint() -> None:
    """Stop this thread's computation here if its caller has gone (:func:`cancellable`)."""
    wanted = getattr(_scope, "wanted", None)
    if wanted is not None and not wanted():
        raise Cancelled()


@contextlib.contextmanager
def work_log() -> Iterator[list[tuple[str, float]]]:
    """Collect the work estimates that calls in this thread check: yields a list
    that receives ``(what, operations)`` for each :func:`check_work`, accepted
    or not (the benchmarks compare them with measured times).

    >>> from warp_texton import Texton, synthesize
    >>> with work_log() as log:
    ...     _ = synthesize(Texton([[0.1, 0.2], [0.3, 0.4]], [0.5]), (4, 4), device="cpu")
    >>> log[0][0], log[0][1] > 0
    ('a 4x4 raster at MNI 30', True)
    """
    outer = getattr(_log, "entries", None)
    entries: list[tuple[str, float]] = []
    _log.entries = entries
    try:
        yield entries
    finally:
        _log.entries = outer


def check_work(operations: float, what: str, hint: str, *, param: str | None = None,
               mentions: tuple[str, ...] = (), early: bool = False) -> None:
    """Refuse a request whose estimated work exceeds the work budget.

    ``what`` names the request (``"a 4096x4096 raster at MNI 30000"``), ``hint``
    says what to change (``"use a lower mni or a smaller raster"``); ``param``
    and ``mentions`` as for :func:`check_memory`. ``early``: a first estimate made
    before the work's setup, which a later check of the same request refines: it
    goes to :func:`work_log` only when it refuses.
    """
    entries = getattr(_log, "entries", None)
    if early and operations <= work_budget():
        return
    if entries is not None:
        entries.append((what, float(operations)))
    budget = work_budget()
    if not operations <= budget:  # NaN and inf are refused too
        size = f"{operations:.3g}" if math.isfinite(operations) else "an unbounded number of"
        example = f"1e{math.ceil(math.log10(operations))}" if math.isfinite(operations) else "1e13"
        raise OverBudget(
            f"{what} needs about {size} operations, over the work budget of {budget:.3g}; "
            f"{hint} (or raise the budget with {WORK_ENV}, e.g. {WORK_ENV}={example})",
            param, mentions=mentions,
        )
