"""Run as a script (``python tests/tools/NAME.py``), a tool imports this first: it puts this
checkout on the import path (its refimpl, and tests/tools as the package ``tools``)."""

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
for _path in (REPO, REPO / "tests"):
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))
