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
