"""Scenes: a tracked sequence as data to reason about (queries, explanations, anticipation, situations).

A :class:`Scene` is the paper's explanation EXP = <H^events, MT> of one sequence, frozen and
JSON-serialisable: the motion tracks (observed boxes, halted spans with their Kalman-predicted
boxes, end), the abduced event log, and the fluent timelines obtained by replaying the events
with :class:`refimpl.events.EventState` frame by frame.  On top of it this module answers:

* queries (``query(scene, "hidden_by trk_12")``; the forms are in :data:`QUERY_FORMS`);
* explanations: the event log as one English sentence per episode (:func:`explain`);
* anticipation of hidden entities (paper Section 4.1.2): ``anticipate(unhides_from_behind(T1,T2),T)``,
  ``interpolated_position(T1,T)`` and ``warning(hidden_entity_in_front(T1,T))`` (:func:`anticipate`),
  and its evaluation against the actual reappearances of real sequences
  (:func:`evaluate_anticipation`, ``python -m refimpl.scene anticipation-eval``);
* safety-critical situations of the paper's Table 5 that boxes support: HIDDEN_ENTITY and
  SUDDEN_STOP (:func:`situations`).

Time semantics (docs/model-spec.md section 2): an event that occurs at t sets its fluents from
t + 1 on, so ``holds_at(F, V, t)`` is the value after the events of the frames before t.  A
track hidden by ``hides_behind`` at 235 and resumed by ``unhides_from_behind`` at 268 is halted
(unobserved) at frames 235..267, and ``hidden_by`` is true at frames 236..268.

docs/reasoning.md is the user guide: query language, definitions, evaluation and examples.
"""

from __future__ import annotations

import bisect
import json
import math
import os
import statistics
import sys
from dataclasses import dataclass, field, replace
from typing import Callable, Iterable, Mapping, Sequence

from . import relations as rel
from .events import EVENT_TABLE, EventState, explaining
from .spec import HistoryEvent, ProblemFormatError, Term, natural_key, parse_term

SCENE_FORMAT = "refimpl-scene"
SCENE_VERSION = 1

Box = tuple[float, float, float, float]


class SceneError(ValueError):
    """A user mistake with a scene (bad scene file, bad query, unknown track): one line, exit 2."""


# ---------------------------------------------------------------------------------------
# The scene
# ---------------------------------------------------------------------------------------

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

    def halted_box(self, frame: int) -> Box | None:
        return self._halt.get(frame)

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

    def type_of(self, trk_id: str) -> str | None:
        t = self._by_id.get(trk_id)
        return t.type if t is not None else None


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
    """The scene of a tracked DetectionSequence (refimpl.io) and its TrackingResult (refimpl.tracker)."""
    tracks = [SceneTrack(r.id, r.type,
                         tuple((int(f), _round_box(b)) for f, b in r.observed),
                         tuple((int(f), _round_box(b)) for f, b in r.halted),
                         r.ended_at) for r in result.tracks]
    first = seq.frames[0].frame if seq.frames else seq.first_frame
    last = seq.frames[-1].frame if seq.frames else seq.first_frame - 1
    return make_scene(seq.name, tracks, result.events, first, last, seq.image_size, seq.fps)


# ---------------------------------------------------------------------------------------
# JSON
# ---------------------------------------------------------------------------------------

def scene_to_json(scene: Scene) -> dict:
    """The scene as a JSON-ready dict (the file format of :func:`save_scene`)."""
    return {
        "format": SCENE_FORMAT,
        "version": SCENE_VERSION,
        "name": scene.name,
        "image_size": list(scene.image_size) if scene.image_size else None,
        "fps": scene.fps,
        "first_frame": scene.first_frame,
        "last_frame": scene.last_frame,
        "tracks": [{"id": t.id, "type": t.type,
                    "observed": [[f, *b] for f, b in t.observed],
                    "halted": [[f, *b] for f, b in t.halted],
                    "ended_at": t.ended_at} for t in scene.tracks],
        "events": [str(e) for e in scene.events],
        "timelines": {k: [list(i) for i in v] for k, v in scene.timelines},
    }


def _need(cond: bool, what: str) -> None:
    if not cond:
        raise SceneError(what)


def _int(v, what: str) -> int:
    _need(isinstance(v, int) and not isinstance(v, bool), f"{what} must be an integer, got {v!r}")
    return v


SCENE_MAX_COORD = 1_000_000.0
"""Box coordinates and sizes beyond this magnitude (pixels) are refused, as in refimpl.io."""
SCENE_MAX_IMAGE = 100_000
"""image_size entries must be 1..SCENE_MAX_IMAGE pixels."""


def _boxes(rows, what: str) -> tuple[tuple[int, Box], ...]:
    """[frame, x, y, w, h] rows: frames strictly increasing, finite coordinates, positive sizes."""
    _need(isinstance(rows, list), f"{what} must be a list")
    out = []
    for row in rows:
        _need(isinstance(row, list) and len(row) == 5
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row),
              f"{what}: each entry must be [frame, x, y, w, h], got {row!r:.80}")
        frame = _int(row[0], f"{what}: frame")
        _need(all(abs(v) <= SCENE_MAX_COORD or v != v for v in row[1:]),  # (NaN is caught below)
              f"{what}: frame {frame}: box coordinates must be finite numbers within +-{SCENE_MAX_COORD:g}")
        box = tuple(float(v) for v in row[1:])
        _need(all(math.isfinite(v) and abs(v) <= SCENE_MAX_COORD for v in box),
              f"{what}: frame {frame}: box coordinates must be finite numbers within +-{SCENE_MAX_COORD:g}, "
              f"got {list(box)}")
        _need(box[2] > 0 and box[3] > 0, f"{what}: frame {frame}: box width and height must be > 0, got {list(box)}")
        _need(not out or frame > out[-1][0],
              f"{what}: frames must be strictly increasing, got {frame} after {out[-1][0] if out else ''}")
        out.append((frame, box))
    return tuple(out)  # type: ignore[return-value]


def _event(text, i: int) -> HistoryEvent:
    from .events import EFFECTS
    _need(isinstance(text, str), f"events[{i}] must be a string 'occurs_at(E,T)'")
    try:
        term = parse_term(text)
    except ProblemFormatError as exc:
        raise SceneError(f"events[{i}]: {exc.reason}") from None
    _need(term.name == "occurs_at" and len(term.args) == 2 and term.args[1].is_int,
          f"events[{i}] is not occurs_at(E,T): {text!r:.80}")
    event = term.args[0]
    known = EFFECTS.get(event.name)
    _need(known is not None, f"events[{i}]: unknown event {event.name!r} (known: {', '.join(EFFECTS)})")
    _need(len(event.args) == known[0] and all(not a.args and not a.is_int for a in event.args),
          f"events[{i}]: {event.name} takes {known[0]} track id(s), got {text!r:.80}")
    return HistoryEvent(event, term.args[1].as_int())


