"""The event state both paths of the CP-SAT backend query (the fast path and the full model):
``TrackwiseState``, one memoised EventState per track."""

from __future__ import annotations

from typing import Sequence

from ..core.spec import Term
from ..knowledge.events import EventState, fluent_key


class TrackwiseState:
    """The queries of an EventState (values, holds_at, started_at, halted_at) answered from one
    EventState per track, each folded from that track's own events only, and memoised.

    Exact because every effect, start and halt time of an event concerns its first argument only
    (refimpl.knowledge.event_table.EFFECTS: each effect's fluent has the event's first argument as its own first
    argument; recover's "hidden_by(T, X) for every X" too), and the set-valued grouping of one
    time point is per fluent; folding a track's events in time order (stable, as EventState does)
    gives that track's fluents exactly.  Per-track states, with the holds_at answers they gave, are
    reused across frames while the track's events are unchanged (``cache``), so a tracker's frame
    folds only new events and asks each state only what no earlier frame asked;
    ``used`` holds the entries this frame needed, the cache to pass to the next frame: track ->
    (its events, their state and memo).  A track's entry is reused where its events are equal to
    the entry's (a tuple comparison, which takes the tracker's own event objects, the same from
    frame to frame, by identity: no event is hashed)."""

    _EMPTY = EventState()

    def __init__(self, history: Sequence, tracks: Sequence[str],
                 cache: dict[str, tuple[tuple, tuple[EventState, dict]]] | None = None):
        groups: dict[str, list] = {}
        for h in history:
            args = h.event.args
            if args:  # events without arguments have no effect (no EFFECTS entry of arity 0)
                a0 = args[0]  # str(Term) of a constant is its name
                groups.setdefault(a0.name if type(a0) is Term and not a0.args else str(a0), []).append(h)
        cache = {} if cache is None else cache
        # per track: its EventState and the memo of its holds_at answers, which never change (the
        # state is folded once from the track's events; a new event makes a new key)
        self.used: dict[str, tuple[tuple, tuple[EventState, dict]]] = {}
        self._per: dict[str, tuple[EventState, dict]] = {}
        for trk in tracks:
            events = groups.get(trk)
            if not events:
                continue
            key = tuple(events)
            got = cache.get(trk)
            if got is not None and got[0] == key:
                entry = got[1]
            else:
                entry = (EventState(events, (trk,)), {})
            self.used[trk] = (key, entry)
            self._per[trk] = entry
        self._empty = (self._EMPTY, {})

    def _state(self, trk: str) -> EventState:
        return self._per.get(trk, self._empty)[0]

    def values(self, fluent) -> frozenset[str]:
        key = fluent_key(fluent)
        return self._state(key[1]).values_of_key(key)

    def holds_at(self, fluent, value: str) -> bool:
        key = fluent_key(fluent)
        st, memo = self._per.get(key[1], self._empty)
        memo_key = (key, value)
        got = memo.get(memo_key)
        if got is None:
            got = memo[memo_key] = value in st.values_of_key(key)
        return got

    def hidden_by_holding(self, trk: str, value: str) -> frozenset[str] | None:
        """EventState.hidden_by_holding from trk's own state (hidden_by(trk, X) is trk's fluent),
        memoised with its holds_at answers (keyed (trk, value), where theirs are (fluent tuple, value))."""
        st, memo = self._per.get(trk, self._empty)
        memo_key = (trk, value)
        if memo_key in memo:
            return memo[memo_key]
        got = memo[memo_key] = st.hidden_by_holding(trk, value)
        return got

    def started_at(self, trk: str) -> int | None:
        return self._state(trk).started_at(trk)

    def halted_at(self, trk: str) -> int | None:
        return self._state(trk).halted_at(trk)
