"""The scene as data: motion tracks, the event log and the fluent timelines replayed from it.

A :class:`Scene` is the paper's explanation EXP = <H^events, MT> of one sequence, frozen: the
motion tracks (observed boxes, halted spans with their Kalman-predicted boxes, end), the abduced
event log, and the fluent timelines obtained by replaying the events with
:class:`refimpl.knowledge.events.EventState` frame by frame (time semantics: refimpl.scene's package doc).
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from typing import Iterable, Mapping, Sequence

from ..knowledge.events import EventState
from ..knowledge.event_table import EVENT_TABLE
from ..core.errors import UserFacingError
from ..core.spec import HistoryEvent, Term, natural_key


Box = tuple[float, float, float, float]


class SceneError(ValueError, UserFacingError):
    """A user mistake with a scene (bad scene file, bad query, unknown track): one line, exit 2."""


@dataclass(frozen=True)
class SceneTrack:
    """One motion track: observed boxes, halted frames with Kalman-predicted boxes, end."""

    id: str
    type: str
    observed: tuple[tuple[int, Box], ...]
    """(frame, box) for every frame a detection was assigned to it (or resumed it), in frame order."""
    halted: tuple[tuple[int, Box], ...]
    """(frame, predicted box) for every frame it was halted (unobserved), in frame order."""
    ended_at: int | None
    """The frame of its end action (lost, noise or leaves_fov), None if alive at the end."""
    _obs: dict = field(init=False, repr=False, compare=False)
    _obs_frames: tuple = field(init=False, repr=False, compare=False)
    _halt: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_obs", dict(self.observed))
        object.__setattr__(self, "_obs_frames", tuple(f for f, _ in self.observed))
        object.__setattr__(self, "_halt", dict(self.halted))

    @property
    def number(self) -> int | str:
        """12 for trk_12 (the id itself when it has no number)."""
        key = natural_key(self.id)
        return key[1] if key[1] >= 0 else self.id

    @property
    def first_frame(self) -> int:
        return min([f for f, _ in self.observed[:1]] + [f for f, _ in self.halted[:1]])

    def last_frame(self, scene_last: int) -> int:
        """The last frame of its life: its end action, or the scene's last frame if it never ended."""
        return self.ended_at if self.ended_at is not None else scene_last

    def observed_box(self, frame: int) -> Box | None:
        return self._obs.get(frame)

    def box_at(self, frame: int) -> tuple[str, Box] | None:
        """('observed', box) or ('halted', predicted box) at frame, or None."""
        if frame in self._obs:
            return "observed", self._obs[frame]
        if frame in self._halt:
            return "halted", self._halt[frame]
        return None

    def observed_until(self, frame: int, count: int) -> list[tuple[int, Box]]:
        """The last ``count`` observations at or before frame, oldest first."""
        i = bisect.bisect_right(self._obs_frames, frame)
        return list(self.observed[max(0, i - count):i])


@dataclass(frozen=True)
class Scene:
    """A tracked sequence: tracks, event log and fluent timelines (JSON: :func:`save_scene`)."""

    name: str
    image_size: tuple[int, int] | None
    first_frame: int
    last_frame: int
    fps: float | None
    tracks: tuple[SceneTrack, ...]
    events: tuple[HistoryEvent, ...]
    """The event log occurs_at(E, t) in time order (the tracker's order within a frame)."""
    timelines: tuple[tuple[str, tuple[tuple[int, int, str], ...]], ...]
    """(fluent atom, ((from_frame, to_frame, value), ...)) over the life of the fluent's track."""
    _by_id: dict = field(init=False, repr=False, compare=False)
    _timeline_map: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_by_id", {t.id: t for t in self.tracks})
        object.__setattr__(self, "_timeline_map", dict(self.timelines))

    def track(self, trk_id: str) -> SceneTrack:
        try:
            return self._by_id[trk_id]
        except KeyError:
            raise SceneError(f"no track {trk_id} in scene {self.name} ({_id_range(self)})") from None

    def has_track(self, trk_id: str) -> bool:
        return trk_id in self._by_id

    def timeline(self, fluent: str) -> tuple[tuple[int, int, str], ...]:
        """The intervals of one fluent atom, e.g. 'visibility(trk_13)' (empty if not recorded)."""
        return self._timeline_map.get(fluent.replace(" ", ""), ())

    def life(self, trk_id: str) -> tuple[int, int]:
        t = self.track(trk_id)
        return t.first_frame, t.last_frame(self.last_frame)


def _id_range(scene: Scene) -> str:
    if not scene.tracks:
        return "it has no tracks"
    ids = sorted((t.id for t in scene.tracks), key=natural_key)
    return f"{len(ids)} tracks, {ids[0]} .. {ids[-1]}"


def _round_box(box: Sequence[float]) -> Box:
    return tuple(round(float(v), 2) for v in box)  # type: ignore[return-value]


def _track_lives(tracks: Iterable[SceneTrack], last_frame: int) -> dict[str, tuple[int, int]]:
    return {t.id: (t.first_frame, t.last_frame(last_frame)) for t in tracks if t.observed or t.halted}


