"""The hand-written event calculus (the paper's Sigma_dyn): fluents, a history folded into their
values, and ``poss`` of the events over a frame problem (the event table and the preconditions it
names are refimpl.knowledge.event_table).

This module is what the CP-SAT backend uses instead of the ASP rules for fluents, effects and
``poss``; an independent answer checker calls the same functions, so "possible" means one thing
in refimpl's Python.  The normative text is docs/model-spec.md sections 2 and 4.

Fluents (the paper's Table "ABDUCIBLES; Fluents", Appendix A ``fluent/1`` and ``possVal/2``)::

    visibility(T)      fully_visible | partially_visible | not_visible   initially fully_visible
    hidden_by(T1, T2)  true | false                                      initially false
    clipped(T)         true | false                                      initially false
    in_fov(T)          true | false                                      initially true

Semantics of ``holds_at(F, V)`` at the current time point (docs/model-spec.md section 2):
start from the initial value (Appendix A, ``holds_at(..., mintime)``), then apply the history's
time points in increasing order; an event at time Tm sets its fluents from the next time point
on; a fluent no event sets keeps its values (inertia).  ``holds_at`` is a relation: at a time
point where events set F, F's values afterwards are exactly the set of values set there, so a
hand-written history that sets one fluent to two values at one time point makes both hold.
Every history event is folded, also one at or before ``mintime`` (refimpl reading of
docs/model-spec.md: the initial values hold before the earliest time point; the ASP encoding
initialises at the least of mintime and the history's time points, which is the same).

Reading of negative conditions (refimpl decision, docs/model-spec.md): a precondition written
``F != V`` in the spec is the paper's ``not holds_at(F, V, curr_time)`` (negation as failure),
and ``F = V`` is ``holds_at(F, V, curr_time)``.  With a set-valued fluent both can differ from a
functional reading, e.g. visibility {fully_visible, not_visible} is "= not_visible" and not
"!= not_visible".

Effects apply whatever the other arguments of the event name: ``hides_behind(T1, T2)`` makes T1
not_visible even if T2 is no longer a current track (refimpl decision, docs/model-spec.md: the
effects table is unconditional; the paper's ``causesValue`` rules carry ``trk/2`` guards only
to ground them over the tracks of the problem).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Iterable, Mapping, Union

from ..core.facts import parse_term
from ..core.spec import FrameProblem, HistoryEvent, Term
from .event_table import EVENT_TABLE, OTHERS, explaining

# ---------------------------------------------------------------------------------------
# Fluents, values, initial values
# ---------------------------------------------------------------------------------------

FLUENT_ARITY: Mapping[str, int] = {"visibility": 1, "hidden_by": 2, "clipped": 1, "in_fov": 1}

INITIAL_VALUE: Mapping[str, str] = {
    "visibility": "fully_visible",  # Appendix A: holds_at(visibility(Trk), fully_visible, mintime)
    "hidden_by": "false",           # Appendix A: holds_at(hidden_by(Trk1, Trk2), false, mintime)
    "clipped": "false",             # Appendix A: holds_at(clipped(Trk), false, mintime)
    "in_fov": "true",               # refimpl decision (docs/model-spec.md): a track starts in view
}

# ---------------------------------------------------------------------------------------
# Fluent keys (the effects themselves are data of the event table, refimpl.knowledge.event_table)
# ---------------------------------------------------------------------------------------

FluentKey = tuple[str, ...]
FluentLike = Union[Term, str, tuple]


def fluent_key(fluent: FluentLike) -> FluentKey:
    """('visibility', 'trk_1') from a Term, an atom string 'visibility(trk_1)' or a tuple."""
    if type(fluent) is tuple:  # the queries' own form, asked thousands of times a frame: memoised
        try:
            return _tuple_fluent_key(fluent)
        except TypeError:  # an unhashable element: not memoisable (and not a fluent either)
            pass
    return _fluent_key(fluent)


@lru_cache(maxsize=1 << 14)
def _tuple_fluent_key(fluent: tuple) -> FluentKey:
    return _fluent_key(fluent)


def _fluent_key(fluent: FluentLike) -> FluentKey:
    if type(fluent) is tuple and fluent and type(fluent[0]) is str \
            and len(fluent) == FLUENT_ARITY.get(fluent[0], -2) + 1 and all(type(x) is str for x in fluent):
        return fluent  # already its key, (name, arguments...) as text: what the rest computes, 8x faster
    if isinstance(fluent, str):
        fluent = parse_term(fluent)
    if isinstance(fluent, Term):
        key = (fluent.name,) + tuple(str(a) for a in fluent.args)
    else:
        key = tuple(str(x) for x in fluent)
    name = key[0] if key else ""
    if name not in FLUENT_ARITY or len(key) - 1 != FLUENT_ARITY[name]:
        raise ValueError(f"not a fluent: {fluent!r} (fluents: "
                         + ", ".join(f"{n}/{a}" for n, a in FLUENT_ARITY.items()) + ")")
    return key


def _event_parts(event: Union[Term, str]) -> tuple[str, tuple[str, ...]]:
    if isinstance(event, str):
        event = parse_term(event)
    # str(Term) of a constant is its name: read it without the call (this runs per folded event)
    return event.name, tuple([a.name if type(a) is Term and not a.args else str(a) for a in event.args])


# ---------------------------------------------------------------------------------------
# The state: fluent values after a history
# ---------------------------------------------------------------------------------------

_HALTING = frozenset(e.name for e in explaining("halt"))
_STARTING = frozenset(e.name for e in explaining("start"))


class EventState:
    """Fluent values, start/halt times and event occurrences after an event history.

    Built once from a history (any order: events are folded in increasing time order) and
    then updated incrementally with :meth:`apply` for the events abduced at each new time
    point; an update costs O(events applied) (plus, for ``recover(T)``, O(hidden_by fluents
    of T set explicitly)), never a refold of the history.

    Values are those holding after the last time point folded, i.e. at any later time point,
    in particular at the problem's curr_time (every history event is before curr_time).
    """

    __slots__ = ("tracks", "time", "_values", "_others", "_hb_index", "_group_time",
                 "_group_keys", "_group_others", "_occurs", "_started", "_halted")

    def __init__(self, history: Iterable[HistoryEvent] = (), tracks: Iterable[str] = ()):
        self.tracks: tuple[str, ...] = tuple(tracks)
        """The current track ids (only their fluents matter; any id can be queried)."""
        self.time: int | None = None
        """The last history time point folded in (None: empty history)."""
        self._values: dict[FluentKey, frozenset[str]] = {}     # explicit values; absent = initial
        self._others: dict[str, frozenset[str]] = {}           # T1 -> hidden_by(T1, X) for X not in _values
        self._hb_index: dict[str, set[str]] = {}               # T1 -> X with ('hidden_by', T1, X) in _values
        self._group_time: int | None = None                    # time point being folded
        self._group_keys: set[FluentKey] = set()               # fluents set at _group_time
        self._group_others: set[str] = set()                   # T1 whose hidden_by(T1, *) was set at _group_time
        self._occurs: set[tuple[str, int]] = set()
        self._started: dict[str, int] = {}
        self._halted: dict[str, int] = {}
        for h in sorted(history, key=lambda h: h.time):
            self._add(h.event, h.time)

    @classmethod
    def from_problem(cls, problem: FrameProblem) -> "EventState":
        """The state at problem.time from the problem's own history and tracks."""
        return cls(problem.history, (t.id for t in problem.tracks))

    # -- updating --------------------------------------------------------------------------
    def apply(self, events: Iterable[Union[Term, str]], t: int,
              tracks: Iterable[str] | None = None) -> "EventState":
        """Fold in the events abduced at time point t (in place) and return self.

        t must not be before the last time point folded; events at the same time point as the
        previous call join that time point (the set-valued semantics). ``tracks`` optionally
        replaces the current track ids (for the next frame). Use :meth:`copy` for a snapshot.
        Event strings may be bare events ('recover(trk_1)') or 'occurs_at(E,t)' atoms.
        """
        if self._group_time is not None and t < self._group_time:
            raise ValueError(f"events at {t} come before the last time point folded ({self._group_time})")
        for e in events:
            term = parse_term(e) if isinstance(e, str) else e
            if term.name == "occurs_at" and len(term.args) == 2:
                if term.args[1].is_int and term.args[1].as_int() != t:
                    raise ValueError(f"{term} is not at time point {t}")
                term = term.args[0]
            self._add(term, t)
        if self._group_time is None or t > self._group_time:
            self._start_group(t)  # a time point with no events still advances time
        if tracks is not None:
            self.tracks = tuple(tracks)
        return self

    def copy(self) -> "EventState":
        new = EventState.__new__(EventState)
        new.tracks = self.tracks
        new.time = self.time
        new._values = dict(self._values)
        new._others = dict(self._others)
        new._hb_index = {k: set(v) for k, v in self._hb_index.items()}
        new._group_time = self._group_time
        new._group_keys = set(self._group_keys)
        new._group_others = set(self._group_others)
        new._occurs = set(self._occurs)
        new._started = dict(self._started)
        new._halted = dict(self._halted)
        return new

    def _start_group(self, t: int) -> None:
        self._group_time = t
        self._group_keys.clear()
        self._group_others.clear()
        self.time = t

    def _add(self, event: Term, t: int) -> None:
        if self._group_time is None or t > self._group_time:
            self._start_group(t)
        name, args = _event_parts(event)
        self._occurs.add((f"{name}({','.join(args)})" if args else name, t))
        # derived, not fluents (docs/model-spec.md section 2)
        spec = EVENT_TABLE.get(name)
        if spec is None or spec.arity != len(args):
            return  # an unknown event, or a known one with another arity, has no effect
        if name in _STARTING:
            self._started[args[0]] = max(t, self._started.get(args[0], t))
        if name in _HALTING:
            self._halted[args[0]] = max(t, self._halted.get(args[0], t))
        for fluent, positions, value in spec.effects:
            if OTHERS in positions:
                self._set_others(args[positions[0]], value)  # type: ignore[index]
            else:
                self._set((fluent, *[args[i] for i in positions]), value)  # type: ignore[index]

    def _set(self, key: FluentKey, value: str) -> None:
        if key in self._group_keys:
            self._values[key] = self._values[key] | {value}
            return
        base: frozenset[str] = frozenset()
        if key[0] == "hidden_by":
            if key[1] in self._group_others:
                base = self._others[key[1]]
            self._hb_index.setdefault(key[1], set()).add(key[2])
        self._values[key] = base | {value}
        self._group_keys.add(key)

    def _set_others(self, t1: str, value: str) -> None:
        """hidden_by(t1, X) := value for every X != t1 (kept as t1's default, not per pair)."""
        if t1 in self._group_others:
            self._others[t1] = self._others[t1] | {value}
        else:
            self._others[t1] = frozenset((value,))
            self._group_others.add(t1)
        for x in list(self._hb_index.get(t1, ())):
            key = ("hidden_by", t1, x)
            if x == t1:
                continue  # hidden_by(T, T) is no fluent; OTHERS excludes it
            if key in self._group_keys:
                self._values[key] = self._values[key] | {value}
            else:
                del self._values[key]
                self._hb_index[t1].discard(x)

    # -- queries -----------------------------------------------------------------------------
    def values(self, fluent: FluentLike) -> frozenset[str]:
        """The set of values the fluent holds at curr_time (one value unless set-valued)."""
        return self.values_of_key(fluent_key(fluent))

    def values_of_key(self, key: FluentKey) -> frozenset[str]:
        """:meth:`values` of a fluent already given as its key (what :func:`fluent_key` returns)."""
        got = self._values.get(key)
        if got is not None:
            return got
        if key[0] == "hidden_by" and key[1] in self._others and key[1] != key[2]:
            return self._others[key[1]]
        return frozenset((INITIAL_VALUE[key[0]],))

    def holds_at(self, fluent: FluentLike, value: str) -> bool:
        """holds_at(F, V, curr_time)."""
        return value in self.values(fluent)

    def hidden_by_holding(self, trk: str, value: str) -> frozenset[str] | None:
        """Every X with holds_at(hidden_by(trk, X), value), when they are finitely many: the X set
        explicitly whose values include it; None when X's default (the initial value, or what a
        recover(trk) set for every X) includes it, so that any other track may hold it.  Lets a
        caller test a precondition that needs hidden_by(trk, X) = value for those X alone, instead
        of every other track."""
        default = self._others.get(trk)
        if value in (frozenset((INITIAL_VALUE["hidden_by"],)) if default is None else default):
            return None
        explicit = self._hb_index.get(trk, ())
        return frozenset(x for x in explicit if x != trk and value in self._values[("hidden_by", trk, x)])

    def occurs_at(self, event: Union[Term, str], t: int) -> bool:
        """occurs_at(E, t) is in the history folded so far."""
        name, args = _event_parts(event)
        return (f"{name}({','.join(args)})" if args else name, t) in self._occurs

    def started_at(self, trk: str) -> int | None:
        """The greatest Tm with occurs_at(enters_fov(trk), Tm), or None (docs/model-spec.md section 2)."""
        return self._started.get(trk)

    def halted_at(self, trk: str) -> int | None:
        """The greatest Tm with occurs_at(hides_behind(trk,_), Tm) or occurs_at(missing_detections(trk), Tm)."""
        return self._halted.get(trk)

    def snapshot(self, tracks: Iterable[str] | None = None) -> dict[FluentKey, frozenset[str]]:
        """Every fluent of the given (default: current) tracks with its values: for tests and debugging."""
        ids = tuple(self.tracks if tracks is None else tracks)
        out: dict[FluentKey, frozenset[str]] = {}
        for a in ids:
            for name in ("visibility", "clipped", "in_fov"):
                out[(name, a)] = self.values((name, a))
            for b in ids:
                if a != b:
                    out[("hidden_by", a, b)] = self.values(("hidden_by", a, b))
        return out




