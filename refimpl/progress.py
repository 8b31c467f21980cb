"""Progress bars on stderr (tqdm): never on stdout, so they never mix into result lines.

A bar shows only when stderr is a terminal and the caller did not ask for quiet; otherwise
nothing at all is written (logs and pipes stay clean).
"""

from __future__ import annotations

import sys

from tqdm import tqdm


class Progress:
    """``step(what)`` once per unit of work; closes itself after ``total`` steps (None: not known
    in advance, e.g. frames arriving on a pipe: a count, closed by the caller)."""

    def __init__(self, total: int | None, label: str, enabled: bool = True, unit: str = "it"):
        self.total, self.label, self.done = total, label, 0
        self.bar = tqdm(total=total, desc=label, unit=unit, file=sys.stderr, dynamic_ncols=True,
                        disable=not enabled or not _stderr_is_terminal(), leave=True)

    def step(self, what: str = "") -> None:
        self.done += 1
        if what:
            self.bar.set_postfix_str(what, refresh=False)
        self.bar.update(1)
        if self.total is not None and self.done >= self.total:
            self.close()

    def close(self) -> None:
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
