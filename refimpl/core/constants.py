"""Model constants: defaults read from model/constants.lp, overridden by a problem's #const facts.

Both backends take their numbers from here, so a threshold means the same in ASP and CP-SAT.
"""

from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path
from typing import Mapping

from .spec import FrameProblem, ProblemFormatError

_CONST_LINE = re.compile(r"^\s*#const\s+([a-z_][A-Za-z0-9_]*)\s*=\s*(-?\d+)\s*\.")


def model_dir() -> Path:
    """The folder holding the ASP encoding (model/*.lp), from a checkout or an installed package."""
    package = Path(__file__).resolve().parents[1]  # refimpl/
    checkout = package.parent / "model"
    if (checkout / "constants.lp").is_file():
        return checkout
    # an installed package holds model/ as refimpl/model/ (pyproject: package-dir refimpl.model)
    return package / "model"


@lru_cache(maxsize=1)
def default_constants() -> Mapping[str, int]:
    """The #const defaults of model/constants.lp, in file order."""
    out: dict[str, int] = {}
    text = (model_dir() / "constants.lp").read_text(encoding="utf-8")
    for line in text.splitlines():
        m = _CONST_LINE.match(line)
        if m:
            out[m.group(1)] = int(m.group(2))
    return out


def resolve_constants(problem: FrameProblem, overrides: Mapping[str, int] | None = None) -> dict[str, int]:
    """Defaults, then the problem's #const values, then explicit overrides; unknown names are an error."""
    merged = dict(default_constants())
    for source in (dict(problem.constants), dict(overrides or {})):
        for name, value in source.items():
            if name not in merged:
                known = ", ".join(sorted(merged))
                raise ProblemFormatError(f"unknown constant {name!r} (known: {known})")
            merged[name] = int(value)
    merged["curr_time"] = problem.time
    return merged
