"""The README and docs/*.md show real runs: every command they show is run, and what it prints is
compared with what they show (README.md and docs/reasoning.md: every command; docs/model.md and
docs/evaluation.md: every command that shows output, tools.doc_examples.SHOWN_ONLY).

* A ```text (or ```console) block holds a session: lines starting with ``$ `` are commands (a trailing ``\\``
  continues one), the lines after a command up to the next are what it prints (stdout and stderr
  together, as on a terminal without progress bars).  A command whose shown output has a line
  ``...`` shows some of its lines: they must appear, in order, among what it prints (``...`` stands for
  the rest); any other command must print exactly the lines shown.
* A ```sh block of ``refimpl ...`` lines (no ``[...]`` placeholders) is run, its output not shown.
* Timings (``30.9 ms``, ``"solve_ms": 8.967``) are the only thing not compared.

Each document runs in a fresh folder laid out as the documents assume (``data/`` of this
checkout, ``docs/`` for the pictures, ``../shared`` beside it), commands in document order, so a
later command reads the files an earlier one wrote.  When the tracker or the model changes,
these tests fail until the documents are regenerated (run the commands, paste what they print).
"""

from __future__ import annotations

import pytest

from tools.doc_examples import REPO, _normal, _run, _workspace, examples, runnable


def test_the_parser_finds_the_examples():
    # the README shows at least solve, track, eval, query, explain, plot and diff, each with output
    found = examples(REPO / "README.md")
    words = {e.command.split()[1] for e in found if e.command.startswith("refimpl ")}
    assert {"solve", "track", "eval", "query", "explain", "plot", "diff"} <= words
    assert sum(e.shown is not None and len(e.shown) > 0 for e in found) >= 8
    # a continued command is one command
    track = next(e for e in found if e.command.startswith("refimpl track"))
    assert "--scene 0011.scene.json" in track.command and "\\" not in track.command
    # every $ line can be pasted: no prose after a command (an excerpt is marked by a "..." line)
    solve = next(e for e in found if e.command.startswith("refimpl solve"))
    assert solve.excerpt and solve.command == "refimpl solve data/examples/bus_t235.lp --backend clingo"
    for doc in ("README.md", "docs/reasoning.md"):
        assert not [e.command for e in examples(REPO / doc) if "excerpt" in e.command]


def test_every_session_with_output_in_the_documents_is_run():
    # issue 41: docs/model.md's worked examples (section 4: every `refimpl solve` of the example
    # frames; section 6: diff) went stale with only one cost vector tested; every document with a
    # `$ refimpl` command that shows output is now among the tested ones
    tested = {"README.md", "docs/reasoning.md", "docs/model.md", "docs/evaluation.md"}
    for doc in sorted((REPO / "docs").glob("*.md")):
        name = str(doc.relative_to(REPO))
        shows = [e for e in examples(doc) if e.shown and e.command.startswith("refimpl ")]
        assert not shows or name in tested, f"{name} shows refimpl output no test runs"
    solves = [e.command for e in runnable("docs/model.md") if e.command.startswith("refimpl solve")]
    # 4.1-4.3: cpsat and clingo on three frames, 4.3's --const run, 4.4's cpsat-full run
    assert len(solves) == 8 and sum("kitti_0020_t79" in c for c in solves) == 3


@pytest.mark.parametrize("doc", ["README.md", "docs/reasoning.md", "docs/model.md", "docs/evaluation.md"])
def test_every_example_prints_what_the_document_shows(doc, shared_data, tmp_path):
    work = _workspace(tmp_path, shared_data, doc)
    wrong = []
    for ex in runnable(doc):
        printed = _normal(_run(ex.command, work)).splitlines()
        if ex.shown is None:
            continue
        shown = [_normal(line) for line in ex.shown]
        if ex.excerpt:
            wanted = [line for line in shown if line.strip() != "..."]
            it = iter(printed)
            if not all(any(line == got for got in it) for line in wanted):
                wrong.append(f"{doc}:{ex.line}: $ {ex.command}\n  shows (excerpt) {wanted}\n  prints {printed}")
        elif printed != shown:
            wrong.append(f"{doc}:{ex.line}: $ {ex.command}\n  shows  {shown}\n  prints {printed}")
    assert not wrong, "\n".join(wrong)
