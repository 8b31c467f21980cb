"""The per-frame problem <VO_t, P_t, ML_t> of the paper (Section 3, Step 1) and its fact format.

A frame problem holds the visual observations (detections), the Kalman predictions of the
tracks, the matching likelihood (IoU x 100000, integers), the current time point, model
constants and the event history H^events before the current time point.  It reads and writes
exactly the ASP fact syntax the paper prints::

    #const curr_time=79.
    det(det_0, car, 99).
    box2d(det_0, 0, 189, 208, 119).
    trk(trk_0, car).
    trk_state(trk_0, halted).
    box2d(trk_0, -42, 227, 249, 159).
    iou(trk_0,det_0,34625).
    occurs_at(missing_detections(trk_0),70).

This module is layer 0: of refimpl it imports only the errors' base (refimpl.core.errors), and
nothing heavy.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Callable, Iterable, Mapping
from functools import lru_cache

from .errors import UserFacingError

IOU_SCALE = 100_000
"""Matching likelihood unit: IoU 1.0 is written as 100000 (the paper's iou/3 facts)."""

TRACK_STATES = ("active", "halted")

ASP_INT_MIN, ASP_INT_MAX = -2 ** 31, 2 ** 31 - 1
"""Integers in a fact file must fit clingo's 32-bit integers."""

MAX_TERM_DEPTH = 100
"""Deeper nested terms are an error (events nest two levels; the parser and str() recurse per level)."""

Box = tuple[int, int, int, int]
"""An integer box (x, y, w, h) in pixels: top-left corner, width, height; x, y may be negative."""


class ProblemFormatError(ValueError, UserFacingError):
    """A fact file (or fact text) that is not a valid frame problem; the message names file and line."""

    def __init__(self, message: str, source: str = "<text>", line: int | None = None):
        self.source = source
        self.line = line
        self.reason = message
        where = f"{source}:{line}" if line is not None else source
        super().__init__(f"{where}: {message}")


@dataclass(frozen=True, order=True)
class Term:
    """A ground ASP term: a constant/integer (no args) or a function term name(args...)."""

    name: str
    args: tuple["Term", ...] = ()

    def __str__(self) -> str:
        if not self.args:
            return self.name
        return f"{self.name}({','.join(str(a) for a in self.args)})"

    @property
    def is_int(self) -> bool:
        return not self.args and re.fullmatch(r"-?[0-9]+", self.name) is not None

    def as_int(self) -> int:
        if not self.is_int:
            raise ValueError(f"{self} is not an integer")
        return int(self.name)


    @property
    def arg_names(self) -> tuple[str, ...]:
        """The arguments as text: ('trk_1', 'det_2') for assign(trk_1,det_2)."""
        return tuple(str(a) for a in self.args)


_ATOM_TOKEN = re.compile(r"[(),]|[^(),\s]+")
_FLAT_ARG = re.compile(r"[^(),\s]+")


@lru_cache(maxsize=1 << 16)
def parse_atom(text: str) -> Term:
    """A solver's ground atom as a Term: 'occurs_at(hides_behind(trk_13,trk_12),235)',
    'assign(trk_1,det_2)', 'halt(trk_3)'.  The one parser of the atoms a backend, a hypothesis or
    the checker hands on (memoised: answers repeat their atoms); unlike :func:`parse_term` it does
    not validate symbols or integer ranges, which the solvers' own output always meets, but a
    malformed atom is still a ValueError."""
    head, paren, rest = text.partition("(")
    if not paren and _FLAT_ARG.fullmatch(head):  # a constant
        return Term(head)
    if paren and "(" not in rest and rest.endswith(")") and _FLAT_ARG.fullmatch(head):  # name(a,b,...)
        args = rest[:-1].split(",")
        if all(_FLAT_ARG.fullmatch(a) for a in args):
            return Term(head, tuple(map(Term, args)))
    # any other shape (nested, with blanks, or malformed): token by token
    tokens = _ATOM_TOKEN.findall(text)
    pos = 0

    def term() -> Term:
        nonlocal pos
        if pos >= len(tokens) or tokens[pos] in "(),":
            raise ValueError(f"not an atom: {text!r}")
        name = tokens[pos]
        pos += 1
        if pos < len(tokens) and tokens[pos] == "(":
            pos += 1
            args = [term()]
            while pos < len(tokens) and tokens[pos] == ",":
                pos += 1
                args.append(term())
            if pos >= len(tokens) or tokens[pos] != ")":
                raise ValueError(f"not an atom: {text!r}")
            pos += 1
            return Term(name, tuple(args))
        return Term(name)

    out = term()
    if pos != len(tokens):
        raise ValueError(f"not an atom: {text!r}")
    return out


def event_of(atom: str) -> Term:
    """The event E of an 'occurs_at(E,T)' atom, or the atom itself as a Term if it is a bare event."""
    t = parse_atom(atom)
    return t.args[0] if t.name == "occurs_at" and len(t.args) == 2 else t


def track_number(trk_id: str) -> int:
    """The number of a track id: 12 for 'trk_12' (the tracker names its tracks trk_<n>)."""
    return int(trk_id.rsplit("_", 1)[1])


@dataclass(frozen=True)
class Detection:
    """One visual observation: det(Id, Type, Conf) and box2d(Id, X, Y, W, H)."""

    id: str
    type: str
    conf: int
    box: Box


@dataclass(frozen=True)
class TrackPrediction:
    """One track's Kalman prediction for this time point: trk/2, trk_state/2 and box2d/5."""

    id: str
    type: str
    state: str
    box: Box


@dataclass(frozen=True)
class HistoryEvent:
    """occurs_at(Event, Time) for an event abduced at an earlier time point."""

    event: Term
    time: int

    def __str__(self) -> str:
        return f"occurs_at({self.event},{self.time})"


@dataclass(frozen=True)
class FrameProblem:
    """<VO_t, P_t, ML_t> plus constants and the event history before curr_time."""

    time: int
    detections: tuple[Detection, ...] = ()
    tracks: tuple[TrackPrediction, ...] = ()
    iou: tuple[tuple[str, str, int], ...] = ()
    """Matching likelihood (trk id, det id, IoU x 100000); pairs not listed have likelihood 0."""
    constants: tuple[tuple[str, int], ...] = ()
    """#const overrides other than curr_time, in file order."""
    history: tuple[HistoryEvent, ...] = ()
    match_types: tuple[tuple[str, str], ...] = ()
    """Extra match_type(TrkType, DetType) facts; a type always matches itself."""

    def __post_init__(self) -> None:
        _validate(self)

    # -- lookups -------------------------------------------------------------------------
    @property
    def constant_map(self) -> dict[str, int]:
        return dict(self.constants)

    @property
    def iou_map(self) -> dict[tuple[str, str], int]:
        return {(t, d): v for t, d, v in self.iou}

    def detection(self, det_id: str) -> Detection:
        for d in self.detections:
            if d.id == det_id:
                return d
        raise KeyError(det_id)

    def track(self, trk_id: str) -> TrackPrediction:
        for t in self.tracks:
            if t.id == trk_id:
                return t
        raise KeyError(trk_id)

    # -- fact format -----------------------------------------------------------------------
    def to_facts(self) -> str:
        return write_facts(self)

    @classmethod
    def from_facts(cls, text: str, source: str = "<text>") -> "FrameProblem":
        return parse_facts(text, source)


def _check_symbol(name: str, what: str, of: str = "") -> None:
    """``what`` + ``of`` names the symbol in the message (joined only for one: this runs per object)."""
    if not isinstance(name, str) or not _is_symbol(name):
        raise ProblemFormatError(f"{what}{of}: {_symbol_error(str(name))}")


@lru_cache(maxsize=1 << 12)
def _is_symbol(name: str) -> bool:
    """_SYMBOL.fullmatch, memoised: a tracker's ids and types come back every frame."""
    return _SYMBOL.fullmatch(name) is not None


def _validate(p: FrameProblem) -> None:
    ids: set[str] = set()
    for o in p.detections + p.tracks:
        _check_symbol(o.id, "id")
        _check_symbol(o.type, "type of ", o.id)
    for name, _ in p.constants:
        _check_symbol(name, "#const name")
    for d in p.detections:
        if d.id in ids:
            raise ProblemFormatError(f"duplicate id {d.id}")
        ids.add(d.id)
        if not 0 <= d.conf <= 100:
            raise ProblemFormatError(f"confidence of {d.id} must be 0..100, got {d.conf}")
        _check_box(d.id, d.box)
    for t in p.tracks:
        if t.id in ids:
            raise ProblemFormatError(f"duplicate id {t.id}")
        ids.add(t.id)
        if t.state not in TRACK_STATES:
            raise ProblemFormatError(f"trk_state of {t.id} must be active or halted, got {t.state}")
        _check_box(t.id, t.box)
    trk_ids = {t.id for t in p.tracks}
    det_ids = {d.id for d in p.detections}
    seen: set[tuple[str, str]] = set()
    for t, d, v in p.iou:
        if t not in trk_ids:
            raise ProblemFormatError(f"iou({t},{d},{v}) names unknown track {t}")
        if d not in det_ids:
            raise ProblemFormatError(f"iou({t},{d},{v}) names unknown detection {d}")
        if not 0 <= v <= IOU_SCALE:
            raise ProblemFormatError(f"iou({t},{d},{v}) must be within 0..{IOU_SCALE}")
        if (t, d) in seen:
            raise ProblemFormatError(f"duplicate iou for ({t},{d})")
        seen.add((t, d))
    for h in p.history:
        if h.time >= p.time:
            raise ProblemFormatError(f"history event {h} is not before curr_time={p.time}")


def _check_box(ident: str, box: Box) -> None:
    if len(box) != 4 or not (isinstance(box[0], int) and isinstance(box[1], int) and isinstance(box[2], int)
                             and isinstance(box[3], int)):
        raise ProblemFormatError(f"box of {ident} must be four integers")
    if box[2] <= 0 or box[3] <= 0:
        raise ProblemFormatError(f"box of {ident} must have width and height > 0, got {box[2]}x{box[3]}")


# ---------------------------------------------------------------------------------------
# Writing
# ---------------------------------------------------------------------------------------

def _box_fact(ident: str, box: Box) -> str:
    return f"box2d({ident}, {box[0]}, {box[1]}, {box[2]}, {box[3]})."


def write_facts(p: FrameProblem) -> str:
    """The problem in the paper's fact syntax; parse_facts(write_facts(p)) == p."""
    out = [f"#const curr_time={p.time}."]
    out += [f"#const {k}={v}." for k, v in p.constants]
    out += [f"det({d.id}, {d.type}, {d.conf})." for d in p.detections]
    out += [_box_fact(d.id, d.box) for d in p.detections]
    for t in p.tracks:
        out.append(f"trk({t.id}, {t.type}).")
        out.append(f"trk_state({t.id}, {t.state}).")
    out += [_box_fact(t.id, t.box) for t in p.tracks]
    out += [f"iou({t},{d},{v})." for t, d, v in p.iou]
    out += [f"match_type({a}, {b})." for a, b in p.match_types]
    out += [f"{h}." for h in p.history]
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------

_TOKEN = re.compile(r"\s*(?:(?P<num>-?[0-9]+)|(?P<name>[a-z_][A-Za-z0-9_]*)|(?P<punct>[(),.]))")
_CONST = re.compile(r"#const\s+([a-z_][A-Za-z0-9_]*)\s*=\s*(-?[0-9]+)\s*\.")
_SYMBOL = re.compile(r"(?!not\b)[a-z][A-Za-z0-9_]*")
"""Ids, types, constant and event names: what clingo and the CP-SAT backend both read as one
constant.  clingo reads a name that starts with '_' (``_``, ``_Person``) as a variable and
``not`` as a keyword, so those are refused (uppercase-first names are variables too: the
tokenizer never takes them as names)."""
_LINE_BREAK = re.compile(r"\r\n|\r|\n")  # not str.splitlines: \f, \v, \x85, U+2028 ... are no line ends


def _symbol_error(name: str) -> str:
    why = "a keyword" if name == "not" else "an anonymous variable" if name == "_" else "a variable"
    return (f"name {name!r} is {why} to clingo: ids, types and constant names start with a lowercase "
            "letter (a-z, then letters, digits, _) and are not 'not'")


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
        if not _SYMBOL.fullmatch(val):
            raise self.fail(_symbol_error(val))
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
    if not _SYMBOL.fullmatch(name):
        raise acc.fail(f"#const {_symbol_error(name)}", lineno)
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


def _read_fact(acc: _Facts, line: str, lineno: int) -> str:
    """Read one fact at the start of line; the rest of the line."""
    cur = _Cursor(line, acc.source, lineno)
    fact = cur.term()
    cur.expect(".")
    row = _predicate(acc, fact, lineno)
    row.read(acc, fact, _argument_values(acc, fact, row, lineno), lineno)
    return line[cur.pos:].strip()


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
        with open(path, encoding="utf-8-sig") as fh:  # -sig: a leading BOM is not part of the text
            text = fh.read()
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


def natural_key(ident: str) -> tuple:
    """Sort key for ids like trk_12: name part, then number (trk_2 before trk_12)."""
    m = re.fullmatch(r"(.*?)(\d+)", ident)
    return (m.group(1), int(m.group(2)), ident) if m else (ident, -1, ident)


def with_history(p: FrameProblem, history: Iterable[HistoryEvent]) -> FrameProblem:
    """The same problem with another event history."""
    return FrameProblem(p.time, p.detections, p.tracks, p.iou, p.constants, tuple(history), p.match_types)


def with_constants(p: FrameProblem, overrides: Mapping[str, int]) -> FrameProblem:
    """The same problem with #const values overridden or added."""
    merged = dict(p.constants)
    merged.update(overrides)
    return FrameProblem(p.time, p.detections, p.tracks, p.iou, tuple(merged.items()), p.history, p.match_types)
