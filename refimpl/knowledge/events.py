"""The hand-written event calculus (the paper's Sigma_dyn) and the events' preconditions.

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

from dataclasses import dataclass
from functools import lru_cache
from typing import Callable, Iterable, Mapping, Union

from ..core.geometry import intersection_area
from .relations import near_border, outside_fov, overlapping_top
from ..core.spec import FrameProblem, HistoryEvent, Term, TrackPrediction
from ..core.facts import parse_term

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
# Effects (causesValue) as data
# ---------------------------------------------------------------------------------------

OTHERS = "*"
"""In an effect's argument list: every current track X other than the event's first argument."""

Effect = tuple[str, tuple[Union[int, str], ...], str]
"""(fluent, argument positions of the event or OTHERS, value): one causesValue rule."""

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
    return event.name, tuple(str(a) for a in event.args)


# ---------------------------------------------------------------------------------------
# The state: fluent values after a history
# ---------------------------------------------------------------------------------------

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
                self._set((fluent,) + tuple(args[i] for i in positions), value)  # type: ignore[index]

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


# ---------------------------------------------------------------------------------------
# Preconditions (poss), docs/model-spec.md section 4
# ---------------------------------------------------------------------------------------

def _not_hidden(state: EventState, trk: str) -> bool:
    return not state.holds_at(("visibility", trk), "not_visible")


def poss_hides_behind(state: EventState, constants: Mapping[str, int],
                      trk1: TrackPrediction, trk2: TrackPrediction,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """Appendix A: poss(hides_behind(T1,T2)) :- position(overlapping_top,T1,T2),
    not holds_at(visibility(T1),not_visible), not holds_at(visibility(T2),not_visible).
    overlapping_top is refimpl.knowledge.relations.overlapping_top (refimpl decision, docs/model-spec.md section 3)."""
    return (
        trk1.id != trk2.id
        and overlapping_top(trk1.box, trk2.box, constants["hide_overlap"])
        and _not_hidden(state, trk1.id)
        and _not_hidden(state, trk2.id)
    )


def poss_missing_detections(state: EventState, constants: Mapping[str, int], trk: TrackPrediction,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """Appendix A: poss(missing_detections(T)) :- holds_at(clipped(T),false),
    not holds_at(visibility(T),not_visible)."""
    return state.holds_at(("clipped", trk.id), "false") and _not_hidden(state, trk.id)


def poss_unhides_from_behind(state: EventState, constants: Mapping[str, int],
                             trk1: TrackPrediction, trk2: TrackPrediction,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """Section 4.1.1: poss(unhides_from_behind(T1,T2)) :- holds_at(visibility(T1),not_visible),
    not holds_at(visibility(T2),not_visible); refimpl decision (docs/model-spec.md): also
    T1 != T2 and holds_at(hidden_by(T1,T2),true)."""
    return (
        trk1.id != trk2.id
        and state.holds_at(("hidden_by", trk1.id, trk2.id), "true")
        and state.holds_at(("visibility", trk1.id), "not_visible")
        and _not_hidden(state, trk2.id)
    )


def poss_recover(state: EventState, constants: Mapping[str, int], trk: TrackPrediction,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """refimpl decision (docs/model-spec.md): clipped(T)=true or visibility(T)=not_visible."""
    return state.holds_at(("clipped", trk.id), "true") or state.holds_at(("visibility", trk.id), "not_visible")


def poss_enters_fov(state: EventState, constants: Mapping[str, int], det_id: str,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """refimpl decision (docs/model-spec.md): always possible for a detection."""
    return True


def poss_leaves_fov(state: EventState, constants: Mapping[str, int], trk: TrackPrediction,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """refimpl decision (docs/model-spec.md): in_fov(T)=true and near_border(T)."""
    return state.holds_at(("in_fov", trk.id), "true") and near_border(
        trk.box, constants["img_width"], constants["img_height"], constants["border_margin"])


def kept_in_mind(state: EventState, constants: Mapping[str, int], trk: TrackPrediction,
                 tracks: Mapping[str, TrackPrediction]) -> bool:
    """refimpl rule (docs/model.md, "Out of sight, not out of mind"; grows from Section 4.1.2's
    anticipate(unhides_from_behind(T1,T2),T) :- holds_at(hidden_by(T1,T2)), topology(proper_part,T1,T2)):
    a halted track is kept in mind while its predicted box is not entirely outside the field of view
    and either some current track T2 it is hidden_by still overlaps it, or some current track now
    covers it from the front (position(overlapping_top, T, T2)): an occlusion seen only after the
    halt (the track was halted as missing_detections) keeps it in mind too."""
    if outside_fov(trk.box, constants["img_width"], constants["img_height"]):
        return False
    return any(t2 != trk.id and (
        (state.holds_at(("hidden_by", trk.id, t2), "true") and intersection_area(trk.box, other.box) > 0)
        or overlapping_top(trk.box, other.box, constants["hide_overlap"])) for t2, other in tracks.items())


def anticipated_unhide(state: EventState, constants: Mapping[str, int], trk: TrackPrediction,
                       tracks: Mapping[str, TrackPrediction]) -> bool:
    """refimpl rule (docs/model.md 3.17, events.lp [anticipated_unhide]; grows from Section 4.1.2's
    anticipate(unhides_from_behind(T1,T2),T) :- holds_at(hidden_by(T1,T2)), topology(proper_part,T1,T2),
    movement(moves_out_of,T1,T2,T)): a hidden track is anticipated to unhide now when its predicted
    box has moved out of the box of a current track T2 it is hidden_by, at least half of it:
    2 * inter(T1, T2) <= W1 * H1.  Then a detection there may resume it with the confidence a new
    track needs (association.lp [resume_constraints], second rule)."""
    if not state.holds_at(("visibility", trk.id), "not_visible"):
        return False
    w, h = trk.box[2], trk.box[3]
    return any(t2 != trk.id and state.holds_at(("hidden_by", trk.id, t2), "true")
               and 2 * intersection_area(trk.box, other.box) <= w * h for t2, other in tracks.items())


def poss_lost(state: EventState, constants: Mapping[str, int], trk: TrackPrediction, *,
              tracks: Mapping[str, TrackPrediction]) -> bool:
    """refimpl decision (docs/model.md): halted_at(T,Tm) and either curr_time - Tm >= L and T is not
    kept in mind (L = lost_after_hidden if visibility(T)=not_visible and not clipped(T)=true, else
    lost_after_missing: a track that went missing keeps that bound after it is re-explained as
    hidden, 3.18), or curr_time - Tm >= lost_after_hidden_max (the safety bound, whatever the scene says)."""
    tm = state.halted_at(trk.id)
    if tm is None:
        return False
    age = constants["curr_time"] - tm
    if age >= constants["lost_after_hidden_max"]:
        return True
    hidden = (state.holds_at(("visibility", trk.id), "not_visible")
              and not state.holds_at(("clipped", trk.id), "true"))
    limit = constants["lost_after_hidden"] if hidden else constants["lost_after_missing"]
    return age >= limit and not kept_in_mind(state, constants, trk, tracks)


def poss_noise(state: EventState, constants: Mapping[str, int], trk: TrackPrediction,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """refimpl decision (docs/model-spec.md): started_at(T,Tm) and curr_time - Tm <= noise_max_age."""
    tm = state.started_at(trk.id)
    return tm is not None and constants["curr_time"] - tm <= constants["noise_max_age"]


# ---------------------------------------------------------------------------------------
# The event table: one place for everything refimpl knows about an event
# ---------------------------------------------------------------------------------------

EXPLAINED_ACTIONS = ("halt", "resume", "start", "end")
"""The actions that need exactly one explaining event (assign and the ignores need none)."""


@dataclass(frozen=True)
class EventType:
    """One abducible event of the paper's Table "Events" (Appendix A ``event/1``).

    Every consumer derives what it needs from here: the event calculus (effects, started_at /
    halted_at), the CP-SAT model and its fast path (which action it explains, its cost, its
    precondition), the independent checker (arity, explanation rule, precondition), the scene
    (episodes and sentences) and the plots (marker and colour).  model/events.lp holds the same
    event as ASP rules; tests/test_event_table.py fails when the two disagree or a consumer
    misses an event.
    """

    name: str
    arity: int
    """2 for a pair of tracks (Trk1, Trk2); 1 for one track (or, for ``start``, one detection)."""
    explains: str
    """The action it explains (explain_* rules): halt, resume, start or end."""
    poss: Callable[..., bool]
    """Its precondition: poss(state, constants, *arguments as TrackPrediction (or the det id for a
    start), tracks=the frame's current tracks by id) -- some preconditions look at other tracks."""
    effects: tuple[Effect, ...]
    """causesValue rules: (fluent, argument positions or OTHERS, value)."""
    phrase: str
    """How a sentence says it happened to a track, followed by the second track for a pair event
    ('went out of sight behind', 'came out from behind', 'was given up as lost', ...)."""
    marker: str
    colour: str
    """Its marker and colour in plots."""
    closing: str = ""
    """How a sentence says a halt ended with it ('reappeared', 'was detected again', ...).  Empty:
    the halt_kind of a halting event, else the phrase."""

    also_explains: tuple[str, ...] = ()
    """Actions it explains when they must be re-explained (REEXPLAINED): hides_behind also explains
    the ignore_trk of a missing track that a current track now covers (events.lp [explain_ignore])."""

    # -- roles: what the consumers need to know about it, so that none of them names an event --
    halt_kind: str = ""
    """For an event explaining a halt: the kind of halt it opens, as the scene and its queries call
    it ('hidden', 'missing'); a halt episode, track_summary and the sentences read it.  Required
    for a halting event, empty for every other."""
    occluder: int | None = None
    """The argument position of the track in front (hides_behind(T1, T2), unhides_from_behind(T1,
    T2): 1), None when the event names no occluder.  A halt with an occluder starts a hiding episode
    (scene, occlusion benchmark); a resume with one ends it by coming out from behind (tracker's
    fill_hidden, anticipation scoring)."""
    prefilter: str = ""
    """For a pair event: a condition its precondition implies that the CP-SAT model tests for all
    pairs at once before calling ``poss`` (a speed-up only, the same answers):
    'overlapping_top' (position(overlapping_top, T1, T2)) or 'hidden' (visibility(T1) = not_visible);
    empty: every other track is tested.  tests/test_event_table.py checks the implication."""
    says_since: bool = False
    """Its sentence says since when the track was seen ('..., seen since frame 12, was discarded
    as noise')."""

    def __post_init__(self) -> None:
        if self.explains not in EXPLAINED_ACTIONS:
            raise ValueError(f"event {self.name}: explains {self.explains!r}, not one of {EXPLAINED_ACTIONS}")
        if (self.explains == "halt") != bool(self.halt_kind):
            raise ValueError(f"event {self.name}: a halt_kind is required for a halting event and only there")
        if self.occluder is not None and not 0 < self.occluder < self.arity:
            raise ValueError(f"event {self.name}: occluder {self.occluder} is not a second argument")
        if self.prefilter not in ("", "overlapping_top", "hidden") or (self.prefilter and self.arity != 2):
            raise ValueError(f"event {self.name}: prefilter {self.prefilter!r} (pair events: '', "
                             "'overlapping_top' or 'hidden')")
        if not self.closing:
            object.__setattr__(self, "closing", self.halt_kind or self.phrase)

    @property
    def hides(self) -> bool:
        """It ends the first track's visibility: one of its effects is visibility(T1) := not_visible."""
        return ("visibility", (0,), "not_visible") in self.effects

    @property
    def unhides(self) -> bool:
        """It resumes a track by coming out from behind its occluder."""
        return self.explains == "resume" and self.occluder is not None

    @property
    def cost_constant(self) -> str:
        """The model constant holding its priority-1 cost (model/constants.lp)."""
        return f"cost_{self.name}"


EVENT_TABLE: Mapping[str, EventType] = {e.name: e for e in (
    # Appendix A: causesValue(hides_behind(T1,T2), visibility(T1), not_visible) and
    # causesValue(hides_behind(T1,T2), hidden_by(T1,T2), true); refimpl decision (docs/model.md
    # 3.16): it also re-explains the ignore of a missing track (explain_ignore) and leaves its
    # clipped = true (3.18: such a track keeps the lost_after_missing bound).
    EventType("hides_behind", 2, "halt", poss_hides_behind,
              effects=(("visibility", (0,), "not_visible"), ("hidden_by", (0, 1), "true")),
              phrase="went out of sight behind", marker="v", colour="#d62728",
              also_explains=("ignore_trk",), halt_kind="hidden", occluder=1, prefilter="overlapping_top"),
    # Appendix A: causesValue(missing_detections(T), clipped(T), true).
    EventType("missing_detections", 1, "halt", poss_missing_detections, effects=(("clipped", (0,), "true"),),
              phrase="was missed by the detector", marker="x", colour="#e377c2", halt_kind="missing"),
    # refimpl decision (docs/model-spec.md): the inverse of hides_behind; and clipped(T1) := false
    # (docs/model.md 3.18: a missing track re-explained as hidden is still clipped), so that a
    # resume leaves every fluent at its initial value.
    EventType("unhides_from_behind", 2, "resume", poss_unhides_from_behind,
              effects=(("visibility", (0,), "fully_visible"), ("hidden_by", (0, 1), "false"),
                       ("clipped", (0,), "false")),
              phrase="came out from behind", closing="reappeared", marker="^", colour="#9467bd",
              occluder=1, prefilter="hidden"),
    # refimpl decision (docs/model-spec.md): recover resets everything halting may have set.
    EventType("recover", 1, "resume", poss_recover,
              effects=(("clipped", (0,), "false"), ("visibility", (0,), "fully_visible"),
                       ("hidden_by", (0, OTHERS), "false")),
              phrase="was detected again", marker="+", colour="#17becf"),
    # refimpl decision (docs/model-spec.md), after the paper's in_fov fluent.
    EventType("enters_fov", 1, "start", poss_enters_fov, effects=(("in_fov", (0,), "true"),),
              phrase="entered the field of view", marker=">", colour="#2ca02c"),
    EventType("leaves_fov", 1, "end", poss_leaves_fov, effects=(("in_fov", (0,), "false"),),
              phrase="left the field of view", marker="<", colour="#8c564b"),
    # refimpl decision (docs/model-spec.md): the track ends, nothing to record.
    EventType("lost", 1, "end", poss_lost, effects=(), phrase="was given up as lost", marker="s", colour="#000000"),
    EventType("noise", 1, "end", poss_noise, effects=(), phrase="was discarded as noise", marker="D",
              colour="#bcbd22", says_since=True),
)}
"""event name -> EventType, in the order of the paper's Table "Events"."""

@lru_cache(maxsize=None)
def explaining(action: str) -> tuple[EventType, ...]:
    """The events that may explain an action, in table order (() for assign and ignore_det; for
    ignore_trk the events that re-explain a missing track, see :func:`reexplained`)."""
    return tuple(e for e in EVENT_TABLE.values() if e.explains == action or action in e.also_explains)


def halting(kind: str) -> EventType | None:
    """The halting event whose halt_kind is ``kind`` ('hidden', 'missing', ...), else None."""
    return next((e for e in explaining("halt") if e.halt_kind == kind), None)


HALT_KINDS = tuple(e.halt_kind for e in EVENT_TABLE.values() if e.explains == "halt")
"""The kinds of halt a scene tells apart, in table order ('hidden', 'missing')."""
HIDING_KINDS = tuple(e.halt_kind for e in EVENT_TABLE.values() if e.explains == "halt" and e.occluder is not None)
"""The halt kinds with an occluder (a hiding episode: 'hidden')."""


REEXPLAINED = ("ignore_trk",)
"""Actions explained only when :func:`reexplained` says so (events.lp [explain_ignore])."""


def reexplained(state: EventState, trk: str) -> bool:
    """refimpl rule (docs/model.md 3.16, events.lp [explain_ignore]): an ignored halted track that
    is clipped (halted as missing_detections) must be explained by one possible event of
    explaining('ignore_trk') when there is one: the track that now covers it from the front is why
    it is still unseen, so it hides behind that track (hides_behind needs it not not_visible, so
    this happens once per halt)."""
    return state.holds_at(("clipped", trk), "true")


EVENT_NAMES = tuple(EVENT_TABLE)
EFFECTS: Mapping[str, tuple[int, tuple[Effect, ...]]] = {n: (e.arity, e.effects) for n, e in EVENT_TABLE.items()}
"""event name -> (arity, effects): an event whose name is not here, or whose arity differs, has
no effect (it matches no causesValue rule)."""
COST_CONSTANT: Mapping[str, str] = {n: e.cost_constant for n, e in EVENT_TABLE.items()}
POSS: Mapping[str, Callable[..., bool]] = {n: e.poss for n, e in EVENT_TABLE.items()}
_HALTING = frozenset(e.name for e in explaining("halt"))
_STARTING = frozenset(e.name for e in explaining("start"))


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
