"""Model constants: defaults read from model/constants.lp (and the events' costs from
model/events.lp), overridden by a problem's #const facts.

Both backends take their numbers from here, so a threshold means the same in ASP and CP-SAT.
"""

from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path
from typing import Mapping

from .spec import FrameProblem, ProblemFormatError

CONSTANT_FILES = ("constants.lp", "events.lp")
"""The files of model/ holding #const defaults."""
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
    """The #const defaults of the encoding, in file order: model/constants.lp, then the events'
    costs, which stand beside each event in model/events.lp (cost_<event>)."""
    out: dict[str, int] = {}
    for name in CONSTANT_FILES:
        text = (model_dir() / name).read_text(encoding="utf-8")
        for line in text.splitlines():
            m = _CONST_LINE.match(line)
            if m:
                if m.group(1) in out:
                    raise ValueError(f"model constant {m.group(1)} is defined twice in {', '.join(CONSTANT_FILES)}")
                out[m.group(1)] = int(m.group(2))
    return out


def resolve_constants(problem: FrameProblem, overrides: Mapping[str, int] | None = None) -> dict[str, int]:
    """Defaults, then the problem's #const values, then explicit overrides; unknown names are an error.
    A fresh dict on every call (the callers may change it)."""
    merged = dict(_base(problem.constants))  # a tracker's constants: the same every frame, merged once
    _override(merged, (overrides or {}).items())
    merged["curr_time"] = problem.time
    return merged


def _override(merged: dict[str, int], items) -> None:
    """Set each (name, value) in turn; a name that is not a model constant is an error."""
    for name, value in items:
        if name not in merged:
            known = ", ".join(sorted(merged))
            raise ProblemFormatError(f"unknown constant {name!r} (known: {known})")
        merged[name] = int(value)


def _base(constants) -> Mapping[str, int]:
    try:
        hash(constants)
    except TypeError:  # not a tuple of pairs (a list, say): merged without the memo
        return _merged.__wrapped__(constants)
    return _merged(constants)


@lru_cache(maxsize=256)
def _merged(constants: tuple[tuple[str, int], ...]) -> Mapping[str, int]:
    """The defaults with these #const values (memoised; callers copy it)."""
    merged = dict(default_constants())
    _override(merged, constants)
    return merged
