"""Text shown to a person, on a terminal or in a page: the control characters of a string written
out so that they show instead of acting.

A scene file's track ids, types and sequence name, a path, a message naming one of them: strings
anyone may have written.  Printed raw, ``\\x1b[2J`` clears the terminal, ``\\x1b]0;...\\x07`` sets
its title, ``\\r`` writes over the line, ``\\x9b`` starts a control sequence on some terminals and
U+202E shows what follows backwards.  :func:`visible` writes each such character as a Python
string literal writes it (``\\x1b``, ``\\r``, ``\\x9b``, ``\\u202e``) and leaves every other
character as it is (a backslash too: the text is for reading, not for reading back).
"""

from __future__ import annotations

import unicodedata

_BIDI = (*range(0x202A, 0x202F), *range(0x2066, 0x206A))
"""The bidirectional embeddings, overrides and isolates (LRE .. RLO, LRI .. PDI)."""
_SEPARATORS = (0x2028, 0x2029)
"""Unicode's line and paragraph separators: line breaks to ``str.splitlines`` and to some terminals."""

_ESCAPES = {cp: repr(chr(cp))[1:-1] for cp in (*range(0xA0), *_BIDI, *_SEPARATORS)
            if cp in _BIDI or cp in _SEPARATORS or unicodedata.category(chr(cp)) == "Cc"}
"""Code point -> its escape: C0 (newline and tab too), DEL, C1, the bidirectional controls and the
two separators."""


def visible(text: str) -> str:
    """``text`` with every control character escaped, newlines too: one line, as a message is."""
    return text.translate(_ESCAPES)