def _check_scene(scene: "Scene") -> None:
    """Everything query / explain / plot rely on, beyond the types (SceneError otherwise)."""
    lo, hi = scene.first_frame, scene.last_frame
    _need(lo <= hi, f"first_frame {lo} is after last_frame {hi}")
    if scene.image_size is not None:
        _need(all(1 <= v <= SCENE_MAX_IMAGE for v in scene.image_size),
              f"image_size must be two sizes 1..{SCENE_MAX_IMAGE}, got {list(scene.image_size)}")
    _need(scene.fps is None or (math.isfinite(scene.fps) and scene.fps > 0), f"fps must be > 0, got {scene.fps}")
    seen: set[str] = set()
    for t in scene.tracks:
        _need(t.id not in seen, f"duplicate track id {t.id!r}")
        seen.add(t.id)
        _need(bool(t.observed), f"track {t.id} has no observed box (every track starts with one)")
        frames = [f for f, _ in t.observed] + [f for f, _ in t.halted]
        _need(all(lo <= f <= hi for f in frames), f"track {t.id} has a box outside frames {lo}..{hi}")
        _need(len(set(frames)) == len(frames), f"track {t.id} is both observed and halted in one frame")
        if t.ended_at is not None:
            _need(t.observed[-1][0] <= t.ended_at <= hi,
                  f"track {t.id} ends at {t.ended_at}, before its last observation or after last_frame")
    last = None
    for i, e in enumerate(scene.events):
        _need(lo <= e.time <= hi, f"events[{i}] {e} is outside frames {lo}..{hi}")
        _need(last is None or e.time >= last, f"events[{i}] {e} is out of time order")
        last = e.time
    for k, v in scene.timelines:
        _need(all(a <= b for a, b, _ in v), f"timelines[{k!r}]: an interval ends before it starts")


def scene_from_json(data) -> Scene:
    """Inverse of :func:`scene_to_json`; SceneError (without the file name) on anything malformed."""
    _need(isinstance(data, dict), "the top level must be a JSON object")
    _need(data.get("format") == SCENE_FORMAT, f"not a refimpl scene (\"format\" is {data.get('format')!r},"
          f" expected {SCENE_FORMAT!r})")
    _need(data.get("version") == SCENE_VERSION, f"unsupported scene version {data.get('version')!r}"
          f" (this refimpl reads version {SCENE_VERSION})")
    for key in ("name", "first_frame", "last_frame", "tracks", "events", "timelines"):
        _need(key in data, f"missing field {key!r}")
    _need(isinstance(data["name"], str), "name must be a string")
    size = data.get("image_size")
    _need(size is None or (isinstance(size, list) and len(size) == 2 and all(isinstance(v, int) for v in size)),
          f"image_size must be [width, height] or null, got {size!r}")
    fps = data.get("fps")
    _need(fps is None or (isinstance(fps, (int, float)) and not isinstance(fps, bool)), "fps must be a number or null")
    _need(isinstance(data["tracks"], list), "tracks must be a list")
    tracks = []
    for i, t in enumerate(data["tracks"]):
        _need(isinstance(t, dict) and isinstance(t.get("id"), str) and isinstance(t.get("type"), str),
              f"tracks[{i}] must be an object with string id and type")
        ended = t.get("ended_at")
        tracks.append(SceneTrack(t["id"], t["type"], _boxes(t.get("observed"), f"tracks[{i}].observed"),
                                 _boxes(t.get("halted", []), f"tracks[{i}].halted"),
                                 None if ended is None else _int(ended, f"tracks[{i}].ended_at")))
    _need(isinstance(data["events"], list), "events must be a list")
    events = tuple(_event(e, i) for i, e in enumerate(data["events"]))
    lines = data["timelines"]
    _need(isinstance(lines, dict), "timelines must be an object")
    timelines = []
    for k, v in lines.items():
        _need(isinstance(v, list) and all(isinstance(i, list) and len(i) == 3 and isinstance(i[0], int)
                                          and isinstance(i[1], int) and isinstance(i[2], str) for i in v),
              f"timelines[{k!r}] must be a list of [from_frame, to_frame, value]")
        timelines.append((k, tuple((i[0], i[1], i[2]) for i in v)))
    scene = Scene(data["name"], tuple(size) if size is not None else None, _int(data["first_frame"], "first_frame"),
                  _int(data["last_frame"], "last_frame"), None if fps is None else float(fps),
                  tuple(tracks), events, tuple(timelines))
    _check_scene(scene)
    return scene


def save_scene(path: str | os.PathLike, scene: Scene) -> None:
    """Write the scene as JSON, atomically (a temporary file in the same folder, then a rename)."""
    from .io import write_text_atomic
    write_text_atomic(path, json.dumps(scene_to_json(scene), separators=(",", ":")) + "\n")


def load_scene(path: str | os.PathLike) -> Scene:
    """Read a scene file; a missing, unreadable or malformed file is a SceneError naming the file."""
    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except FileNotFoundError:
        raise SceneError(f"{path}: no such scene file") from None
    except UnicodeDecodeError:
        raise SceneError(f"{path}: not a refimpl scene file (not UTF-8 text)") from None
    except json.JSONDecodeError as exc:
        raise SceneError(f"{path}: not a refimpl scene file (invalid JSON at line {exc.lineno}"
                         f" column {exc.colno}: {exc.msg})") from None
    except RecursionError:
        raise SceneError(f"{path}: not a refimpl scene file (JSON nested too deeply)") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise SceneError(f"{path}: not a refimpl scene file ({str(exc).splitlines()[0][:80]})") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        return scene_from_json(data)
    except SceneError as exc:
        raise SceneError(f"{path}: {exc}") from None


# ---------------------------------------------------------------------------------------
# Episodes: what the event log says happened to each track
# ---------------------------------------------------------------------------------------

ENDINGS = tuple(e.name for e in explaining("end"))
_HALTS = {e.name: e for e in explaining("halt")}
_RESUMES = tuple(e.name for e in explaining("resume"))


@dataclass(frozen=True)
class Episode:
    """One stretch of a track's story: a halt (hidden or missing) with how it ended, or a single event.

    kind: 'hidden' (hides_behind T1 behind ``other``), 'missing' (missing_detections), or the
    name of a single event ('enters_fov', 'leaves_fov', 'lost', 'noise', or any other).
    For a halt, ``end`` is the frame of the event that closed it and ``end_event`` its name
    ('unhides_from_behind', 'recover', 'lost', 'noise', 'leaves_fov'); both None when the
    track was still halted at the end of the sequence.
    """

    kind: str
    track: str
    start: int
    other: str | None = None
    end: int | None = None
    end_event: str | None = None


