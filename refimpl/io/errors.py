"""The errors of the file readers: one line naming the file and, where it is about a line, the line."""

from __future__ import annotations

import os

from ..core.errors import UserFacingError


class InputFormatError(ValueError, UserFacingError):
    """A user mistake in an input file; the message is ``"<path>:<line>: <reason>"``."""

    def __init__(self, reason: str, path: str | os.PathLike, line: int | None = None):
        self.reason = reason
        self.path = str(path)
        self.line = line
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {reason}")

    def __reduce__(self):  # keep it picklable (e.g. across a process pool)
        return (type(self), (self.reason, self.path, self.line))


class InputFormatWarning(UserWarning):
    """Rows a reader skipped by documented policy (they are also recorded on the result)."""