_HIDDEN_BY_PAIRS = frozenset(e.name for e in EVENT_TABLE.values()
                              if any(f == "hidden_by" and pos == (0, 1) for f, pos, _ in e.effects))
"""Events that set hidden_by(T1, T2) for the pair they name."""


def fluent_timelines(events: Iterable[HistoryEvent], lives: Mapping[str, tuple[int, int]]
                     ) -> dict[str, tuple[tuple[int, int, str], ...]]:
    """Replay the events with EventState frame by frame: each fluent's (from, to, value) intervals.

    ``lives`` maps a track id to its (first, last) frame; a track's fluents visibility, clipped
    and in_fov are recorded over its life, and hidden_by(T1, T2) over T1's life for every pair
    that some hides_behind / unhides_from_behind event names (all other pairs are false
    throughout).  The value at frame f is holds_at(F, V, f): the events before f folded.  A
    set-valued fluent gives one interval per value, overlapping.
    """
    events = sorted(events, key=lambda e: e.time)
    by_time: dict[int, list[Term]] = {}
    for e in events:
        by_time.setdefault(e.time, []).append(e.event)
    pairs = sorted({(str(e.event.args[0]), str(e.event.args[1])) for e in events
                    if e.event.name in _HIDDEN_BY_PAIRS and len(e.event.args) == 2},
                   key=lambda p: (natural_key(p[0]), natural_key(p[1])))
    fluents: list[tuple[str, tuple[str, ...], int, int]] = []  # (atom, key, first, last)
    for trk in sorted(lives, key=natural_key):
        a, b = lives[trk]
        for name in ("visibility", "clipped", "in_fov"):
            fluents.append((f"{name}({trk})", (name, trk), a, b))
    for t1, t2 in pairs:
        if t1 in lives and t1 != t2:
            a, b = lives[t1]
            fluents.append((f"hidden_by({t1},{t2})", ("hidden_by", t1, t2), a, b))
    out: dict[str, list[tuple[int, int, str]]] = {f[0]: [] for f in fluents}
    if not fluents:
        return {}
    lo = min(f[2] for f in fluents)
    hi = max(f[3] for f in fluents)
    starting: dict[int, list[int]] = {}
    for i, f in enumerate(fluents):
        starting.setdefault(f[2], []).append(i)
    state = EventState()
    for t in sorted(by_time):
        if t < lo:
            state.apply(by_time[t], t)
    live: set[int] = set()
    current: dict[int, tuple[frozenset[str], int]] = {}

    def close(i: int, last: int) -> None:
        values, since = current.pop(i)
        for v in sorted(values):
            out[fluents[i][0]].append((since, last, v))

    for f in range(lo, hi + 1):
        live.update(starting.get(f, ()))
        for i in sorted(live):
            values = state.values(fluents[i][1])
            if i in current and current[i][0] != values:
                close(i, f - 1)
            if i not in current:
                current[i] = (values, f)
            if fluents[i][3] == f:  # the fluent's last frame
                close(i, f)
                live.discard(i)
        state.apply(by_time.get(f, ()), f)
    return {k: tuple(v) for k, v in out.items()}


def make_scene(name: str, tracks: Iterable[SceneTrack], events: Iterable[HistoryEvent],
               first_frame: int, last_frame: int, image_size: tuple[int, int] | None = None,
               fps: float | None = None) -> Scene:
    """A scene from tracks and an event log; the fluent timelines are computed here."""
    tracks = tuple(sorted(tracks, key=lambda t: natural_key(t.id)))
    events = tuple(sorted(events, key=lambda e: e.time))  # stable: keeps the order within a frame
    lines = fluent_timelines(events, _track_lives(tracks, last_frame))
    size = (int(image_size[0]), int(image_size[1])) if image_size else None
    return Scene(name, size, int(first_frame), int(last_frame), None if fps is None else float(fps),
                 tracks, events, tuple(lines.items()))


def scene_from_result(seq, result) -> Scene:
    """The scene of a tracked DetectionSequence (refimpl.io) and its TrackingResult (refimpl.tracking.tracker)."""
    tracks = [SceneTrack(r.id, r.type,
                         tuple((int(f), _round_box(b)) for f, b in r.observed),
                         tuple((int(f), _round_box(b)) for f, b in r.halted),
                         r.ended_at) for r in result.tracks]
    first = seq.frames[0].frame if seq.frames else seq.first_frame
    last = seq.frames[-1].frame if seq.frames else seq.first_frame - 1
    return make_scene(seq.name, tracks, result.events, first, last, seq.image_size, seq.fps)


def frame_runs(frames: Iterable[int]) -> list[tuple[int, int]]:
    """Sorted frames as maximal runs of consecutive frames: [(first, last), ...]."""
    out: list[list[int]] = []
    for f in sorted(set(frames)):
        if out and f == out[-1][1] + 1:
            out[-1][1] = f
        else:
            out.append([f, f])
    return [(a, b) for a, b in out]


def track_id(scene: Scene, text: str) -> str:
    """The id of a track named as in a query ('13' or 'trk_13'); an unknown id is a SceneError."""
    ident = f"trk_{text}" if text.isdigit() else text
    scene.track(ident)
    return ident