def episodes(scene: Scene) -> list[Episode]:
    """The event log grouped into episodes, in time order (then track number).

    A hides_behind / missing_detections halts the track; the next unhides_from_behind or
    recover of the track (a resume), or its lost / noise / leaves_fov (an end), closes the halt.
    """
    out: list[Episode] = []
    open_halt: dict[str, Episode] = {}
    for e in scene.events:
        name, args = e.event.name, [str(a) for a in e.event.args]
        if not args:
            out.append(Episode(name, "", e.time))
            continue
        trk = args[0]
        if name in _HALTS:
            if trk in open_halt:  # a second halt without a resume closes the first
                out.append(replace(open_halt.pop(trk), end=e.time, end_event=name))
            open_halt[trk] = Episode(_HALTS[name].closing, trk, e.time, args[1] if len(args) > 1 else None)
        elif name in _RESUMES + ENDINGS and trk in open_halt:
            ep = open_halt.pop(trk)
            out.append(replace(ep, end=e.time, end_event=name))
        else:
            out.append(Episode(name, trk, e.time, args[1] if len(args) > 1 else None))
    out.extend(open_halt.values())
    return sorted(out, key=lambda ep: (ep.start, natural_key(ep.track)))


@dataclass(frozen=True)
class HidingEpisode:
    """T1 hidden behind T2 from hidden_at (its hides_behind) to resumed_at (the resume frame)."""

    track: str
    hider: str
    hidden_at: int
    resumed_at: int | None
    """The frame of unhides_from_behind / recover (T1 observed again), else None."""
    how: str
    """'unhides_from_behind', 'recover', 'lost', 'noise', 'leaves_fov', or 'open' (still hidden at the end)."""


def hiding_episodes(scene: Scene) -> list[HidingEpisode]:
    """Every hides_behind of the log with how the hiding ended."""
    out = []
    for ep in episodes(scene):
        if ep.kind != "hidden":
            continue
        resumed = ep.end if ep.end_event in _RESUMES else None
        out.append(HidingEpisode(ep.track, ep.other or "", ep.start, resumed, ep.end_event or "open"))
    return out


# ---------------------------------------------------------------------------------------
# Explanations
# ---------------------------------------------------------------------------------------

def _who(scene: Scene, trk: str, capital: bool) -> str:
    t = scene._by_id.get(trk)
    number = t.number if t is not None else (natural_key(trk)[1] if natural_key(trk)[1] >= 0 else trk)
    typ = f" ({t.type})" if t is not None else ""
    return f"{'Track' if capital else 'track'} {number}{typ}"


def _later(a: int, b: int) -> str:
    n = b - a
    return f"{n} frame{'s' if n != 1 else ''} later"


def explain_episode(scene: Scene, ep: Episode) -> str:
    """One plain-English sentence for an episode (phrases from the event table, refimpl.events)."""
    who = _who(scene, ep.track, True) if ep.track else ""
    halt = next((e for e in _HALTS.values() if e.closing == ep.kind), None)
    if halt is not None:
        other = f" {_who(scene, ep.other or '?', False)}" if halt.arity == 2 else ""
        head = f"{who} {halt.phrase}{other} at frame {ep.start}"
        if ep.end is None:
            return f"{head} and was still {ep.kind} at the end of the sequence (frame {scene.last_frame})."
        closing = EVENT_TABLE.get(ep.end_event or "")
        verb = closing.closing if closing is not None else f"ended with {ep.end_event}"
        return f"{head} and {verb} at frame {ep.end}, {_later(ep.start, ep.end)}."
    spec = EVENT_TABLE.get(ep.kind)
    if spec is None or not ep.track:
        args = f"({ep.track}{',' + ep.other if ep.other else ''})" if ep.track else ""
        return f"Event {ep.kind}{args} occurred at frame {ep.start}."
    since = ""
    if spec.name == "noise" and ep.track in scene._by_id:
        since = f", seen since frame {scene._by_id[ep.track].first_frame},"
    other = f" {_who(scene, ep.other or '?', False)}" if spec.arity == 2 else ""
    return f"{who}{since} {spec.phrase}{other} at frame {ep.start}."


def explain(scene: Scene, track: str | None = None) -> list[str]:
    """The event sequence as sentences, one per episode, in time order; ``track`` keeps the
    episodes of that track and those in which it hides another."""
    if track is not None:
        track = _trk(scene, track)  # 13 or trk_13; an unknown id is a SceneError
    out = []
    for ep in episodes(scene):
        if track is None or ep.track == track or (ep.kind == "hidden" and ep.other == track):
            out.append(explain_episode(scene, ep))
    return out


# ---------------------------------------------------------------------------------------
# Anticipation of hidden entities (paper Section 4.1.2) and the ego region
# ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class EgoRegion:
    """The image region "in front of the ego vehicle", in fractions of the image width and height.

    A box is in the region when its bottom-centre point (where it stands on the ground) has
    x0 <= x / width <= x1 and y0 <= y / height <= y1.  Default: the lower-centre band, the
    middle third of the width and the lower half of the height (for a forward-looking
    camera: the road ahead of the ego vehicle).
    """

    x0: float = 1 / 3
    x1: float = 2 / 3
    y0: float = 0.5
    y1: float = 1.0

    def __post_init__(self) -> None:
        if not (0 <= self.x0 < self.x1 <= 1 and 0 <= self.y0 < self.y1 <= 1):
            raise SceneError(f"ego region must have 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1, got "
                             f"{self.x0:g},{self.x1:g},{self.y0:g},{self.y1:g}")

    @classmethod
    def parse(cls, text: str) -> "EgoRegion":
        """'X0,X1,Y0,Y1' in fractions of the image, e.g. '0.33,0.67,0.5,1'."""
        try:
            x0, x1, y0, y1 = (float(v) for v in text.split(","))
        except ValueError:
            raise SceneError(f"ego region must be X0,X1,Y0,Y1 (fractions of the image), got {text!r}") from None
        return cls(x0, x1, y0, y1)

    def pixels(self, image_size: tuple[int, int]) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) in pixels."""
        w, h = image_size
        return self.x0 * w, self.x1 * w, self.y0 * h, self.y1 * h

    def contains(self, box: Sequence[float], image_size: tuple[int, int] | None) -> bool:
        """position(in_front, box): the box's bottom-centre lies in the region (False if the size is unknown)."""
        if not image_size or image_size[0] <= 0 or image_size[1] <= 0:
            return False
        x, y = box[0] + box[2] / 2, box[1] + box[3]
        xa, xb, ya, yb = self.pixels(image_size)
        return xa <= x <= xb and ya <= y <= yb


@dataclass(frozen=True)
class ReasoningConfig:
    """Parameters of anticipation, warnings and situations (frames and pixels)."""

    region: EgoRegion = EgoRegion()
    anticipation_threshold: int = 30
    """warning(hidden_entity_in_front(T1, T)) needs T - t < this many frames."""
    covered_share: float = 0.5
    """T1 counts as behind T2 while T2 covers at least this share of T1's box (1.0 = proper part)."""
    horizon: int = 100
    """How many frames ahead anticipation looks for the moment T1 moves out of T2."""
    velocity_window: int = 5
    """Constant velocity from the first and last of a track's last observations within this many frames."""
    motion: str = "velocity"
    """'velocity' (constant box velocity from observed boxes) or 'kalman' (the tracker's Kalman prediction)."""
    stop_window: int = 3
    """SUDDEN_STOP: speeds are measured over this many frames."""
    stop_min_speed: float = 4.0
    """SUDDEN_STOP: the speed before (px/frame of the bottom-centre) must be at least this."""
    stop_ratio: float = 0.25
    """SUDDEN_STOP: the speed after must be at most this share of the speed before."""

    def __post_init__(self) -> None:
        if self.motion not in ("velocity", "kalman"):
            raise SceneError(f"motion must be 'velocity' or 'kalman', got {self.motion!r}")
        if not 0 < self.covered_share <= 1:
            raise SceneError(f"covered_share must be in (0, 1], got {self.covered_share}")
        for name in ("anticipation_threshold", "horizon", "velocity_window", "stop_window"):
            if getattr(self, name) < 1:
                raise SceneError(f"{name} must be at least 1, got {getattr(self, name)}")


