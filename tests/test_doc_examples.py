"""The README and docs/reasoning.md show real runs: every command they show is run, and what it
prints is compared with what they show.

* A ```text block holds a session: lines starting with ``$ `` are commands (a trailing ``\\``
  continues one), the lines after a command up to the next are what it prints (stdout and stderr
  together, as on a terminal without progress bars).  A command annotated ``(... an excerpt)``
  shows some of its lines: they must appear, in order, among what it prints (``...`` stands for
  the rest); any other command must print exactly the lines shown.
* A ```sh block of ``refimpl ...`` lines (no ``[...]`` placeholders) is run, its output not shown.
* Timings (``30.9 ms``, ``"solve_ms": 8.967``) are the only thing not compared.

Each document runs in a fresh folder laid out as the documents assume (``data/`` of this
checkout, ``docs/`` for the pictures, ``../shared`` beside it), commands in document order, so a
later command reads the files an earlier one wrote.  When the tracker or the model changes,
these tests fail until the documents are regenerated (run the commands, paste what they print).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^\s*```(\w*)\s*$")
TIMING = [(re.compile(r"\d+(\.\d+)? ms\b"), "<t> ms"), (re.compile(r'"solve_ms": [0-9.]+'), '"solve_ms": <t>')]
EXCERPT = re.compile(r"\s{2,}\(([^)]*an excerpt[^)]*)\)\s*$")
FILES = {"docs/reasoning.md": {"bad.json": '{"format": "refimpl-scene", "version": 1}\n'}}
"""Input files a document describes in prose rather than makes with a command."""


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
    if lang != "text" or not any(line.startswith("$ ") for _, line in lines):
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
    m = EXCERPT.search(command)
    if m:
        return Example(n, command[:m.start()], tuple(shown), True)
    return Example(n, command, tuple(shown))


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


def _workspace(tmp: Path, shared: Path, doc: str) -> Path:
    """A folder laid out as the documents assume: ./data, ./docs, ../shared."""
    root = tmp / "place"
    work = root / "work"
    (work / "docs").mkdir(parents=True)
    (work / "data").symlink_to(REPO / "data")
    (root / "shared").symlink_to(shared)
    for name, text in FILES.get(doc, {}).items():
        (work / name).write_text(text)
    return work


def _run(command: str, cwd: Path) -> str:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    env["COLUMNS"] = "200"
    shell = f'refimpl() {{ "{sys.executable}" -m refimpl "$@"; }}\n{command}'
    done = subprocess.run(["bash", "-c", shell], cwd=cwd, env=env, capture_output=True, text=True, timeout=600,
                          stdin=subprocess.DEVNULL)
    return done.stdout + done.stderr


def test_the_parser_finds_the_examples():
    # the README shows at least solve, track, eval, query, explain, plot and diff, each with output
    found = examples(REPO / "README.md")
    words = {e.command.split()[1] for e in found if e.command.startswith("refimpl ")}
    assert {"solve", "track", "eval", "query", "explain", "plot", "diff"} <= words
    assert sum(e.shown is not None and len(e.shown) > 0 for e in found) >= 8
    # a continued command is one command
    track = next(e for e in found if e.command.startswith("refimpl track"))
    assert "--scene 0011.scene.json" in track.command and "\\" not in track.command


@pytest.mark.parametrize("doc", ["README.md", "docs/reasoning.md"])
def test_every_example_prints_what_the_document_shows(doc, shared_data, tmp_path):
    work = _workspace(tmp_path, shared_data, doc)
    wrong = []
    for ex in examples(REPO / doc):
        printed = _normal(_run(ex.command, work)).splitlines()
        if ex.shown is None:
            continue
        shown = [_normal(line) for line in ex.shown]
        if ex.excerpt:
            wanted = [line for line in shown if line != "..."]
            it = iter(printed)
            if not all(any(line == got for got in it) for line in wanted):
                wrong.append(f"{doc}:{ex.line}: $ {ex.command}\n  shows (excerpt) {wanted}\n  prints {printed}")
        elif printed != shown:
            wrong.append(f"{doc}:{ex.line}: $ {ex.command}\n  shows  {shown}\n  prints {printed}")
    assert not wrong, "\n".join(wrong)
