"""docs/model.md stays in step with the ASP model and the command line.

* every `% [label]` of model/*.lp has a row in one of docs/model.md's rule tables (header
  `| label | ASP | ...`, the label in backticks in the row's first cell), and the row's ASP cell
  cites exactly the `file.lp:N` lines that carry that label;
* every `refimpl ...` command shown in a fenced code block of docs/model.md parses with
  refimpl.cli.build_parser() (parse only, nothing runs).
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from refimpl.cli import COMMANDS, build_parser

REPO = Path(__file__).resolve().parent.parent
DOC = REPO / "docs" / "model.md"
MODEL = REPO / "model"

LABEL = re.compile(r"%\s*\[([A-Za-z0-9_]+)\]")
LP_REF = re.compile(r"\b([a-z_]+\.lp):(\d+(?:,\d+)*)")
FENCE = re.compile(r"^\s*(```|~~~)")
COMMAND = re.compile(r"^\s*(?:\$\s+)?(?:python3?\s+-m\s+)?refimpl\s+(.*)$")


def _asp_labels() -> dict[str, set[tuple[str, int]]]:
    """label -> {(file name, line number)} of its `% [label]` comments."""
    out: dict[str, set[tuple[str, int]]] = {}
    for path in sorted(MODEL.glob("*.lp")):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for m in LABEL.finditer(line):
                out.setdefault(m.group(1), set()).add((path.name, n))
    return out


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def _doc_rows() -> dict[str, list[str]]:
    """label -> the rows of docs/model.md's rule tables (header `| label | ASP | ...`) whose first
    cell names it in backticks."""
    rows: dict[str, list[str]] = {}
    in_rule_table = False
    for line in DOC.read_text(encoding="utf-8").splitlines():
        if not line.lstrip().startswith("|"):
            in_rule_table = False
            continue
        cells = _cells(line)
        if cells[:2] == ["label", "ASP"]:
            in_rule_table = True
            continue
        if in_rule_table:
            for label in re.findall(r"`([A-Za-z0-9_]+)`", cells[0]):
                rows.setdefault(label, []).append(line)
    return rows


def _code_block_commands() -> list[tuple[int, str]]:
    """(line number, arguments) of every `refimpl ...` line inside a fenced code block."""
    commands, inside = [], False
    for n, line in enumerate(DOC.read_text(encoding="utf-8").splitlines(), 1):
        if FENCE.match(line):
            inside = not inside
            continue
        if inside:
            m = COMMAND.match(line)
            if m:
                commands.append((n, m.group(1)))
    return commands


def test_model_has_labels():
    labels = _asp_labels()
    assert len(labels) > 40, sorted(labels)  # the grep itself works


def test_every_asp_label_has_a_row():
    rows = _doc_rows()
    missing = sorted(set(_asp_labels()) - set(rows))
    assert not missing, f"labels of model/*.lp without a row in docs/model.md: {missing}"


def test_asp_line_references_point_at_the_label():
    labels = _asp_labels()
    rows = _doc_rows()
    wrong = []
    for label, places in labels.items():
        for row in rows.get(label, []):
            asp_cell = _cells(row)[1]
            cited = {(f, int(n)) for f, ns in LP_REF.findall(asp_cell) for n in ns.split(",")}
            if not cited:
                wrong.append(f"{label}: no file.lp:N reference in its ASP column")
            for f, n in sorted(cited - places):
                wrong.append(f"{label}: {f}:{n} is not a '% [{label}]' line")
            for f, n in sorted(places - cited):
                wrong.append(f"{label}: its '% [{label}]' comment at {f}:{n} is not cited")
    assert not wrong, "docs/model.md is out of step with model/*.lp:\n" + "\n".join(wrong)


def test_doc_shows_commands():
    assert len(_code_block_commands()) >= 6


@pytest.mark.parametrize("lineno,args", _code_block_commands())
def test_command_parses(lineno, args):
    argv = shlex.split(args)
    try:
        ns = build_parser().parse_args(argv)
    except SystemExit as exc:  # argparse reports a bad command line by exiting
        pytest.fail(f"docs/model.md:{lineno}: 'refimpl {args}' does not parse (exit {exc.code})")
    assert ns.command in COMMANDS, f"docs/model.md:{lineno}: no command selected"


def test_the_bus_frames_cost_vector_in_docs_model_md_is_the_solvers():
    # docs/model.md shows `refimpl solve data/examples/bus_t235.lp` (sections 1 and 4.1) with its
    # cost vector; its level 0 (the tie-break) counts the events of the table, so a new event
    # changes it: the text must follow.  CP-SAT's answer here is the one test_association's
    # test_bus_t235_car_hides_behind_bus derives by hand on every backend.
    from refimpl.solvers.cpsat import CpSatSolver
    from refimpl.core.facts import read_problem

    h = CpSatSolver().solve(read_problem(str(REPO / "data" / "examples" / "bus_t235.lp")))
    text = DOC.read_text(encoding="utf-8")
    shown = " ".join(f"{v}@{p}" for p, v in h.cost)
    assert text.count(f"cost:    {shown}") == 2  # the cpsat and clingo runs of 4.1
    assert f"`{shown}` means" in text
    assert "tie-break " + str(h.cost[-1][1]) + "." in text
    assert "`" + str(tuple(h.cost)).replace(" ", "") + "`" in text


PROSE_REF = re.compile(r"`([a-z_]+\.lp):(\d+(?:,\d+)*)`(?:,? `\[([A-Za-z0-9_]+)\]`)?")


def test_asp_line_references_in_the_text_point_at_one_whole_label():
    # outside the rule tables (checked above) a citation `file.lp:N,...` in docs/*.md or README.md
    # names every line of one label in that file, and if a `[label]` follows it, that label; a
    # stale one (issue 41: `spatial.lp:41,43` for the box area, which moved to [size]) fails here
    labels = _asp_labels()
    by_line = {place: label for label, places in labels.items() for place in places}
    wrong = []
    for doc in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
            if line.lstrip().startswith("|") and doc == DOC:
                continue  # a rule table's row
            for f, ns, named in PROSE_REF.findall(line):
                cited = {(f, int(k)) for k in ns.split(",")}
                found = {by_line.get(c) for c in cited}
                where = f"{doc.relative_to(REPO)}:{n}: `{f}:{ns}`"
                if None in found or len(found) != 1:
                    wrong.append(f"{where} is not the lines of one label ({sorted(map(str, found))})")
                    continue
                (label,) = found
                if cited != {p for p in labels[label] if p[0] == f}:
                    wrong.append(f"{where}: [{label}] stands at {sorted(k for g, k in labels[label] if g == f)}")
                if named and named != label:
                    wrong.append(f"{where} names [{named}], but the lines are [{label}]'s")
    assert not wrong, "\n".join(wrong)


def test_no_placeholder_is_left_in_the_documents():
    # an all-capitals word with an underscore (LOGIT_HOTA stood in docs/model.md 3.19, issue 41) is a
    # number someone meant to fill in; the documents' own capitals-and-underscore names (event and
    # situation kinds, constants of the code) are the exceptions, each a word of refimpl's code
    code = "\n".join(p.read_text(encoding="utf-8") for p in (REPO / "refimpl").rglob("*.py"))
    code += " REDUCED_VISIBILITY BLOCKED_LANE EXITING_PARKED_VEHICLE"  # Table 5's situations refimpl has not
    left = []
    for doc in [REPO / "README.md", REPO / "CONTRIBUTING.md", *sorted((REPO / "docs").glob("*.md"))]:
        for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
            for word in re.findall(r"\b[A-Z][A-Z0-9]*_[A-Z0-9_]+\b", line):
                if word not in code:
                    left.append(f"{doc.relative_to(REPO)}:{n}: {word}")
            for word in re.findall(r"\b(?:TODO|TBD|FIXME|XXX)\b", line):
                left.append(f"{doc.relative_to(REPO)}:{n}: {word}")
    assert not left, "\n".join(left)


def test_code_references_name_something_in_that_file():
    # `file.py:NAME` in the documents: some refimpl (or tests) module of that name holds NAME as a
    # word; issue 41 found `events.py:FLUENT_VALUES` (gone: FLUENT_ARITY) and
    # `cpsat_model.py:match_type` (moved to admissibility.py)
    texts: dict[str, list[str]] = {}
    for p in [*(REPO / "refimpl").rglob("*.py"), *(REPO / "tests").rglob("*.py")]:
        texts.setdefault(p.name, []).append(p.read_text(encoding="utf-8"))
    wrong = []
    for doc in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
            for f, name in re.findall(r"`(?:[\w/]*/)?(\w+\.py):([A-Za-z_][\w.]*)`", line):
                word = re.compile(r"\b" + re.escape(name.split(".")[-1]) + r"\b")
                if not any(word.search(t) for t in texts.get(f, [])):
                    wrong.append(f"{doc.relative_to(REPO)}:{n}: `{f}:{name}`")
    assert not wrong, "\n".join(wrong)


def test_module_paths_in_the_documents_exist():
    # docs/detectors.md cited `refimpl/io.py` long after io became a package (issue 41)
    missing = [f"{doc.relative_to(REPO)}:{n}: {path}"
               for doc in [REPO / "README.md", REPO / "CONTRIBUTING.md", *sorted((REPO / "docs").glob("*.md"))]
               for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1)
               for path in re.findall(r"\brefimpl/[\w/]+\.py\b", line) if not (REPO / path).is_file()]
    assert not missing, "\n".join(missing)