DEFAULT_CONFIG = ReasoningConfig()


def reasoning_config(anticipation_threshold: int | None = None, ego_region: str | None = None,
                     **overrides) -> ReasoningConfig:
    """The default ReasoningConfig with the given settings (the CLI's --anticipation-threshold, --ego-region)."""
    if anticipation_threshold is not None:
        overrides["anticipation_threshold"] = anticipation_threshold
    if ego_region is not None:
        overrides["region"] = EgoRegion.parse(ego_region)
    return replace(DEFAULT_CONFIG, **overrides)

Predictor = Callable[[int], Box]


def _clamp(box: Sequence[float]) -> Box:
    x, y, w, h = box
    return (x, y, max(w, 1.0), max(h, 1.0))


def velocity_predictor(track: SceneTrack, now: int, window: int) -> Predictor | None:
    """Constant box velocity from the track's observations up to ``now``: frame -> box.

    The velocity (of x, y, w and h) is the difference between the last observed box and the
    oldest one observed within ``window`` frames before it, per frame; a single observation
    gives velocity zero.  None if the track was never observed up to now.
    """
    seen = track.observed_until(now, window + 1)
    if not seen:
        return None
    f1, b1 = seen[-1]
    old = [(f, b) for f, b in seen if f >= f1 - window]
    f0, b0 = old[0]
    v = [(b1[i] - b0[i]) / (f1 - f0) if f1 > f0 else 0.0 for i in range(4)]
    return lambda f: _clamp([b1[i] + v[i] * (f - f1) for i in range(4)])


def kalman_predictor(track: SceneTrack, now: int) -> Predictor | None:
    """The tracker's Kalman extrapolation of a halted track (SORT's constant-velocity model).

    SORT's state moves the box centre and area linearly and keeps the aspect ratio; its
    velocity is read off the last observed box (the filtered state) and the first predicted
    box of the halt after it.  None if the track has no halted frame after an observation by now.
    """
    seen = track.observed_until(now, 1)
    if not seen:
        return None
    f0, b0 = seen[-1]
    nxt = [(f, b) for f, b in track.halted if f0 < f <= now]
    if not nxt:
        return None
    f1, b1 = nxt[0]

    def zs(b):
        return b[0] + b[2] / 2, b[1] + b[3] / 2, b[2] * b[3]
    (u0, v0, s0), (u1, v1, s1) = zs(b0), zs(b1)
    dt = f1 - f0
    du, dv, ds = (u1 - u0) / dt, (v1 - v0) / dt, (s1 - s0) / dt
    r = b1[2] / b1[3]

    def at(f: int) -> Box:
        k = f - f1
        s = max(s1 + ds * k, 1.0)
        w = math.sqrt(s * r)
        h = s / w
        return _clamp((u1 + du * k - w / 2, v1 + dv * k - h / 2, w, h))
    return at


def _predictor(track: SceneTrack, now: int, config: ReasoningConfig, hidden: bool) -> Predictor | None:
    if hidden and config.motion == "kalman":
        p = kalman_predictor(track, now)
        if p is not None:
            return p
    return velocity_predictor(track, now, config.velocity_window)


def hidden_behind_at(scene: Scene, trk: str, t: int) -> str | None:
    """The track T2 that trk is hidden behind after the events up to t (hidden_by(trk,T2) holds at t+1), or None."""
    for ep in hiding_episodes(scene):
        if ep.track == trk and ep.hidden_at <= t:
            end = ep.resumed_at if ep.resumed_at is not None else _episode_end(scene, ep)
            if end is None or t < end:
                return ep.hider
    return None


def _episode_end(scene: Scene, ep: HidingEpisode) -> int | None:
    if ep.how == "open":
        return None
    for e in scene.events:
        if e.time >= ep.hidden_at and e.event.name == ep.how and e.event.args and str(e.event.args[0]) == ep.track:
            return e.time
    return None


@dataclass(frozen=True)
class Anticipation:
    """anticipate(unhides_from_behind(track, hider), at), made at time point ``now``."""

    track: str
    hider: str
    now: int
    at: int
    box: Box
    """interpolated_position(track, at) as a box: the predicted box at ``at``."""
    position: tuple[float, float]
    """The centre of ``box`` (px)."""
    in_front: bool
    """position(in_front, ...): the box's bottom-centre is in the ego region."""
    warning: bool
    """warning(hidden_entity_in_front(track, at)): at - now < anticipation_threshold and in_front."""

    def atoms(self) -> list[str]:
        x, y = self.position
        out = [f"anticipate(unhides_from_behind({self.track},{self.hider}),{self.at})",
               f"point2d(interpolated_position({self.track},{self.at}),{round(x)},{round(y)})"]
        if self.warning:
            out.append(f"warning(hidden_entity_in_front({self.track},{self.at}))")
        return out


def anticipate(scene: Scene, trk: str, now: int, config: ReasoningConfig = DEFAULT_CONFIG,
               hider: str | None = None) -> Anticipation | None:
    """The paper's rule at curr_time = now, after the abduction at ``now``::

        anticipate(unhides_from_behind(T1,T2),T) :- curr_time < T, holds_at(hidden_by(T1,T2),curr_time),
            topology(proper_part,T1,T2), movement(moves_out_of,T1,T2,T).

    T1 = trk is hidden behind T2 after the events up to ``now``; both tracks' boxes are
    extrapolated from what was observed up to ``now`` (ReasoningConfig.motion); "proper part"
    is read as T2 covering at least covered_share of T1's box at ``now`` (1.0 is the strict
    reading); T is relations.first_time_moves_out_of over now+1 .. now+horizon.  None when T1
    is not hidden at ``now``, is not behind T2 by that measure, or does not move out within
    the horizon.
    """
    t1 = scene.track(trk)
    hider = hider or hidden_behind_at(scene, trk, now)
    if hider is None or not scene.has_track(hider):
        return None
    p1 = _predictor(t1, now, config, hidden=True)
    p2 = _predictor(scene.track(hider), now, config, hidden=False)
    if p1 is None or p2 is None:
        return None
    if rel.coverage(p1(now), p2(now)) < config.covered_share:
        return None
    future = range(now + 1, now + config.horizon + 1)
    at = rel.first_time_moves_out_of({f: p1(f) for f in future}, {f: p2(f) for f in future},
                                     config.covered_share)
    if at is None:
        return None
    box = p1(at)
    front = config.region.contains(box, scene.image_size)
    return Anticipation(trk, hider, now, at, tuple(round(v, 2) for v in box),  # type: ignore[arg-type]
                        (round(box[0] + box[2] / 2, 2), round(box[1] + box[3] / 2, 2)), front,
                        front and at - now < config.anticipation_threshold)


