"""Reading the paper's fact format: a fact file (or fact text) into a FrameProblem (refimpl.core.spec).

The format is the ASP syntax the paper prints (``#const curr_time=79.``, ``det(det_0, car, 99).``,
``box2d(det_0, 0, 189, 208, 119).``, ``trk/2``, ``trk_state/2``, ``iou/3``, ``match_type/2``,
``occurs_at(Event,T).``); ``write_facts`` (refimpl.core.spec, beside the model it prints, and
re-exported here) writes it, and ``parse_facts(write_facts(p)) == p``.  The reader is a table of
predicate readers (``_PREDICATES``: a new predicate is one row and its reader); every error is a
``ProblemFormatError`` naming the source and the line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable

from .records import RecordTooLong, read_text
from .spec import (ASP_INT_MAX, ASP_INT_MIN, IOU_SCALE, MAX_TERM_DEPTH, SYMBOL, TRACK_STATES, Box, Detection,
                   FrameProblem, HistoryEvent, ProblemFormatError, Term, TrackPrediction, symbol_error,
                   write_facts)

__all__ = ["parse_facts", "parse_term", "read_problem", "write_facts"]


_TOKEN = re.compile(r"\s*(?:(?P<num>-?[0-9]+)|(?P<name>[a-z_][A-Za-z0-9_]*)|(?P<punct>[(),.]))")
_CONST = re.compile(r"#const\s+([a-z_][A-Za-z0-9_]*)\s*=\s*(-?[0-9]+)\s*\.")
_LINE_BREAK = re.compile(r"\r\n|\r|\n")  # not str.splitlines: \f, \v, \x85, U+2028 ... are no line ends


def _asp_int(text: str) -> int | None:
    """The value of an integer token, or None outside clingo's 32-bit range (a huge token is not converted)."""
    if len(text.lstrip("-").lstrip("0")) > 10:
        return None
    value = int(text)
    return value if ASP_INT_MIN <= value <= ASP_INT_MAX else None


def _int_range_error(text: str) -> str:
    shown = text if len(text) <= 40 else f"{text[:12]}...({len(text.lstrip('-'))} digits)"
    return f"integer {shown} is outside the 32-bit range {ASP_INT_MIN}..{ASP_INT_MAX} of ASP integers"


class _Cursor:
    def __init__(self, text: str, source: str, line: int):
        self.text, self.pos, self.source, self.line = text, 0, source, line

    def fail(self, msg: str) -> ProblemFormatError:
        return ProblemFormatError(msg, self.source, self.line)

    def peek(self) -> tuple[str, str] | None:
        m = _TOKEN.match(self.text, self.pos)
        if not m:
            return None
        kind = m.lastgroup or "punct"
        return kind, m.group(kind)

    def next(self) -> tuple[str, str]:
        m = _TOKEN.match(self.text, self.pos)
        if not m:
            rest = self.text[self.pos:].strip()
            if not rest:
                raise self.fail("unexpected end of line inside a fact (facts stay on one line)")
            raise self.fail(f"unexpected text {rest[:30]!r}")
        self.pos = m.end()
        kind = m.lastgroup or "punct"
        return kind, m.group(kind)

    def expect(self, char: str) -> None:
        if self.at_end():
            raise self.fail(f"expected {char!r} at the end of the line (facts end with '.' and stay on one line)")
        kind, val = self.next()
        if val != char:
            raise self.fail(f"expected {char!r}, got {val!r}")

    def at_end(self) -> bool:
        return self.text[self.pos:].strip() == ""

    def term(self, depth: int = 0) -> Term:
        if depth > MAX_TERM_DEPTH:
            raise self.fail(f"term nested deeper than {MAX_TERM_DEPTH} levels")
        kind, val = self.next()
        if kind == "num":
            value = _asp_int(val)
            if value is None:
                raise self.fail(_int_range_error(val))
            return Term(str(value))
        if kind != "name":
            raise self.fail(f"expected a term, got {val!r}")
        if not SYMBOL.fullmatch(val):
            raise self.fail(symbol_error(val))
        nxt = self.peek()
        if nxt and nxt[1] == "(":
            self.next()
            args = [self.term(depth + 1)]
            while True:
                _, sep = self.next()
                if sep == ")":
                    break
                if sep != ",":
                    raise self.fail(f"expected ',' or ')', got {sep!r}")
                args.append(self.term(depth + 1))
            return Term(val, tuple(args))
        return Term(val)


