"""The per-frame problem <VO_t, P_t, ML_t> of the paper (Section 3, Step 1), and how it is printed.

A frame problem holds the visual observations (detections), the Kalman predictions of the
tracks, the matching likelihood (IoU x 100000, integers), the current time point, model
constants and the event history H^events before the current time point.  ``write_facts`` (and
``FrameProblem.to_facts``) print it in exactly the ASP fact syntax the paper prints, which
refimpl.core.facts reads back (``parse_facts``, ``read_problem``)::

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
from dataclasses import dataclass
from typing import Callable, Iterable, Mapping
from functools import lru_cache

from .errors import UserFacingError

IOU_SCALE = 100_000
"""Matching likelihood unit: IoU 1.0 is written as 100000 (the paper's iou/3 facts)."""

CONF_WEIGHT_SCALE = 10_000
"""likelihood_conf (0..100) times a confidence gap (0..100): the unit of the weight
pair_likelihood multiplies the IoU by; IOU_SCALE x CONF_WEIGHT_SCALE = 10^9 fits clingo's 32 bits."""


def pair_likelihood(iou: int, conf: int, likelihood_conf: int) -> int:
    """A pair's matching likelihood, the weight its assign or resume adds at level 10
    (model/optimisation.lp [matching_likelihood], refimpl decision, docs/model.md 3.30): the IoU
    (x 100000) weighed by the detection's confidence, IoU x (1 - likelihood_conf/100 x (1 - conf/100)),
    in integers as clingo computes it (every operand >= 0, so its truncating division is floor).
    likelihood_conf 0: the IoU alone (the paper); 100: IoU x conf / 100."""
    return iou * (CONF_WEIGHT_SCALE - likelihood_conf * (100 - conf)) // CONF_WEIGHT_SCALE


MAX_LIKELIHOOD_HALVING = 10_000
"""The largest likelihood_halving: a pair's weight (<= IOU_SCALE) times it fits clingo's 32 bits."""


def halved_likelihood(ml: int, halted_for: int | None, likelihood_halving: int) -> int:
    """A halted track's pair weight at level 10 (model/optimisation.lp [stale_likelihood], refimpl
    decision, docs/model.md 3.31): its matching likelihood ``ml`` times H / (H + the frames since its
    halt), H = likelihood_halving, in integers as clingo computes it (floor: every operand >= 0).
    Unchanged where H is 0 or the track has no halt in its history (``halted_for`` None).  The
    encoding takes a gap above 10^9 as 10^9 (32 bits): the same quotient, 0, as ml x H <= 10^9."""
    if not likelihood_halving or halted_for is None:
        return ml
    return ml * likelihood_halving // (likelihood_halving + halted_for)


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


def parse_atom(text: str, *, memo: bool = True) -> Term:
    """A solver's ground atom as a Term: 'occurs_at(hides_behind(trk_13,trk_12),235)',
    'assign(trk_1,det_2)', 'halt(trk_3)'.  The one parser of the atoms a backend, a hypothesis or
    the checker hands on; unlike :func:`parse_term` it does not validate symbols or integer
    ranges, which the solvers' own output always meets, but a malformed atom is still a ValueError.

    Memoised, except an event at its time point ('occurs_at(E,T)'): actions come back frame after
    frame, an event's atom names its frame and is asked for once.  Kept, those Terms only grew the
    heap that every full garbage collection walks (MOT15: 6,924 distinct of 7,069 asked, each
    entry half a dozen objects; the collections it caused were the slowest frames of a run,
    docs/benchmarks.md "The slowest frames"), and so does a larger memo: 4,096 atoms hold every
    track x detection pair a frame of a few hundred objects asks again.  ``memo=False``: parsed
    afresh, not kept (for a caller that keeps what it needs of the Term in a memo of its own)."""
    if not memo or text.startswith("occurs_at("):
        return _parse_atom(text)
    return _parse_atom_memo(text)


def _parse_atom(text: str) -> Term:
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


_parse_atom_memo = lru_cache(maxsize=1 << 12)(_parse_atom)


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

    @classmethod
    def unchecked(cls, time: int, detections: tuple[Detection, ...] = (), tracks: tuple[TrackPrediction, ...] = (),
                  iou: tuple[tuple[str, str, int], ...] = (), constants: tuple[tuple[str, int], ...] = (),
                  history: tuple[HistoryEvent, ...] = (), match_types: tuple[tuple[str, str], ...] = ()) -> FrameProblem:
        """The same problem as the constructor builds, without its checks: only for a caller that
        holds every invariant they test by construction (the tracker, whose ids, integer boxes and
        IoU facts it makes itself and whose other values it has checked: AbductionTracker.frame_problem);
        every other caller uses the constructor."""
        self = object.__new__(cls)
        for name, value in (("time", time), ("detections", detections), ("tracks", tracks), ("iou", iou),
                            ("constants", constants), ("history", history), ("match_types", match_types)):
            object.__setattr__(self, name, value)
        return self

    # -- lookups -------------------------------------------------------------------------
    @property
    def constant_map(self) -> dict[str, int]:
        return dict(self.constants)

    @property
    def iou_map(self) -> dict[tuple[str, str], int]:
        return {(t, d): v for t, d, v in self.iou}

    def likelihood_map(self, likelihood_conf: int, likelihood_halving: int = 0,
                       halted_at: Callable[[str], int | None] | None = None) -> dict[tuple[str, str], int]:
        """(trk, det) -> the pair's matching likelihood at level 10 (pair_likelihood), for every iou/3
        fact; with likelihood_halving a halted track's halved by its time since the halt
        (halved_likelihood; ``halted_at``: the event state's, trk -> the time of its latest halt)."""
        if not likelihood_conf:
            ml = self.iou_map
        else:
            conf = {d.id: d.conf for d in self.detections}
            ml = {(t, d): pair_likelihood(v, conf[d], likelihood_conf) for t, d, v in self.iou}
        if likelihood_halving and halted_at is not None:
            since = {t.id: (None if (h := halted_at(t.id)) is None else self.time - h)
                     for t in self.tracks if t.state == "halted"}
            ml = {(t, d): v if t not in since else halved_likelihood(v, since[t], likelihood_halving)
                  for (t, d), v in ml.items()}
        return ml

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
        """The problem in the paper's fact syntax (write_facts); read back by refimpl.core.facts.parse_facts."""
        return write_facts(self)


SYMBOL = re.compile(r"(?!not\b)[a-z][A-Za-z0-9_]*")
"""Ids, types, constant and event names: what clingo and the CP-SAT backend both read as one
constant.  clingo reads a name that starts with '_' (``_``, ``_Person``) as a variable and
``not`` as a keyword, so those are refused (uppercase-first names are variables too: the
tokenizer never takes them as names)."""


def symbol_error(name: str) -> str:
    """Why ``name`` is no symbol, in one phrase (the fact reader's and the model's own checks)."""
    why = "a keyword" if name == "not" else "an anonymous variable" if name == "_" else "a variable"
    return (f"name {name!r} is {why} to clingo: ids, types and constant names start with a lowercase "
            "letter (a-z, then letters, digits, _) and are not 'not'")


def _check_symbol(name: str, what: str, of: str = "") -> None:
    """``what`` + ``of`` names the symbol in the message (joined only for one: this runs per object)."""
    if not isinstance(name, str) or not _is_symbol(name):
        raise ProblemFormatError(f"{what}{of}: {symbol_error(str(name))}")


def is_symbol(name) -> bool:
    """Whether ``name`` is a str that SYMBOL matches (what _validate asks of every id and type)."""
    return isinstance(name, str) and _is_symbol(name)


@lru_cache(maxsize=1 << 12)
def _is_symbol(name: str) -> bool:
    """SYMBOL.fullmatch, memoised: a tracker's ids and types come back every frame."""
    return SYMBOL.fullmatch(name) is not None


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
