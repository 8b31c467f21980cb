"""Progress bars on stderr (tqdm): never on stdout, so they never mix into result lines.

A bar shows only when stderr is a terminal and the caller did not ask for quiet; otherwise
nothing at all is written (logs and pipes stay clean).  tqdm is imported only for a bar that
shows (importing it costs ~60 ms of every command's start otherwise).
"""

from __future__ import annotations

import sys


class Progress:
    """``step(what)`` once per unit of work (``step(n=k)`` for k units at once); closes itself
    after ``total`` steps (None: not known in advance, e.g. frames arriving on a pipe: a count,
    closed by the caller).  ``describe(what)`` names the work under way without a step (e.g. the
    sequence whose frames are being counted)."""

    def __init__(self, total: int | None, label: str, enabled: bool = True, unit: str = "it"):
        self.total, self.label, self.done = total, label, 0
        self.bar = None  # no bar: step() only counts
        if enabled and _stderr_is_terminal():
            from tqdm import tqdm
            self.bar = tqdm(total=total, desc=label, unit=unit, file=sys.stderr, dynamic_ncols=True, leave=True)

    def step(self, what: str = "", n: int = 1) -> None:
        self.done += n
        if self.bar is not None:
            if what:
                self.bar.set_postfix_str(what, refresh=False)
            self.bar.update(n)
        if self.total is not None and self.done >= self.total:
            self.close()

    def describe(self, what: str) -> None:
        if what and self.bar is not None:
            self.bar.set_postfix_str(what, refresh=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _stderr_is_terminal() -> bool:
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced or closed stderr
        return False