def _strip_comment(line: str) -> str:
    i = line.find("%")
    return line if i < 0 else line[:i]


class _Facts:
    """What parse_facts has read so far, each entry with the line it came from (private to this module)."""

    def __init__(self, source: str):
        self.source = source
        self.consts: list[tuple[str, int]] = []
        self.curr_time: int | None = None
        self.dets: dict[str, tuple[str, int, int]] = {}
        self.trks: dict[str, tuple[str, int]] = {}
        self.states: dict[str, tuple[str, int]] = {}
        self.boxes: dict[str, tuple[Box, int]] = {}
        self.ious: list[tuple[str, str, int, int]] = []
        self.iou_seen: set[tuple[str, str]] = set()
        self.history: list[tuple[HistoryEvent, int]] = []
        self.match_types: list[tuple[str, str]] = []

    def fail(self, message: str, lineno: int | None) -> ProblemFormatError:
        return ProblemFormatError(message, self.source, lineno)

    def dup(self, ident: str, what: str, lineno: int) -> ProblemFormatError:
        return self.fail(f"duplicate {what} for {ident}", lineno)


# One reader per predicate: (facts so far, the fact, its checked argument values, line number).

def _read_det(acc: _Facts, fact: Term, vals: list, lineno: int) -> None:
    if vals[0] in acc.dets or vals[0] in acc.trks:
        raise acc.dup(vals[0], "det/trk id", lineno)
    if not 0 <= vals[2] <= 100:
        raise acc.fail(f"{fact}: confidence must be 0..100", lineno)
    acc.dets[vals[0]] = (vals[1], vals[2], lineno)


def _read_trk(acc: _Facts, fact: Term, vals: list, lineno: int) -> None:
    if vals[0] in acc.dets or vals[0] in acc.trks:
        raise acc.dup(vals[0], "det/trk id", lineno)
    acc.trks[vals[0]] = (vals[1], lineno)


def _read_trk_state(acc: _Facts, fact: Term, vals: list, lineno: int) -> None:
    if vals[0] in acc.states:
        raise acc.dup(vals[0], "trk_state", lineno)
    if vals[1] not in TRACK_STATES:
        raise acc.fail(f"{fact}: state must be active or halted", lineno)
    acc.states[vals[0]] = (vals[1], lineno)


def _read_box2d(acc: _Facts, fact: Term, vals: list, lineno: int) -> None:
    if vals[0] in acc.boxes:
        raise acc.dup(vals[0], "box2d", lineno)
    if vals[3] <= 0 or vals[4] <= 0:
        raise acc.fail(f"{fact}: width and height must be > 0", lineno)
    acc.boxes[vals[0]] = ((vals[1], vals[2], vals[3], vals[4]), lineno)


def _read_iou(acc: _Facts, fact: Term, vals: list, lineno: int) -> None:
    if (vals[0], vals[1]) in acc.iou_seen:
        raise acc.dup(f"({vals[0]},{vals[1]})", "iou", lineno)
    if not 0 <= vals[2] <= IOU_SCALE:
        raise acc.fail(f"{fact}: IoU must be 0..{IOU_SCALE}", lineno)
    acc.iou_seen.add((vals[0], vals[1]))
    acc.ious.append((vals[0], vals[1], vals[2], lineno))


def _read_occurs_at(acc: _Facts, fact: Term, vals: list, lineno: int) -> None:
    acc.history.append((HistoryEvent(vals[0], vals[1]), lineno))


