"""refimpl: online visual abduction for multi-object tracking, as an ASP model and an equivalent CP-SAT model.

``refimpl.Tracker`` is the library interface (refimpl.api): ``Tracker().update(dets) -> tracks``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

__version__ = "0.1.0"
__all__ = ["Tracker", "__version__"]

if TYPE_CHECKING:
    from .api import Tracker


def __getattr__(name: str):
    # imported on first use, so that `import refimpl` (and the CLI's start) stays light
    if name == "Tracker":
        from .api import Tracker
        return Tracker
    raise AttributeError(f"module 'refimpl' has no attribute {name!r}")