def no_anticipation_reason(scene: Scene, trk: str, now: int, config: ReasoningConfig = DEFAULT_CONFIG) -> str:
    """Why :func:`anticipate` gives nothing for trk at now (one line)."""
    hider = hidden_behind_at(scene, trk, now)
    if hider is None:
        return f"{trk} is not hidden at frame {now}"
    p1 = _predictor(scene.track(trk), now, config, hidden=True)
    p2 = _predictor(scene.track(hider), now, config, hidden=False) if scene.has_track(hider) else None
    if p1 is None or p2 is None:
        return f"no anticipation: {trk} or {hider} has no observed box before frame {now}"
    share = rel.coverage(p1(now), p2(now))
    if share < config.covered_share:
        return (f"no anticipation: {trk} is hidden behind {hider} at frame {now}, but {hider} covers only "
                f"{100 * share:.0f}% of its predicted box (the rule needs {100 * config.covered_share:.0f}%)")
    return (f"no anticipation: {trk} is hidden behind {hider} at frame {now}, but its predicted box does not "
            f"move out of {hider}'s within {config.horizon} frames")


# ---------------------------------------------------------------------------------------
# Safety-critical situations (Table 5)
# ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Situation:
    """A safety-critical situation with its objects and time span (frames, inclusive)."""

    kind: str
    objects: tuple[str, ...]
    start: int
    end: int

    def describe(self) -> str:
        span = f"frame {self.start}" if self.start == self.end else f"frames {self.start}-{self.end}"
        if self.kind == "HIDDEN_ENTITY":
            return f"HIDDEN_ENTITY {self.objects[0]} hidden behind {self.objects[1]} in front: {span}"
        return f"{self.kind} {' '.join(self.objects)}: {span}"


def _runs(frames: Iterable[int]) -> list[tuple[int, int]]:
    """Sorted frames as maximal runs of consecutive frames: [(first, last), ...]."""
    out: list[list[int]] = []
    for f in sorted(set(frames)):
        if out and f == out[-1][1] + 1:
            out[-1][1] = f
        else:
            out.append([f, f])
    return [(a, b) for a, b in out]


def hidden_entity_situations(scene: Scene, config: ReasoningConfig = DEFAULT_CONFIG) -> list[Situation]:
    """HIDDEN_ENTITY (T1, T2): T1 is hidden behind T2 (its halted frames between hides_behind and
    the resume or end) while T1's Kalman-predicted box stands in the ego region."""
    out = []
    for ep in hiding_episodes(scene):
        t1 = scene.track(ep.track) if scene.has_track(ep.track) else None
        if t1 is None:
            continue
        end = ep.resumed_at if ep.resumed_at is not None else _episode_end(scene, ep)
        frames = [f for f, b in t1.halted if f >= ep.hidden_at and (end is None or f < end)
                  and config.region.contains(b, scene.image_size)]
        out += [Situation("HIDDEN_ENTITY", (ep.track, ep.hider), a, b) for a, b in _runs(frames)]
    return out


def _foot(b: Box) -> tuple[float, float]:
    return b[0] + b[2] / 2, b[1] + b[3]


def sudden_stop_situations(scene: Scene, config: ReasoningConfig = DEFAULT_CONFIG) -> list[Situation]:
    """SUDDEN_STOP (T): a track in front decelerating sharply, from its observed boxes.

    With w = stop_window and p(f) the bottom-centre of the observed box at f, the speed at f is
    v(f) = |p(f) - p(f - w)| / w px/frame (both frames observed).  Frame f is a stop when the
    speed before, b = min(v(f - w - 1), v(f - w)), is at least stop_min_speed, the speed after
    stays low, max(v(f), v(f + 1)) <= stop_ratio * b, and the box at f is in the ego region.
    Two windows on each side keep a single misplaced detection from looking like a stop.  The
    situation spans the deceleration, f - w .. f, merged over consecutive stops.
    """
    w = config.stop_window
    out = []
    for t in scene.tracks:
        def speed(f: int) -> float | None:
            a, b = t.observed_box(f - w), t.observed_box(f)
            if a is None or b is None:
                return None
            (xa, ya), (xb, yb) = _foot(a), _foot(b)
            return math.hypot(xb - xa, yb - ya) / w
        frames: list[int] = []
        for f, box in t.observed:
            before = [speed(f - w - 1), speed(f - w)]
            after = [speed(f), speed(f + 1)]
            if None in before or None in after:
                continue
            slow = min(before)  # type: ignore[type-var]
            if (slow >= config.stop_min_speed and max(after) <= config.stop_ratio * slow  # type: ignore[type-var]
                    and config.region.contains(box, scene.image_size)):
                frames.extend(range(f - w, f + 1))
        out += [Situation("SUDDEN_STOP", (t.id,), a, b) for a, b in _runs(frames)]
    return out


def situations(scene: Scene, config: ReasoningConfig = DEFAULT_CONFIG) -> list[Situation]:
    """HIDDEN_ENTITY and SUDDEN_STOP situations, by start frame."""
    found = hidden_entity_situations(scene, config) + sudden_stop_situations(scene, config)
    return sorted(found, key=lambda s: (s.start, s.kind, tuple(natural_key(o) for o in s.objects)))


# ---------------------------------------------------------------------------------------
# Relations between tracks (Table 2)
# ---------------------------------------------------------------------------------------

_RCC_SHORT = {"dc": "disconnected", "ec": "externally_connected", "po": "partially_overlapping",
              "tpp": "tangential_proper_part", "ntpp": "non_tangential_proper_part",
              "tppi": "tangential_proper_part_inverse", "ntppi": "non_tangential_proper_part_inverse",
              "eq": "equal"}
RCC_SHORT_NAME = {v: k for k, v in _RCC_SHORT.items()}

MOVEMENT_WINDOW = 5
"""Pair movement relations compare the boxes at f - MOVEMENT_WINDOW and f."""


def _spatial_relations() -> dict[str, Callable[[Box, Box], bool]]:
    """name -> test(Y's box, X's box) for relations on the boxes of one frame: "Y name X"."""
    out: dict[str, Callable[[Box, Box], bool]] = {}
    for short, full in _RCC_SHORT.items():
        out[full] = out[short] = (lambda full: lambda a, b: rel.topology(a, b) == full)(full)
    derived = {"proper_part": rel.proper_part, "pp": rel.proper_part, "part_of": rel.part_of, "p": rel.part_of,
               "overlapping": rel.overlap, "overlap": rel.overlap, "o": rel.overlap,
               "discrete": rel.discrete, "dr": rel.discrete, "contact": rel.contact, "c": rel.contact}
    out.update(derived)
    out["overlapping_top"] = lambda a, b: rel.overlapping_top(a, b, _hide_overlap())
    for name in ("left_of", "right_of", "above", "below"):
        out[name] = (lambda name: lambda a, b: name in rel.orientation(a, b))(name)
    out["in_front_of"] = rel.in_front_of
    out["behind"] = lambda a, b: rel.in_front_of(b, a)
    out["near"] = rel.near
    out["far"] = rel.far
    for name in ("smaller", "larger", "same_size"):
        out[name] = (lambda name: lambda a, b: rel.size_relation(a, b) == name)(name)
    for axis, k in (("x", 0), ("y", 1)):
        for name in rel.ALLEN_RELATIONS:
            out[f"{axis}_{name}"] = (lambda name, k: lambda a, b: rel.rectangle_relation(a, b)[k] == name)(name, k)
    return out


