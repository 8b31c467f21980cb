"""refimpl: online visual abduction for multi-object tracking, as an ASP model and an equivalent CP-SAT model.

``refimpl.Tracker`` is the library interface (refimpl.api): ``Tracker().update(dets) -> tracks``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .core.loader import load

__version__ = "0.1.0"
__all__ = ["Tracker", "__version__"]

if TYPE_CHECKING:
    from .api import Tracker


_LAZY = {"Tracker": "refimpl.api:Tracker"}
"""Public names loaded on first use (refimpl.core.loader), so that `import refimpl` (and the CLI's
start) stays light: the library interface imports the whole tracking path."""


def __getattr__(name: str):
    if name in _LAZY:
        return load(_LAZY[name])
    raise AttributeError(f"module 'refimpl' has no attribute {name!r}")
