"""The ground floor: errors, budgets, argument checks and Warp's start-up.

``errors`` (:class:`TextonError`), ``limits`` (memory and work budgets, cancellation),
``checks`` (argument checks that name the argument), ``runtime`` (Warp start-up, devices,
the CPU thread split). Imports nothing else of the package.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .lazy import lazy_names

if TYPE_CHECKING:
    from .errors import TextonError, ExampleWarning
    from .limits import memory_budget, set_memory_budget, work_budget, set_work_budget, scoped_budget, check_memory, check_work, Cancelled, cancellable, checkpoint
    from .runtime import resolve_device

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "TextonError": "errors",
    "ExampleWarning": "errors",
    "memory_budget": "limits",
    "set_memory_budget": "limits",
    "work_budget": "limits",
    "set_work_budget": "limits",
    "scoped_budget": "limits",
    "check_memory": "limits",
    "check_work": "limits",
    "Cancelled": "limits",
    "cancellable": "limits",
    "checkpoint": "limits",
    "resolve_device": "runtime",
}

__all__ = ["Cancelled", "ExampleWarning", "TextonError", "cancellable", "check_memory", "check_work", "checkpoint", "memory_budget", "resolve_device", "scoped_budget", "set_memory_budget", "set_work_budget", "work_budget"]


__getattr__, __dir__ = lazy_names(__name__, _LAZY)