def _hide_overlap() -> int:
    """model/constants.lp hide_overlap: overlapping_top needs more than this % of T1 covered."""
    from .constants import default_constants
    return default_constants()["hide_overlap"]


SPATIAL = _spatial_relations()
MOVEMENT = ("moving_towards", "moving_away", "moving_parallel", "approaching")
LIFETIME = rel.ALLEN_RELATIONS
RELATION_NAMES = tuple(SPATIAL) + MOVEMENT + LIFETIME


def frame_relations(a: Box, b: Box) -> list[str]:
    """The notable relations of box a to box b in one frame (for plots and listings)."""
    out = [RCC_SHORT_NAME[rel.topology(a, b)]]
    if rel.overlapping_top(a, b, _hide_overlap()):
        out.append("overlapping_top")
    out += sorted(rel.orientation(a, b))
    if rel.in_front_of(a, b):
        out.append("in_front_of")
    elif rel.in_front_of(b, a):
        out.append("behind")
    if rel.near(a, b):
        out.append("near")
    elif rel.far(a, b):
        out.append("far")
    return out


def related(scene: Scene, x: str, name: str) -> list[tuple[str, list[tuple[int, int]]]]:
    """Every track Y with ``Y name X`` and the frames (runs) at which it holds.

    Spatial relations use the observed boxes of frames where both are observed; movement
    relations compare frames f - MOVEMENT_WINDOW and f (all four boxes observed); lifetime
    (Allen) relations compare the tracks' lives and report Y's life as its frames.
    """
    tx = scene.track(x)
    out = []
    others = [t for t in scene.tracks if t.id != x]
    if name in LIFETIME:
        lx = scene.life(x)
        for t in others:
            ly = scene.life(t.id)
            if rel.interval_relation(ly, lx) == name:
                out.append((t.id, [ly]))
        return out
    for t in others:
        frames = []
        for f, bx in tx.observed:
            by = t.observed_box(f)
            if by is None:
                continue
            if name in SPATIAL:
                if SPATIAL[name](by, bx):
                    frames.append(f)
            else:
                bx0, by0 = tx.observed_box(f - MOVEMENT_WINDOW), t.observed_box(f - MOVEMENT_WINDOW)
                if bx0 is not None and by0 is not None and name in rel.movement(by0, by, bx0, bx):
                    frames.append(f)
        if frames:
            out.append((t.id, _runs(frames)))
    return out


# ---------------------------------------------------------------------------------------
# Queries
# ---------------------------------------------------------------------------------------

QUERY_FORMS = (
    ("tracks", "every track: type, life, observed / hidden frames"),
    ("track T", "T's life: start, hidden and missing spans, end"),
    ("hidden_by T", "which tracks T hid, and when (frames where hidden_by(X,T) holds)"),
    ("holds_at T FRAME", "every fluent of T at FRAME (holds_at, events before FRAME)"),
    ("events FROM TO [T]", "the events of frames FROM..TO (of track T only)"),
    ("relation T REL", "which tracks Y were ever in relation 'Y REL T', and at which frames"),
    ("anticipate T FRAME", "anticipate(unhides_from_behind(T,T2),T') for T hidden at FRAME, with the warning"),
    ("situations", "safety-critical situations: HIDDEN_ENTITY, SUDDEN_STOP with their frames"),
)


def query_usage() -> str:
    """The one-line list of query forms."""
    return "query forms: " + " | ".join(form for form, _ in QUERY_FORMS)


@dataclass(frozen=True)
class Answer:
    """A query's answer: text lines and the same as JSON-ready data."""

    query: str
    lines: tuple[str, ...]
    data: object

    def to_json(self) -> str:
        return json.dumps({"query": self.query, "answer": self.data})


def _frames_text(a: int, b: int) -> str:
    return f"frame {a}" if a == b else f"frames {a}-{b}"


def _frames_of(runs: Sequence[tuple[int, int]]) -> str:
    """'frame 266' or 'frames 227-234, 268-273'."""
    single = len(runs) == 1 and runs[0][0] == runs[0][1]
    return ("frame " if single else "frames ") + _spans(runs)


def _spans(runs: Sequence[tuple[int, int]]) -> str:
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def _trk(scene: Scene, text: str) -> str:
    ident = f"trk_{text}" if text.isdigit() else text
    scene.track(ident)
    return ident


def _frame(text: str, what: str = "FRAME") -> int:
    try:
        return int(text)
    except ValueError:
        raise SceneError(f"{what} must be a frame number, got {text!r}; {query_usage()}") from None


def track_summary(scene: Scene, trk: str) -> dict:
    """A track's life: first and last frame, observed count, hidden / missing spans, how it ended."""
    t = scene.track(trk)
    halts = []
    for ep in episodes(scene):
        if ep.track == trk and ep.kind in ("hidden", "missing"):
            last = (ep.end - 1) if ep.end is not None else scene.last_frame
            if ep.end_event in ENDINGS:
                last = ep.end
            halts.append({"kind": ep.kind, "behind": ep.other, "from": ep.start, "to": last,
                          "ended_by": ep.end_event, "at": ep.end})
    end_event = None
    if t.ended_at is not None:
        end_event = next((e.event.name for e in scene.events if e.time == t.ended_at and e.event.name in ENDINGS
                          and e.event.args and str(e.event.args[0]) == trk), None)
    return {"track": trk, "type": t.type, "first_frame": t.first_frame,
            "last_frame": t.last_frame(scene.last_frame), "observed_frames": len(t.observed),
            "halted_frames": len(t.halted), "halts": halts, "ended_at": t.ended_at, "ended_by": end_event}


def _summary_lines(s: dict) -> list[str]:
    lines = [f"{s['track']} ({s['type']}): frames {s['first_frame']}-{s['last_frame']}, "
             f"observed in {s['observed_frames']}, halted in {s['halted_frames']}"]
    for h in s["halts"]:
        what = f"hidden behind {h['behind']}" if h["kind"] == "hidden" else "missing"
        closed = (f" ({h['ended_by']} at {h['at']})" if h["ended_by"] else " (still halted at the end)")
        lines.append(f"  {what}: {_frames_text(h['from'], h['to'])}{closed}")
    if s["ended_at"] is None:
        lines.append(f"  alive at the end of the sequence (frame {s['last_frame']})")
    else:
        lines.append(f"  ended at frame {s['ended_at']}" + (f" ({s['ended_by']})" if s["ended_by"] else ""))
    return lines


