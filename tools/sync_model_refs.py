"""Rewrite the `file.lp:N,...` citations of docs/model.md's rule tables from the `% [label]`
comments of model/*.lp, after the encoding moved lines.  tests/test_docs.py checks the same
citations; this keeps them right without counting lines by hand.

    python tools/sync_model_refs.py          # rewrite docs/model.md in place, print what changed
    python tools/sync_model_refs.py --check  # exit 1 if a citation is stale or a label has no row
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DOC = REPO / "docs" / "model.md"
LABEL = re.compile(r"%\s*\[([A-Za-z0-9_]+)\]")
ROW = re.compile(r"^\| `([A-Za-z0-9_]+)` \| `([a-z_]+\.lp):[\d,]+` \|")


def labels() -> dict[str, tuple[str, list[int]]]:
    """label -> (file name, line numbers) of its `% [label]` comments (one file per label)."""
    out: dict[str, tuple[str, list[int]]] = {}
    for path in sorted((REPO / "model").glob("*.lp")):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for m in LABEL.finditer(line):
                out.setdefault(m.group(1), (path.name, []))[1].append(n)
    return out


def main(argv: list[str]) -> int:
    check = "--check" in argv
    found = labels()
    lines = DOC.read_text(encoding="utf-8").splitlines(keepends=True)
    changed, seen = [], set()
    for i, line in enumerate(lines):
        m = ROW.match(line)
        if not m or m.group(1) not in found:
            continue
        name, (lp, numbers) = m.group(1), found[m.group(1)]
        seen.add(name)
        new = line.replace(m.group(0), f"| `{name}` | `{lp}:{','.join(map(str, numbers))}` |", 1)
        if new != line:
            changed.append(f"{name}: {m.group(2)} -> {lp}:{','.join(map(str, numbers))}")
            lines[i] = new
    missing = sorted(set(found) - seen)
    for c in changed:
        print(c)
    for name in missing:
        print(f"no row for label {name}", file=sys.stderr)
    if check:
        return 1 if changed or missing else 0
    if changed:
        DOC.write_text("".join(lines), encoding="utf-8")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
