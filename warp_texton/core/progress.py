"""Progress bars: when they are drawn, without Warp.

Every bar of the package is a tqdm bar that appears only once its work has run
:data:`PROGRESS_DELAY` seconds, so that short calls print nothing (the
documented rule: docs/cli.md). The command line also draws none when its
standard error is not a terminal (:func:`terminal`), so that logs hold no
escape codes; a Python caller who asks for ``progress=True`` gets a bar
wherever tqdm can draw one (a terminal, a notebook).
"""

from __future__ import annotations

import sys
import threading

#: A progress bar appears once its work has run this many seconds.
PROGRESS_DELAY = 2.0
#: Seconds between two redraws of a :class:`NamedSteps` bar that ticks (``tick=True``).
TICK = 0.5


def terminal() -> bool:
    """Whether standard error is a terminal, where a bar's escape codes belong."""
    isatty = getattr(sys.stderr, "isatty", None)
    try:
        return bool(isatty and isatty())
    except ValueError:  # closed
        return False


def bar(iterable=None, *, total=None, desc: str, unit: str, leave: bool = False):
    """A tqdm bar (``tqdm.auto``: a widget in notebooks) shown after :data:`PROGRESS_DELAY`."""
    from tqdm.auto import tqdm

    return tqdm(iterable, total=total, desc=desc, unit=unit, leave=leave, delay=PROGRESS_DELAY)


class NamedSteps:
    """Named steps of one task on one bar whose total, ``len(names)``, never changes: the
    bar shows the step in progress ("bake: charts") and, for a step done in rounds, the
    rounds done so far after the count ("1/3 [..., 4/9]").

    ``tick``: redraw the bar every :data:`TICK` seconds from a thread of its own until
    :meth:`close`, for steps that are one long call reporting nothing (an image's encoding):
    the bar then appears once it is due, and its clock runs, while such a step runs."""

    def __init__(self, bar, names: list[str], desc: str, *, tick: bool = False):
        self.bar, self.names, self.desc, self.done = bar, list(names), desc, 0
        self._name()
        self._stop = threading.Event()
        self._ticker = None
        if tick:
            self._ticker = threading.Thread(target=self._tick, name=f"{desc} progress", daemon=True)
            self._ticker.start()

    def _tick(self) -> None:
        while not self._stop.wait(TICK):
            if hasattr(self.bar, "miniters"):
                self.bar.miniters = 0  # tqdm redraws on an update of 0 only below its (adaptive) miniters
            self.bar.update(0)  # drawn once the bar is due (its delay), at most every mininterval

    def _name(self) -> None:
        if self.done < len(self.names) and hasattr(self.bar, "set_description_str"):
            self.bar.set_description_str(f"{self.desc}: {self.names[self.done]}", refresh=False)
            self.bar.set_postfix_str("", refresh=False)

    def step(self) -> None:
        """The step in progress is done: count it and name the next."""
        self.done += 1
        self._name()
        self.bar.update(1)

    def round(self, k: int, rounds: int) -> None:
        """Round ``k`` (from 1) of the ``rounds`` of the step in progress is done."""
        if k >= rounds:
            self.step()
        elif hasattr(self.bar, "set_postfix_str"):
            self.bar.set_postfix_str(f"{k}/{rounds}", refresh=False)
            self.bar.update(0)  # drawn when the bar is shown and due

    def close(self) -> None:
        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
        self.bar.close()
