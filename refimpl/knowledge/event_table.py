"""The event table: everything refimpl knows about an event, in one row each (the paper's Table
"Events", Appendix A ``event/1``), and the events' preconditions (``poss``) the rows name.

``EVENT_TABLE`` holds per event its arity, the action it explains, its precondition, its
``causesValue`` effects, its sentence and plot style, and its roles (the halt kind it opens, the
argument naming the occluder, a pair event's prefilter); its place in the table is its place in
the tie-break's order.  The lookups by role (``explaining``, ``halting``, ``HALT_KINDS``, ...) are
what every consumer reads; nobody chooses an event by its name.  The event calculus that folds a
history with these effects, and evaluates the preconditions over a frame problem, is
refimpl.knowledge.events.  The normative text of the preconditions is docs/model-spec.md section 4.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Callable, Mapping, Protocol, Union

from ..core.geometry import intersection_area
from ..core.spec import TrackPrediction
from .relations import near_border, out_of_view, outside_fov, overlapped_from_the_top, overlapping_top


class FluentState(Protocol):
    """What a precondition asks of the fluents' state: refimpl.knowledge.events.EventState (the event
    calculus, which reads this table's effects) answers it."""

    def holds_at(self, fluent, value: str) -> bool: ...

    def hidden_by_holding(self, trk: str, value: str) -> frozenset[str] | None: ...

    def started_at(self, trk: str) -> int | None: ...

    def halted_at(self, trk: str) -> int | None: ...


# ---------------------------------------------------------------------------------------
# Effects (causesValue) as data
# ---------------------------------------------------------------------------------------

OTHERS = "*"
"""In an effect's argument list: every current track X other than the event's first argument."""

Effect = tuple[str, tuple[Union[int, str], ...], str]
"""(fluent, argument positions of the event or OTHERS, value): one causesValue rule."""

# ---------------------------------------------------------------------------------------
# Preconditions (poss), docs/model-spec.md section 4
# ---------------------------------------------------------------------------------------

def _not_hidden(state: FluentState, trk: str) -> bool:
    return not state.holds_at(("visibility", trk), "not_visible")


def poss_hides_behind(state: FluentState, constants: Mapping[str, int],
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


def poss_missing_detections(state: FluentState, constants: Mapping[str, int], trk: TrackPrediction,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """Appendix A: poss(missing_detections(T)) :- holds_at(clipped(T),false),
    not holds_at(visibility(T),not_visible)."""
    return state.holds_at(("clipped", trk.id), "false") and _not_hidden(state, trk.id)


def poss_unhides_from_behind(state: FluentState, constants: Mapping[str, int],
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


def poss_recover(state: FluentState, constants: Mapping[str, int], trk: TrackPrediction,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """refimpl decision (docs/model-spec.md): clipped(T)=true or visibility(T)=not_visible."""
    return state.holds_at(("clipped", trk.id), "true") or state.holds_at(("visibility", trk.id), "not_visible")


def poss_enters_fov(state: FluentState, constants: Mapping[str, int], det_id: str,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """refimpl decision (docs/model-spec.md): always possible for a detection."""
    return True


def poss_leaves_fov(state: FluentState, constants: Mapping[str, int], trk: TrackPrediction,
        *, tracks: Mapping[str, TrackPrediction] | None = None) -> bool:
    """refimpl decision (docs/model-spec.md): in_fov(T)=true and near_border(T), and (docs/model.md
    3.25) out_of_view(T): at most leave_visible % of its anticipated box is inside the image."""
    width, height = constants["img_width"], constants["img_height"]
    return (state.holds_at(("in_fov", trk.id), "true")
            and near_border(trk.box, width, height, constants["border_margin"])
            and out_of_view(trk.box, width, height, constants["leave_visible"]))


def kept_in_mind(state: FluentState, constants: Mapping[str, int], trk: TrackPrediction,
                 tracks: Mapping[str, TrackPrediction]) -> bool:
    """refimpl rule (docs/model.md, "Out of sight, not out of mind"; grows from Section 4.1.2's
    anticipate(unhides_from_behind(T1,T2),T) :- holds_at(hidden_by(T1,T2)), topology(proper_part,T1,T2)):
    a halted track is kept in mind while its predicted box is not entirely outside the field of view
    and either some current track T2 it is hidden_by still overlaps it, or some current track now
    covers it from the front (position(overlapping_top, T, T2)): an occlusion seen only after the
    halt (the track was halted as missing_detections) keeps it in mind too."""
    if outside_fov(trk.box, constants["img_width"], constants["img_height"]):
        return False
    box, hide_overlap = trk.box, constants["hide_overlap"]
    return (any(intersection_area(box, other.box) > 0 for other in _hidden_by(state, trk.id, tracks))
            or overlapped_from_the_top(box, ((t2, other.box) for t2, other in tracks.items()), hide_overlap,
                                       skip=trk.id))


def _hidden_by(state: FluentState, trk: str, tracks: Mapping[str, TrackPrediction]) -> list[TrackPrediction]:
    """The current tracks T2 != trk with holds_at(hidden_by(trk, T2), true), for an any() over them
    (in no order that matters): from the state's few partners (FluentState.hidden_by_holding) where
    it names them, else by asking every track (a crowd's halted track has one or two among hundreds)."""
    partners = state.hidden_by_holding(trk, "true")
    if partners is None:
        return [o for t2, o in tracks.items() if t2 != trk and state.holds_at(("hidden_by", trk, t2), "true")]
    return [tracks[t2] for t2 in partners if t2 in tracks]


def anticipated_unhide(state: FluentState, constants: Mapping[str, int], trk: TrackPrediction,
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
    return any(2 * intersection_area(trk.box, other.box) <= w * h for other in _hidden_by(state, trk.id, tracks))


def poss_lost(state: FluentState, constants: Mapping[str, int], trk: TrackPrediction, *,
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


def poss_noise(state: FluentState, constants: Mapping[str, int], trk: TrackPrediction,
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
    'overlapping_top' (position(overlapping_top, T1, T2)) or 'hidden_by' (visibility(T1) =
    not_visible and hidden_by(T1, T2) = true: only T1's partners of FluentState.hidden_by_holding
    are tested, in the frame's track order, the order of testing every track); empty: every other
    track is tested.  tests/test_event_table.py checks the implication."""
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
        if self.prefilter not in ("", "overlapping_top", "hidden_by") or (self.prefilter and self.arity != 2):
            raise ValueError(f"event {self.name}: prefilter {self.prefilter!r} (pair events: '', "
                             "'overlapping_top' or 'hidden_by')")
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
              occluder=1, prefilter="hidden_by"),
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


def reexplained(state: FluentState, trk: str) -> bool:
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