def _read_match_type(acc: _Facts, fact: Term, vals: list, lineno: int) -> None:
    acc.match_types.append((vals[0], vals[1]))


@dataclass(frozen=True)
class _Predicate:
    """One row of the fact table: argument kinds ('s' symbol, 'i' integer, 't' any term) and its reader."""

    kinds: str
    read: Callable[[_Facts, Term, list, int], None]


_PREDICATES = {
    ("det", 3): _Predicate("ssi", _read_det),
    ("box2d", 5): _Predicate("siiii", _read_box2d),
    ("trk", 2): _Predicate("ss", _read_trk),
    ("trk_state", 2): _Predicate("ss", _read_trk_state),
    ("iou", 3): _Predicate("ssi", _read_iou),
    ("occurs_at", 2): _Predicate("ti", _read_occurs_at),
    ("match_type", 2): _Predicate("ss", _read_match_type),
}
"""predicate/arity -> its row: the facts a frame problem is made of (a new predicate is one row + its reader)."""


def _read_const(acc: _Facts, line: str, lineno: int) -> str:
    """Read one '#const name=value.' at the start of line; the rest of the line."""
    m = _CONST.match(line)
    if not m:
        raise acc.fail(f"malformed #const: {line[:40]!r}", lineno)
    name, value = m.group(1), _asp_int(m.group(2))
    if not SYMBOL.fullmatch(name):
        raise acc.fail(f"#const {symbol_error(name)}", lineno)
    if value is None:
        raise acc.fail(f"#const {name}: {_int_range_error(m.group(2))}", lineno)
    if name == "curr_time":
        if acc.curr_time is not None:
            raise acc.fail("curr_time defined twice", lineno)
        acc.curr_time = value
    else:
        if any(k == name for k, _ in acc.consts):
            raise acc.fail(f"#const {name} defined twice", lineno)
        acc.consts.append((name, value))
    return line[m.end():].strip()


def _predicate(acc: _Facts, fact: Term, lineno: int) -> _Predicate:
    row = _PREDICATES.get((fact.name, len(fact.args)))
    if row is None:
        raise acc.fail(
            f"unknown fact {fact.name}/{len(fact.args)} (expected one of "
            + ", ".join(f"{n}/{a}" for n, a in _PREDICATES) + ")", lineno)
    return row


def _argument_values(acc: _Facts, fact: Term, row: _Predicate, lineno: int) -> list:
    """The fact's arguments checked against its row's kinds: ints as int, symbols as str, terms as Term."""
    vals: list = []
    for arg, kind in zip(fact.args, row.kinds):
        if kind == "i":
            if not arg.is_int:
                raise acc.fail(f"{fact}: {arg} must be an integer", lineno)
            vals.append(arg.as_int())
        elif kind == "s":
            if arg.args or arg.is_int:
                raise acc.fail(f"{fact}: {arg} must be a constant name", lineno)
            vals.append(arg.name)
        else:
            vals.append(arg)
    return vals


_FLAT_FACT = re.compile(r"([a-z][A-Za-z0-9_]*)\(((?:[a-z][A-Za-z0-9_]*|-?[0-9]+)(?:,(?:[a-z][A-Za-z0-9_]*|-?[0-9]+))*)\)\.")
"""A fact whose arguments are names and integers, written without spaces (``iou(trk_1,det_2,812).``:
nearly every line of a large file)."""


def _flat_fact(line: str) -> tuple[Term, int] | None:
    """(the fact, where it ends) for a line that starts with a _FLAT_FACT whose names are symbols
    and whose integers are in range: the Term _Cursor.term reads there, read with one regular
    expression (a 400-track file's 54,000 facts: 1.1 s -> ~0.4 s); None for anything else, which
    _Cursor reads (and words the errors of)."""
    m = _FLAT_FACT.match(line)
    if m is None or m.group(1) == "not":
        return None
    args = []
    for a in m.group(2).split(","):
        if a[0] in "-0123456789":
            value = _asp_int(a)
            if value is None:
                return None
            args.append(Term(str(value)))
        elif a == "not":
            return None
        else:
            args.append(Term(a))
    return Term(m.group(1), tuple(args)), m.end()


