"""Integers of any size as decimal text and in JSON, both ways.

Python refuses to convert an int of more than ``sys.get_int_max_str_digits()`` decimal digits
(4300 by default) to or from a string: ``str``, ``repr``, f-strings, ``json.dumps`` and
``json.loads`` raise ValueError.  A cost vector's level 0, the canonical tie-break
(refimpl.solvers.common, docs/model.md 3.10), is a sum of powers of two up to the number of
candidate pairs of a component, so a dense 400-track crowd's has thousands of digits.  Every
output that can hold such a number (``solve``, ``diff``, the JSON of an answer, the benchmarks'
JSON) prints it here, and every reader of refimpl's JSON reads numbers here.

No process-wide setting is changed: the conversion splits a large number by a power of ten into
parts below the limit (divide and conquer, so a number of d digits takes O(d^2 / limit) work at
worst, a few milliseconds for 10^5 digits) and joins their texts.
"""

from __future__ import annotations

import json
import math
from typing import Any

_SAFE_DIGITS = 600
"""Digits converted by int/str directly: below the smallest limit Python allows (640)."""

_SAFE_BITS = int(_SAFE_DIGITS * math.log2(10)) - 1
"""An int below 2^_SAFE_BITS has at most _SAFE_DIGITS decimal digits."""


def int_text(n: int) -> str:
    """n in decimal (a minus sign, no leading zeros), whatever its size: what ``str(n)`` prints
    where Python allows it."""
    n = int(n)
    if n < 0:
        return "-" + int_text(-n)
    if n.bit_length() <= _SAFE_BITS:
        return str(n)
    # the low half has k digits (zero-padded); the high half is smaller than n by 10^k
    k = int(n.bit_length() * math.log10(2)) // 2
    high, low = divmod(n, 10 ** k)
    return (int_text(high) if high else "") + int_text(low).rjust(k, "0")


def parse_int(text: str) -> int:
    """The int of a decimal text (an optional sign, then digits), whatever its length: what
    ``int(text)`` gives where Python allows it; ValueError for anything else."""
    s = text.strip()
    sign = 1
    if s[:1] in ("-", "+"):
        sign, s = (-1 if s[0] == "-" else 1), s[1:]
    if not s or not s.isascii() or not s.isdigit():
        raise ValueError(f"not an integer: {text[:40]!r}")
    return sign * _digits(s)


def _digits(s: str) -> int:
    if len(s) <= _SAFE_DIGITS:
        return int(s)
    k = len(s) // 2
    return _digits(s[:-k]) * 10 ** k + _digits(s[-k:])


# ---------------------------------------------------------------------------------------
# JSON: the standard library's text, integers of any size


def dumps(obj: Any, indent: int | None = None, separators: tuple[str, str] | None = None,
          ensure_ascii: bool = True) -> str:
    """``json.dumps(obj, indent=..., separators=...)``, byte for byte, for dicts with str keys,
    lists, tuples, str, int, float, bool and None, with ints of any size (``int_text``)."""
    if separators is None:
        separators = (", ", ": ") if indent is None else (",", ": ")
    item_sep, key_sep = separators
    parts: list[str] = []
    _encode(obj, parts, 0, indent, item_sep, key_sep, ensure_ascii)
    return "".join(parts)


def _encode(obj: Any, out: list[str], level: int, indent: int | None, item_sep: str, key_sep: str,
            ensure_ascii: bool) -> None:
    if obj is True or obj is False or obj is None or isinstance(obj, (str, float)):
        out.append(json.dumps(obj, ensure_ascii=ensure_ascii))
    elif isinstance(obj, int):
        out.append(int_text(obj))
    elif isinstance(obj, (list, tuple, dict)):
        items = list(obj.items()) if isinstance(obj, dict) else list(obj)
        opening, closing = ("{", "}") if isinstance(obj, dict) else ("[", "]")
        if not items:
            out.append(opening + closing)
            return
        inner = "" if indent is None else "\n" + " " * (indent * (level + 1))
        out.append(opening + inner)
        for k, item in enumerate(items):
            if k:
                out.append(item_sep + inner)
            if isinstance(obj, dict):
                key, item = item
                if not isinstance(key, str):
                    raise TypeError(f"JSON keys must be str here, got {type(key).__name__}")
                out.append(json.dumps(key, ensure_ascii=ensure_ascii) + key_sep)
            _encode(item, out, level + 1, indent, item_sep, key_sep, ensure_ascii)
        out.append(("" if indent is None else "\n" + " " * (indent * level)) + closing)
    else:
        raise TypeError(f"Object of type {type(obj).__name__} is not JSON serializable")


def loads(text: str) -> Any:
    """``json.loads(text)`` with integers of any size (``parse_int``)."""
    return json.loads(text, parse_int=parse_int)