def poss(event: Union[Term, str], problem: FrameProblem, state: EventState,
         constants: Mapping[str, int]) -> bool:
    """poss(E) for one event over the problem's current tracks/detections; False for unknown ids."""
    name, args = _event_parts(event)
    spec = EVENT_TABLE.get(name)
    if spec is None or len(args) != spec.arity:
        return False
    fn = spec.poss
    if spec.explains == "start":
        return any(d.id == args[0] for d in problem.detections)
    tracks = {t.id: t for t in problem.tracks}
    if any(a not in tracks for a in args):
        return False
    return fn(state, constants, *(tracks[a] for a in args), tracks=tracks)


def possible_events(problem: FrameProblem, state: EventState,
                    constants: Mapping[str, int]) -> dict[str, bool]:
    """poss of every candidate event at curr_time, keyed by its atom string (no spaces).

    Candidates: hides_behind/unhides_from_behind for ordered pairs of distinct current tracks,
    the one-track events for every current track, enters_fov for every detection.
    """
    out: dict[str, bool] = {}
    tracks = problem.tracks
    by_id = {t.id: t for t in tracks}
    for spec in EVENT_TABLE.values():
        if spec.explains == "start":
            for d in problem.detections:
                out[f"{spec.name}({d.id})"] = spec.poss(state, constants, d.id, tracks=by_id)
        elif spec.arity == 1:
            for t in tracks:
                out[f"{spec.name}({t.id})"] = spec.poss(state, constants, t, tracks=by_id)
        else:
            for t1 in tracks:
                for t2 in tracks:
                    if t1.id != t2.id:
                        out[f"{spec.name}({t1.id},{t2.id})"] = spec.poss(state, constants, t1, t2, tracks=by_id)
    return out
