"""The caps on what one record of an input may be, and the readers that stop at them.

A line without end (``/dev/zero``, a sparse file of gigabytes without a newline, a pipe that never
writes one) would be read whole by Python's line iteration or ``read()``, growing until the memory
runs out.  Every reader of refimpl's text inputs reads through this module instead: a line is read
with ``readline(limit + 1)`` (at most ``limit + 1`` characters, whatever follows), a file read at
once with ``read(limit + 1)``, and one character beyond the cap is a :class:`RecordTooLong` at once.

The caps are far above anything refimpl reads or writes (docs/robustness.md, "Bounded records"):
a MOTChallenge or KITTI line is under 200 characters, a fact file of a dense frame a few MB, a
scene file of the longest shared sequence (MOT17-04, 1,050 frames) under 20 MB.
"""

from __future__ import annotations

import os
from typing import IO, Iterator

from .errors import UserFacingError

MAX_LINE_CHARS = 10_000
"""Characters of one line of a data file or a pipe (detections, ground truth, results, seqinfo.ini,
a seqmap): 50 times the longest KITTI line."""

MAX_TEXT_CHARS = 256 * 2 ** 20
"""Characters of a file read at once (a fact file, a scene file, an ASP encoding, a benchmark's
JSON): its parse takes several times its size in memory, so 256 Mi characters stay within a few GB."""


class RecordTooLong(ValueError, UserFacingError):
    """A line or a file beyond its cap; ``line`` is the line's number (None for a whole file)."""

    def __init__(self, reason: str, line: int | None = None):
        self.reason, self.line = reason, line
        super().__init__(reason)

    def __reduce__(self):
        return (type(self), (self.reason, self.line))


def bounded_lines(fh: IO[str], limit: int = MAX_LINE_CHARS) -> Iterator[str]:
    """The lines of an open text stream as they arrive, each with its newline (as iterating the
    stream gives them); a line of more than ``limit`` characters (its newline not counted) raises
    RecordTooLong after ``limit + 1`` characters are read, so its memory is bounded and the read
    ends in the time of reading ``limit`` characters."""
    lineno = 0
    while True:
        raw = fh.readline(limit + 1)
        if not raw:
            return
        lineno += 1
        if len(raw) > limit and raw[-1] != "\n":
            raise RecordTooLong(f"line {lineno} is longer than {limit} characters (a data line is a few dozen): "
                                "not a data file?", lineno)
        yield raw


def read_text(path: str | os.PathLike, encoding: str = "utf-8", limit: int = MAX_TEXT_CHARS) -> str:
    """A text file read at once, refused with RecordTooLong beyond ``limit`` characters (after
    reading ``limit + 1`` of them, never the rest); open and decoding errors propagate."""
    with open(path, encoding=encoding) as fh:
        text = fh.read(limit + 1)
    if len(text) > limit:
        raise RecordTooLong(f"longer than {limit} characters: too large for a file read at once (not the file meant?)")
    return text