def holds_at(scene: Scene, trk: str, frame: int) -> dict[str, list[str]]:
    """Every fluent of trk at frame: visibility, clipped, in_fov, and hidden_by(trk, X) for the X
    with value true (false for every other X); events before frame folded."""
    state = EventState([e for e in scene.events if e.time < frame])
    out = {f"{name}({trk})": sorted(state.values((name, trk))) for name in ("visibility", "clipped", "in_fov")}
    for t in scene.tracks:
        if t.id != trk and state.holds_at(("hidden_by", trk, t.id), "true"):
            out[f"hidden_by({trk},{t.id})"] = sorted(state.values(("hidden_by", trk, t.id)))
    return out


def query(scene: Scene, text: str, config: ReasoningConfig = DEFAULT_CONFIG) -> Answer:
    """Answer one query (forms: :data:`QUERY_FORMS`); SceneError for a malformed query."""
    words = text.split()
    if not words:
        raise SceneError(f"empty query; {query_usage()}")
    form, args = words[0].lower(), words[1:]
    arity = {"tracks": (0, 0), "track": (1, 1), "hidden_by": (1, 1), "holds_at": (2, 2), "events": (2, 3),
             "relation": (2, 2), "anticipate": (2, 2), "situations": (0, 0)}
    if form not in arity:
        raise SceneError(f"unknown query {words[0]!r}; {query_usage()}")
    lo, hi = arity[form]
    if not lo <= len(args) <= hi:
        usage = next(f for f, _ in QUERY_FORMS if f.split()[0] == form)
        raise SceneError(f"query {form!r} takes the form '{usage}', got {text.strip()!r}; {query_usage()}")
    lines: list[str] = []
    data: object
    if form == "tracks":
        data = [track_summary(scene, t.id) for t in scene.tracks]
        for s in data:
            hidden = sum(1 for h in s["halts"] if h["kind"] == "hidden")
            lines.append(f"{s['track']} ({s['type']}): frames {s['first_frame']}-{s['last_frame']}, observed "
                         f"{s['observed_frames']}, hidden {hidden} time{'s' if hidden != 1 else ''}"
                         + (f", {s['ended_by'] or 'ended'} at {s['ended_at']}" if s["ended_at"] is not None else ""))
    elif form == "track":
        data = track_summary(scene, _trk(scene, args[0]))
        lines = _summary_lines(data)
    elif form == "hidden_by":
        x = _trk(scene, args[0])
        data = []
        for t in scene.tracks:
            runs = [(a, b) for a, b, v in scene.timeline(f"hidden_by({t.id},{x})") if v == "true"]
            if runs:
                data.append({"track": t.id, "frames": [list(r) for r in runs]})
                lines.append(f"{t.id} hidden by {x}: {_frames_of(runs)}")
        if not data:
            lines.append(f"no track was hidden by {x}")
    elif form == "holds_at":
        x, f = _trk(scene, args[0]), _frame(args[1])
        data = holds_at(scene, x, f)
        lines = [f"{k} = {' | '.join(v)}" for k, v in data.items()]
        hidden = [k for k in data if k.startswith("hidden_by")]
        if not hidden:
            lines.append(f"hidden_by({x},X) = false for every other track X")
        where = scene.track(x).box_at(f)
        lines.append(f"{x} at {f}: " + (f"{where[0]} box {_fmt_box(where[1])}" if where else "no box"))
    elif form == "events":
        a, b = _frame(args[0], "FROM"), _frame(args[1], "TO")
        who = _trk(scene, args[2]) if len(args) == 3 else None
        sel = [e for e in scene.events if a <= e.time <= b
               and (who is None or who in (str(x) for x in e.event.args))]
        data = [{"time": e.time, "event": str(e.event)} for e in sel]
        lines = [str(e) for e in sel] or [f"no events in frames {a}-{b}"]
    elif form == "relation":
        x, name = _trk(scene, args[0]), args[1].lower()
        if name not in RELATION_NAMES:
            raise SceneError(f"unknown relation {args[1]!r} (relations: {', '.join(RELATION_NAMES)})")
        found = related(scene, x, name)
        data = [{"track": y, "frames": [list(r) for r in runs]} for y, runs in found]
        lines = [f"{y} {name} {x}: {_frames_of(runs)}" for y, runs in found] or [f"no track is {name} {x}"]
    elif form == "anticipate":
        x, f = _trk(scene, args[0]), _frame(args[1])
        ant = anticipate(scene, x, f, config)
        if ant is None:
            data = None
            lines = [no_anticipation_reason(scene, x, f, config)]
        else:
            data = {"track": ant.track, "hider": ant.hider, "now": ant.now, "at": ant.at, "box": list(ant.box),
                    "position": list(ant.position), "in_front": ant.in_front, "warning": ant.warning,
                    "atoms": ant.atoms()}
            lines = ant.atoms() + [f"({x} predicted to reappear from behind {ant.hider} at frame {ant.at}, "
                                   f"{ant.at - f} frames after {f}, at ({ant.position[0]:.0f}, "
                                   f"{ant.position[1]:.0f}) px; {'in front' if ant.in_front else 'not in front'})"]
    else:  # situations
        found = situations(scene, config)
        data = [{"situation": s.kind, "objects": list(s.objects), "from": s.start, "to": s.end} for s in found]
        lines = [s.describe() for s in found] or ["no safety-critical situations"]
    return Answer(text.strip(), tuple(lines), data)


def _fmt_box(b: Sequence[float]) -> str:
    return "(" + ", ".join(f"{v:.0f}" for v in b) + ")"


# ---------------------------------------------------------------------------------------
# Anticipation evaluation on real sequences
# ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class EpisodeOutcome:
    """One hides_behind -> unhides_from_behind episode scored against the actual reappearance."""

    sequence: str
    track: str
    hider: str
    hidden_at: int
    reappeared_at: int
    anticipation: Anticipation | None
    """The anticipation made at the hiding time (now = hidden_at)."""
    first: Anticipation | None
    """The earliest anticipation made at any now in hidden_at .. reappeared_at - 1."""
    actual_position: tuple[float, float]
    last_seen_position: tuple[float, float]


def _centre(b: Sequence[float]) -> tuple[float, float]:
    return b[0] + b[2] / 2, b[1] + b[3] / 2


def score_scene(scene: Scene, config: ReasoningConfig = DEFAULT_CONFIG) -> list[EpisodeOutcome]:
    """Anticipations for every actual hides_behind(T1,T2) -> unhides_from_behind(T1,T2) episode."""
    out = []
    for ep in hiding_episodes(scene):
        if ep.how != "unhides_from_behind" or ep.resumed_at is None:
            continue
        t1 = scene.track(ep.track)
        actual = t1.observed_box(ep.resumed_at)
        seen = t1.observed_until(ep.hidden_at - 1, 1)
        if actual is None or not seen:
            continue
        at_hiding = anticipate(scene, ep.track, ep.hidden_at, config, ep.hider)
        first = at_hiding
        now = ep.hidden_at + 1
        while first is None and now < ep.resumed_at:
            first = anticipate(scene, ep.track, now, config, ep.hider)
            now += 1
        out.append(EpisodeOutcome(scene.name, ep.track, ep.hider, ep.hidden_at, ep.resumed_at, at_hiding, first,
                                  _centre(actual), _centre(seen[-1][1])))
    return out


