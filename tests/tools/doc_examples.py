"""The documents' examples (README.md, docs/*.md): parse them, run them, and regenerate what they show.

    python tests/tools/doc_examples.py README.md [docs/reasoning.md docs/model.md ...] [--data ../shared/data]

rewrites each document's ```text blocks with what their commands print now (timings as printed);
tests/test_doc_examples.py runs the same commands and fails while a document shows anything else.
What counts as an example is said in that test's docstring.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
FENCE = re.compile(r"^\s*```(\w*)\s*$")
TIMING = [(re.compile(r"\d+(\.\d+)? ms\b"), "<t> ms"), (re.compile(r'"solve_ms": [0-9.]+'), '"solve_ms": <t>')]
ELLIPSIS = "..."
"""A line of shown output that stands for lines left out: the command's output is an excerpt (every
``$`` line stays a command a reader can paste; the document says in prose what is left out)."""
FILES = {"docs/reasoning.md": {"bad.json": '{"format": "refimpl-scene", "version": 1}\n'}}
"""Input files a document describes in prose rather than makes with a command."""
SESSIONS = ("text", "console")
"""The fences of a block that holds a session (``$`` commands and what they print)."""
SHOWN_ONLY = {"docs/model.md", "docs/evaluation.md"}
"""Documents of which only the commands that show output are run: their ```sh blocks name long
runs (a whole benchmark's diff) that the text describes rather than shows."""
HALT_CHOICE = """1 { occurs_at(hides_behind(Trk, Trk2), curr_time) : can_occur(hides_behind(Trk, Trk2));
    occurs_at(missing_detections(Trk), curr_time) } 1 :- halt(Trk)."""
"""model/events.lp's [explain_halt], which docs/model.md 6's ``nohide`` copy replaces."""


@dataclass(frozen=True)
class Example:
    line: int
    command: str
    shown: tuple[str, ...] | None
    """What the document shows it printing; None: not shown (a ```sh block)."""
    excerpt: bool = False


def examples(doc: Path) -> list[Example]:
    """Every runnable command of a document, in order, with what it shows."""
    out: list[Example] = []
    lang, block = None, []
    for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
        m = FENCE.match(line)
        if m and lang is None:
            lang, block = m.group(1) or "plain", []
            continue
        if m:
            out += _block(lang, block)
            lang = None
            continue
        if lang is not None:
            block.append((n, line))
    return out


def _block(lang: str, lines: list[tuple[int, str]]) -> list[Example]:
    found: list[Example] = []
    if lang == "sh":
        for n, line in _joined(lines):
            if line.startswith("refimpl ") and "[" not in line:
                found.append(Example(n, line, None))
        return found
    if lang not in SESSIONS or not any(line.startswith("$ ") for _, line in lines):
        return found
    current: tuple[int, str] | None = None
    shown: list[str] = []
    for n, line in _joined(lines):
        if line.startswith("$ "):
            if current is not None:
                found.append(_example(current, shown))
            current, shown = (n, line[2:]), []
        elif current is not None:
            shown.append(line)
    if current is not None:
        found.append(_example(current, shown))
    return found


def _example(at: tuple[int, str], shown: list[str]) -> Example:
    n, command = at
    while shown and not shown[-1].strip():  # a blank line between two commands is layout
        shown = shown[:-1]
    return Example(n, command, tuple(shown), any(line.strip() == ELLIPSIS for line in shown))


def _joined(lines: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """Lines with their ``\\`` continuations joined (numbered by their first line)."""
    out: list[tuple[int, str]] = []
    pending: tuple[int, str] | None = None
    for n, line in lines:
        if pending is not None:
            pending = (pending[0], pending[1] + " " + line.strip())
        else:
            pending = (n, line)
        if pending[1].endswith("\\"):
            pending = (pending[0], pending[1][:-1].rstrip())
            continue
        out.append(pending)
        pending = None
    if pending is not None:
        out.append(pending)
    return out


def _normal(text: str) -> str:
    for pattern, repl in TIMING:
        text = pattern.sub(repl, text)
    return text.rstrip()


def _workspace(tmp: Path, data: Path, doc: str) -> Path:
    """A folder laid out as the documents assume: ./data (this checkout's), ./docs, ../shared
    (the folder holding the shared ``data``)."""
    root = tmp / "place"
    work = root / "work"
    (work / "docs").mkdir(parents=True)
    (work / "data").symlink_to(REPO / "data")
    (root / "shared").symlink_to(Path(data).resolve().parent)
    for name, text in FILES.get(doc, {}).items():
        (work / name).write_text(text)
    if doc == "docs/model.md":  # section 6's worked example: model/ without hides_behind for a halt
        (work / "nohide").mkdir()
        for lp in sorted((REPO / "model").glob("*.lp")):
            text = lp.read_text(encoding="utf-8")
            if lp.name == "events.lp":
                assert HALT_CHOICE in text, "model/events.lp's [explain_halt] changed: update HALT_CHOICE"
                text = text.replace(HALT_CHOICE, "1 { occurs_at(missing_detections(Trk), curr_time) } 1 :- halt(Trk).")
            (work / "nohide" / lp.name).write_text(text, encoding="utf-8")
    if doc == "docs/evaluation.md":  # "the KITTI Car 0011 results of the README": its track command
        _run("refimpl track --dets ../shared/data/KITTI/tracking/training/det_02_pointrcnn/Car/0011.txt "
             "--format kitti --class Car --out 0011.txt", work)
    return work


def runnable(doc: str) -> list[Example]:
    """The examples of a document the tests run, in order (SHOWN_ONLY: those that show output)."""
    found = examples(REPO / doc)
    return [e for e in found if e.shown is not None] if doc in SHOWN_ONLY else found


def _run(command: str, cwd: Path) -> str:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    env["COLUMNS"] = "200"
    shell = f'refimpl() {{ "{sys.executable}" -m refimpl "$@"; }}\n{command}'
    done = subprocess.run(["bash", "-c", shell], cwd=cwd, env=env, capture_output=True, text=True, timeout=600,
                          stdin=subprocess.DEVNULL)
    return done.stdout + done.stderr


def regenerate(doc: Path, shared: Path, tmp: Path) -> int:
    """Rewrite the output shown under every ``$`` command of a document's ```text blocks (excerpts
    are left as they are); the number of commands rewritten."""
    work = _workspace(tmp, shared, str(doc.relative_to(REPO)))
    printed: dict[int, list[str]] = {}
    for ex in runnable(str(doc.relative_to(REPO))):
        out = _run(ex.command, work).rstrip("\n").splitlines()
        if ex.shown is not None and not ex.excerpt:
            printed[ex.line] = out
    lines = doc.read_text(encoding="utf-8").splitlines()
    out_lines: list[str] = []
    lang: str | None = None
    k = 0
    while k < len(lines):
        line = lines[k]
        m = FENCE.match(line)
        if m:
            lang = (m.group(1) or "plain") if lang is None else None
            out_lines.append(line)
            k += 1
            continue
        out_lines.append(line)
        k += 1
        if lang in SESSIONS and line.startswith("$ ") and k in printed:
            start = k
            while out_lines[-1].endswith("\\"):  # the command's continuation lines
                out_lines.append(lines[k])
                k += 1
            out_lines.extend(printed[start])
            old = []
            while k < len(lines) and not lines[k].startswith("$ ") and not FENCE.match(lines[k]):
                old.append(lines[k])  # the old output
                k += 1
            while old and not old[-1].strip():  # a blank line between two commands stays
                out_lines.append("")
                old.pop()
    doc.write_text("\n".join(out_lines) + "\n", encoding="utf-8")
    return len(printed)


def main() -> int:
    import argparse
    import tempfile
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("docs", nargs="+")
    ap.add_argument("--data", default="../shared/data")
    args = ap.parse_args()
    for name in args.docs:
        with tempfile.TemporaryDirectory() as tmp:
            n = regenerate(REPO / name, Path(args.data).resolve(), Path(tmp))
        print(f"{name}: {n} examples regenerated")
    return 0


if __name__ == "__main__":
    sys.exit(main())