def _read_fact(acc: _Facts, line: str, lineno: int) -> str:
    """Read one fact at the start of line; the rest of the line."""
    flat = _flat_fact(line)
    if flat is None:
        cur = _Cursor(line, acc.source, lineno)
        fact = cur.term()
        cur.expect(".")
        end = cur.pos
    else:
        fact, end = flat
    row = _predicate(acc, fact, lineno)
    row.read(acc, fact, _argument_values(acc, fact, row, lineno), lineno)
    return line[end:].strip()


def _check_references(acc: _Facts) -> None:
    """Every id a fact names is declared, every object has its box (and a track its state)."""
    for ident, (_, lineno) in acc.boxes.items():
        if ident not in acc.dets and ident not in acc.trks:
            raise acc.fail(f"box2d for unknown id {ident}", lineno)
    for ident, (_, _, lineno) in acc.dets.items():
        if ident not in acc.boxes:
            raise acc.fail(f"detection {ident} has no box2d", lineno)
    for ident, (_, lineno) in acc.trks.items():
        if ident not in acc.boxes:
            raise acc.fail(f"track {ident} has no box2d", lineno)
        if ident not in acc.states:
            raise acc.fail(f"track {ident} has no trk_state", lineno)
    for ident, (_, lineno) in acc.states.items():
        if ident not in acc.trks:
            raise acc.fail(f"trk_state for unknown track {ident}", lineno)
    for t, d, v, lineno in acc.ious:
        if t not in acc.trks or d not in acc.dets:
            unknown = t if t not in acc.trks else d
            raise acc.fail(f"iou({t},{d},{v}) names unknown id {unknown}", lineno)


def parse_facts(text: str, source: str = "<text>") -> FrameProblem:
    """Parse the paper's fact syntax into a FrameProblem; errors name source and line."""
    acc = _Facts(source)
    for lineno, raw in enumerate(_LINE_BREAK.split(text), start=1):
        line = _strip_comment(raw).strip()
        while line:
            line = (_read_const if line.startswith("#const") else _read_fact)(acc, line, lineno)

    curr_time = acc.curr_time
    if curr_time is None:
        raise acc.fail("missing '#const curr_time=<int>.'", None)
    _check_references(acc)
    for h, lineno in acc.history:
        if h.time >= curr_time:
            raise acc.fail(f"{h} is not before curr_time={curr_time}", lineno)

    boxes = acc.boxes
    return FrameProblem(
        time=curr_time,
        detections=tuple(Detection(i, ty, c, boxes[i][0]) for i, (ty, c, _) in acc.dets.items()),
        tracks=tuple(TrackPrediction(i, ty, acc.states[i][0], boxes[i][0]) for i, (ty, _) in acc.trks.items()),
        iou=tuple((t, d, v) for t, d, v, _ in acc.ious),
        constants=tuple(acc.consts),
        history=tuple(h for h, _ in acc.history),
        match_types=tuple(acc.match_types),
    )


def read_problem(path: str) -> FrameProblem:
    """Read a fact file; a missing or undecodable file is a ProblemFormatError too."""
    try:
        text = read_text(path, encoding="utf-8-sig")  # -sig: a leading BOM is not part of the text
    except RecordTooLong as exc:
        raise ProblemFormatError(str(exc), path) from None
    except OSError as exc:
        raise ProblemFormatError(f"cannot read file: {exc.strerror or exc}", path) from None
    except UnicodeDecodeError:
        raise ProblemFormatError("not a UTF-8 text file", path) from None
    return parse_facts(text, path)


def parse_term(text: str) -> Term:
    """Parse one ground term such as 'hides_behind(trk_13,trk_12)'."""
    cur = _Cursor(text, "<term>", 1)
    t = cur.term()
    if not cur.at_end():
        raise cur.fail(f"trailing text after term {t}")
    return t