def _stats(values: Sequence[float]) -> dict:
    if not values:
        return {"n": 0, "mean": None, "median": None}
    return {"n": len(values), "mean": statistics.fmean(values), "median": statistics.median(values)}


def summarise_outcomes(outcomes: Sequence[EpisodeOutcome]) -> dict:
    """Rates and error statistics of scored episodes (frames, px).

    ``at_hiding``: the anticipations made at the hiding time; ``earliest``: the first made at any
    time of the hiding; ``baseline``: on the same episodes as ``at_hiding``, the naive guess
    "reappears at the next frame where it was last seen" (frame hidden_at + 1, the centre of the
    last observed box).
    """
    made = [o for o in outcomes if o.anticipation is not None]
    first = [o for o in outcomes if o.first is not None]

    def errs(sel, pick):
        return {
            "lead": _stats([o.reappeared_at - pick(o).now for o in sel]),
            "frame_error": _stats([pick(o).at - o.reappeared_at for o in sel]),
            "abs_frame_error": _stats([abs(pick(o).at - o.reappeared_at) for o in sel]),
            "position_error": _stats([math.dist(pick(o).position, o.actual_position) for o in sel]),
            "exact_frame": sum(1 for o in sel if pick(o).at == o.reappeared_at),
            "within_5_frames": sum(1 for o in sel if abs(pick(o).at - o.reappeared_at) <= 5),
            "warnings": sum(1 for o in sel if pick(o).warning),
        }
    return {
        "episodes": len(outcomes),
        "hidden_frames": _stats([o.reappeared_at - o.hidden_at for o in outcomes]),
        "at_hiding": {"made": len(made), **errs(made, lambda o: o.anticipation)},
        "earliest": {"made": len(first), **errs(first, lambda o: o.first)},
        "baseline": {
            "abs_frame_error": _stats([o.reappeared_at - o.hidden_at - 1 for o in made]),
            "position_error": _stats([math.dist(o.last_seen_position, o.actual_position) for o in made]),
        },
    }


DURATION_BUCKETS = ((1, 1), (2, 4), (5, 9), (10, None))
"""Hidden frames (reappeared_at - hidden_at) by which the evaluation is broken down."""


def evaluate_anticipation(scenes: Iterable[Scene], config: ReasoningConfig = DEFAULT_CONFIG) -> dict:
    """Score the anticipation rule on every hides -> unhides episode of the scenes.

    Returns {"summary": all episodes, "by_hidden_frames": {"1": ..., "2-4": ..., "5-9": ..., "10+": ...},
    "outcomes": [EpisodeOutcome, ...]}.
    """
    outcomes = [o for s in scenes for o in score_scene(s, config)]
    buckets = {}
    for lo, hi in DURATION_BUCKETS:
        label = f"{lo}+" if hi is None else (f"{lo}" if lo == hi else f"{lo}-{hi}")
        sel = [o for o in outcomes if lo <= o.reappeared_at - o.hidden_at and (hi is None or o.reappeared_at - o.hidden_at <= hi)]
        buckets[label] = summarise_outcomes(sel)
    return {"summary": summarise_outcomes(outcomes), "by_hidden_frames": buckets, "outcomes": outcomes}


def _num(v, fmt: str = "{:.1f}") -> str:
    return "-" if v is None else fmt.format(v)


def format_evaluation(rows: Sequence[tuple[str, str, str, dict]]) -> str:
    """A markdown table, one row per (data, motion, hidden frames, summary)."""
    head = ("| data | motion | hidden frames | episodes | anticipated at hiding | median lead (frames) | "
            "frame error, median (signed) | abs frame error, median / mean | within 5 frames | "
            "position error (px), median | baseline: abs frame error median / position error median | "
            "anticipated at any time while hidden | warnings |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for data, motion, bucket, s in rows:
        a, e, b = s["at_hiding"], s["earliest"], s["baseline"]
        n = max(s["episodes"], 1)
        lines.append(
            f"| {data} | {motion} | {bucket} | {s['episodes']} | {a['made']} ({100 * a['made'] / n:.0f}%) | "
            f"{_num(a['lead']['median'], '{:.0f}')} | {_num(a['frame_error']['median'], '{:+.0f}')} | "
            f"{_num(a['abs_frame_error']['median'], '{:.0f}')} / {_num(a['abs_frame_error']['mean'])} | "
            f"{a['within_5_frames']} ({100 * a['within_5_frames'] / max(a['made'], 1):.0f}%) | "
            f"{_num(a['position_error']['median'])} | {_num(b['abs_frame_error']['median'], '{:.0f}')} / "
            f"{_num(b['position_error']['median'])} | {e['made']} ({100 * e['made'] / n:.0f}%) | {a['warnings']} |")
    return "\n".join(lines)


def _benchmark_scenes(name: str, data_root: str, cache: str | None, progress: bool) -> list[Scene]:
    from . import io
    from .tracker import track_sequence
    out = []
    for s in io.benchmark_sequences(name, data_root):
        path = os.path.join(cache, f"{name}-{s.name}.scene.json") if cache else None
        if path and os.path.isfile(path):
            out.append(load_scene(path))
        else:
            dets = io.load_detections(s)
            scene = scene_from_result(dets, track_sequence(dets, backend="cpsat"))
            if path:
                os.makedirs(cache, exist_ok=True)
                save_scene(path, scene)
            out.append(scene)
        if progress:
            print(f"  {name}/{s.name}: {len(out[-1].events)} events", file=sys.stderr)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m refimpl.scene anticipation-eval``: the anticipation evaluation of docs/reasoning.md."""
    import argparse
    p = argparse.ArgumentParser(prog="python -m refimpl.scene",
                                description="Evaluate hidden-entity anticipation on benchmark sequences "
                                            "(tracked with the cpsat backend).")
    p.add_argument("command", choices=("anticipation-eval",))
    p.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    p.add_argument("--benchmarks", default="mot15,kitti-car", help="comma-separated (default mot15,kitti-car)")
    p.add_argument("--cache", help="folder to keep / reuse the tracked scenes (NAME-SEQ.scene.json)")
    p.add_argument("--json", help="also write the summaries as JSON")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    rows = []
    for name in args.benchmarks.split(","):
        name = name.strip()
        scenes = _benchmark_scenes(name, args.data, args.cache, not args.quiet)
        for motion in ("velocity", "kalman"):
            result = evaluate_anticipation(scenes, ReasoningConfig(motion=motion))
            rows.append((name, motion, "all", result["summary"]))
            rows += [(name, motion, k, v) for k, v in result["by_hidden_frames"].items()]
    print(format_evaluation(rows))
    if args.json:
        from .outputs import write_atomic
        write_atomic(args.json, json.dumps([{"data": d, "motion": m, "bucket": b, **s} for d, m, b, s in rows],
                                           indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
