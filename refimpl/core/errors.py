"""The one base of the errors the `refimpl` command reports as one line with exit code 2.

A user's mistake (an argument, a file, a name out of a registry) and a problem without an answer
(no admissible hypothesis, out of time without one) are raised by the layer that finds them, as an
exception of that layer (``refimpl.io.InputFormatError``, ``refimpl.scene.SceneError``, ...) deriving
from :class:`UserFacingError` as well as from its usual builtin (``ValueError``, ``RuntimeError``).  The
command line catches this base (refimpl.cli), so it need not import every layer that may raise one.
"""

from __future__ import annotations


class UserFacingError(Exception):
    """An error whose message is the whole report: one line, exit code 2 from the command line."""
