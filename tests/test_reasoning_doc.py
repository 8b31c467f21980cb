"""docs/reasoning.md says "Every example output below is real": keep one of them honest.

* every `refimpl ...` command in a fenced code block of docs/reasoning.md parses with the CLI's
  parser (parse only);
* every example is re-run end to end and compared with what the doc shows by
  tests/test_doc_examples.py (regenerate with ``python tests/tools/doc_examples.py docs/reasoning.md``).
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from refimpl import cli
from refimpl.cli import COMMANDS, build_parser

REPO = Path(__file__).resolve().parent.parent
DOC = REPO / "docs" / "reasoning.md"
FENCE = re.compile(r"^\s*(```|~~~)")
COMMAND = re.compile(r"^\s*(?:\$\s+)?(?:python3?\s+-m\s+)?refimpl\s+(.*)$")
EXAMPLE = "refimpl query 0011.scene.json hidden_by trk_133"


def _code_blocks() -> list[list[tuple[int, str]]]:
    """The fenced code blocks of the doc, each a list of (line number, line)."""
    blocks, current = [], None
    for n, line in enumerate(DOC.read_text(encoding="utf-8").splitlines(), 1):
        if FENCE.match(line):
            if current is None:
                current = []
            else:
                blocks.append(current)
                current = None
            continue
        if current is not None:
            current.append((n, line))
    return blocks


def _commands() -> list[tuple[int, str]]:
    """(line number, arguments) of every `refimpl ...` line of a code block, continuation lines
    (ending in a backslash) joined; what follows a run of two spaces is a comment of the doc."""
    out = []
    for block in _code_blocks():
        pending: tuple[int, str] | None = None
        for n, line in block:
            if pending is not None:
                line = pending[1] + " " + line.strip()
                n = pending[0]
                pending = None
            m = COMMAND.match(line)
            if not m or m.group(1).split(" ")[0].endswith(":"):   # "refimpl query: error: ..." is output
                continue
            if line.endswith("\\"):
                pending = (n, line[:-1].rstrip())
                continue
            args = re.split(r"\s{2,}\(", m.group(1))[0]          # "situations    (56 lines...)"
            args = args.split(" | ")[0]                          # "... situations | grep X"
            out.append((n, args))
    return out


def _shown_output(command: str) -> list[str]:
    """The lines the doc shows under `$ command`, up to the next `$ ` line or the block's end."""
    for block in _code_blocks():
        lines = [line for _, line in block]
        if f"$ {command}" in lines:
            rest = lines[lines.index(f"$ {command}") + 1:]
            shown = []
            for line in rest:
                if line.startswith("$ "):
                    break
                shown.append(line)
            while shown and not shown[-1].strip():
                shown.pop()
            return shown
    raise AssertionError(f"docs/reasoning.md no longer shows '$ {command}'")


def test_doc_shows_commands():
    # sections 1-7 show track, query (8 forms), explain, occlusion-suite and plot commands
    assert len(_commands()) >= 20


@pytest.mark.parametrize("lineno,args", _commands())
def test_command_parses(lineno, args):
    try:
        ns = build_parser().parse_args(shlex.split(args))
    except SystemExit as exc:  # argparse reports a bad command line by exiting
        pytest.fail(f"docs/reasoning.md:{lineno}: 'refimpl {args}' does not parse (exit {exc.code})")
    assert ns.command in COMMANDS, f"docs/reasoning.md:{lineno}: no command selected"


PINNED_PRESET = ("--no-preset", "--const", "conf_thresh_new_track=80", "--const", "conf_thresh_assign=60", "--const",
                 "iou_thresh=20000", "--const", "conf_thresh_resume=50", "--const", "iou_thresh_resume=10000",
                 "--const", "iou_thresh_occupied=100000", "--const", "leave_visible=100",
                 "--written-box", "detection", "--velocity-noise", "10", "--backfill", "no", "--fill-hidden", "0")
"""The KITTI Car preset the doc's examples were made with, as the doc's command spells it out: on
top of the defaults (--no-preset), so that a later preset's new constant or option cannot change it."""


def test_doc_pins_the_preset_its_examples_were_made_with():
    # both track commands of the doc (0011 and 0007), line continuations removed
    flat = " ".join(DOC.read_text(encoding="utf-8").replace("\\\n", " ").split())
    assert flat.count(" ".join(PINNED_PRESET)) == 2
