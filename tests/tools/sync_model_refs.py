"""Rewrite the `file.lp:N,...` citations of docs/model.md's rule tables from the `% [label]`
comments of model/*.lp, after the encoding moved lines.  tests/test_docs.py checks the same
citations; this keeps them right without counting lines by hand.

    python tests/tools/sync_model_refs.py          # rewrite docs/model.md in place, print what changed
    python tests/tools/sync_model_refs.py --check  # exit 1 if a citation is stale or a label has no row
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "model.md"
LABEL = re.compile(r"%\s*\[([A-Za-z0-9_]+)\]")
ROW = re.compile(r"^\| `([A-Za-z0-9_]+)` \| (`[a-z_]+\.lp:[\d,]+`(?:, `[a-z_]+\.lp:[\d,]+`)*) \|")


def labels() -> dict[str, dict[str, list[int]]]:
    """label -> {file name: line numbers} of its `% [label]` comments (a label may stand in several files)."""
    out: dict[str, dict[str, list[int]]] = {}
    for path in sorted((REPO / "model").glob("*.lp")):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for m in LABEL.finditer(line):
                out.setdefault(m.group(1), {}).setdefault(path.name, []).append(n)
    return out


def citation(places: dict[str, list[int]], order: list[str]) -> str:
    """`file.lp:N,M`, one per file, in the order the row already names them (new files last)."""
    files = [f for f in order if f in places] + sorted(f for f in places if f not in order)
    return ", ".join(f"`{f}:{','.join(map(str, places[f]))}`" for f in files)


def main(argv: list[str]) -> int:
    check = "--check" in argv
    found = labels()
    lines = DOC.read_text(encoding="utf-8").splitlines(keepends=True)
    changed, seen = [], set()
    for i, line in enumerate(lines):
        m = ROW.match(line)
        if not m or m.group(1) not in found:
            continue
        name = m.group(1)
        seen.add(name)
        cited = citation(found[name], re.findall(r"`([a-z_]+\.lp):", m.group(2)))
        new = line.replace(m.group(0), f"| `{name}` | {cited} |", 1)
        if new != line:
            changed.append(f"{name}: {m.group(2)} -> {cited}")
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
