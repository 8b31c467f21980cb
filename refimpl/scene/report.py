"""What the scene report says (``refimpl report``): box states per frame, event timelines per
track and explanations, as frozen values; ``refimpl.scene.report_html`` renders them as one
self-contained HTML page (the space-time picture as inline SVG, so no matplotlib is needed).

* :func:`frame_states`: for every frame, every track's box there and its state -- ``active``
  (observed: a detection was assigned to it), or halted (its Kalman-predicted box) and why, by
  the halt's episode (``refimpl.scene.episodes``): ``hidden`` behind another track (a
  ``hides_behind`` until the resume), ``missing`` (``missing_detections``, the detector missed it),
  or plain ``halted`` when no halt event explains the frame.  A track that ``hides_behind`` at t
  and ``unhides_from_behind`` at r is hidden at t .. r - 1 and active again at r, as the track's
  halted frames say (the ``hidden_by`` fluent itself holds from t + 1 to r: refimpl.scene's
  package doc).
* :func:`track_timelines`: every track's life (its observed and halted runs, the rows of the
  space-time picture) and the events that name it first, in time order.
* :func:`explanations`: ``refimpl explain``'s sentences with the tracks each one is about.
* :func:`default_frame`: the frame shown first when none is chosen -- the one with the most hidden
  tracks (the earliest of those), or with the most boxes when nothing is ever hidden.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..knowledge.event_table import HALT_KINDS, HIDING_KINDS
from .plots import MIN_OBSERVED, frame_relation_lines, halted_spans
from . import Box, EgoRegion, Scene, SceneError, episodes, explain_episode, frame_runs
from .episodes import ENDINGS
from ..core.spec import natural_key

ACTIVE, HIDDEN, MISSING, HALTED = "active", "hidden", "missing", "halted"
STATES = (ACTIVE, *HALT_KINDS, HALTED)
"""A box's state: observed, halted in one of the event table's halt kinds (hidden, missing, ...) or
halted outside any halt episode."""
"""A box's state at a frame (module doc)."""


@dataclass(frozen=True)
class BoxState:
    """One track's box at one frame and its state."""

    track: str
    box: Box
    state: str
    hidden_by: str | None = None
    """The occluder of a ``hidden`` box (the second track of its hides_behind)."""


@dataclass(frozen=True)
class TimelineEvent:
    time: int
    name: str
    other: str | None
    """The second track of a pair event (hides_behind / unhides_from_behind), else None."""


@dataclass(frozen=True)
class TrackTimeline:
    """A track's life and its events (those that name it first), in time order."""

    track: str
    number: int | str
    type: str
    first_frame: int
    last_frame: int
    observed: int
    halted: int
    ended_by: str | None
    """The event that ended it (lost, noise, leaves_fov), None if alive at the end."""
    events: tuple[TimelineEvent, ...]
    observed_runs: tuple[tuple[int, int], ...]
    """(first, last) of every run of observed frames."""
    halted_runs: tuple[tuple[int, int, bool], ...]
    """(first, last, resumed) of every run of halted frames (refimpl.scene.plots.halted_spans)."""

    @property
    def drawn(self) -> bool:
        """In the space-time picture: observed in MIN_OBSERVED+ frames, as ``refimpl plot`` draws by default."""
        return self.observed >= MIN_OBSERVED


@dataclass(frozen=True)
class Explanation:
    sentence: str
    frame: int
    tracks: tuple[str, ...]
    """The tracks the sentence is about (its track, and the occluder of a hiding)."""


@dataclass(frozen=True)
class Report:
    """Everything the HTML page shows."""

    name: str
    first_frame: int
    last_frame: int
    image_size: tuple[int, int] | None
    fps: float | None
    canvas: tuple[float, float]
    """Width and height of the frame picture: the image size, else the extent of every box."""
    ego_region: tuple[float, float, float, float] | None
    """x0, x1, y0, y1 in pixels (only with an image size)."""
    frame: int
    """The frame shown first."""
    frames: tuple[tuple[BoxState, ...], ...]
    """The box states of every frame first_frame .. last_frame."""
    relations: tuple[tuple[str, ...], ...]
    """Per frame, the fluents and pair relations that hold (refimpl.scene.plots.frame_relation_lines)."""
    tracks: tuple[TrackTimeline, ...]
    explanations: tuple[Explanation, ...]
    events: int

    def states_at(self, frame: int) -> tuple[BoxState, ...]:
        if not self.first_frame <= frame <= self.last_frame:
            raise SceneError(f"frame {frame} is outside the scene ({self.first_frame}-{self.last_frame})")
        return self.frames[frame - self.first_frame]


def _halts(scene: Scene) -> dict[str, list[tuple[int, int, str, str | None]]]:
    """track -> (first, last, state, occluder) of every halt episode, the frames it keeps the track halted."""
    out: dict[str, list[tuple[int, int, str, str | None]]] = {}
    for ep in episodes(scene):
        if ep.kind not in HALT_KINDS:
            continue
        if ep.end is None:
            last = scene.last_frame
        else:
            last = ep.end if ep.end_event in ENDINGS else ep.end - 1  # a resume frame is observed again
        out.setdefault(ep.track, []).append((ep.start, last, ep.kind, ep.other if ep.kind in HIDING_KINDS else None))
    return out


def frame_states(scene: Scene) -> dict[int, list[BoxState]]:
    """frame -> the box states there (module doc), tracks in id order."""
    halts = _halts(scene)
    out: dict[int, list[BoxState]] = {f: [] for f in range(scene.first_frame, scene.last_frame + 1)}
    for t in sorted(scene.tracks, key=lambda t: natural_key(t.id)):
        for f, box in t.observed:
            if f in out:
                out[f].append(BoxState(t.id, box, ACTIVE))
        spans = halts.get(t.id, [])
        for f, box in t.halted:
            if f not in out:
                continue
            span = next((s for s in spans if s[0] <= f <= s[1]), None)
            out[f].append(BoxState(t.id, box, span[2], span[3]) if span else BoxState(t.id, box, HALTED))
    for f in out:
        out[f].sort(key=lambda b: natural_key(b.track))
    return out


def default_frame(scene: Scene, states: dict[int, list[BoxState]]) -> int:
    """The frame with the most hidden boxes (earliest), else with the most boxes (earliest)."""
    if not states:
        raise SceneError(f"scene {scene.name} has no frames")
    hidden = {f: sum(b.state in HIDING_KINDS for b in s) for f, s in states.items()}
    key = hidden if any(hidden.values()) else {f: len(s) for f, s in states.items()}
    return max(sorted(key), key=lambda f: key[f])  # max keeps the first of equals: the earliest


def track_timelines(scene: Scene) -> list[TrackTimeline]:
    """Every track (by first frame, then id) with its life and its events."""
    by_track: dict[str, list[TimelineEvent]] = {}
    ended_by: dict[str, str] = {}
    for e in scene.events:
        args = [str(a) for a in e.event.args]
        if not args:
            continue
        by_track.setdefault(args[0], []).append(TimelineEvent(e.time, e.event.name, args[1] if len(args) > 1 else None))
        if e.event.name in ENDINGS:
            ended_by.setdefault(args[0], e.event.name)
    out = []
    for t in sorted(scene.tracks, key=lambda t: (t.first_frame, natural_key(t.id))):
        out.append(TrackTimeline(t.id, t.number, t.type, t.first_frame, t.last_frame(scene.last_frame),
                                 len(t.observed), len(t.halted), ended_by.get(t.id) if t.ended_at is not None else None,
                                 tuple(by_track.get(t.id, ())), tuple(frame_runs(f for f, _ in t.observed)),
                                 tuple(halted_spans(scene, t))))
    return out


def explanations(scene: Scene) -> list[Explanation]:
    """``refimpl explain``'s sentences (one per episode, in time order) with their tracks."""
    out = []
    for ep in episodes(scene):
        tracks = tuple(t for t in (ep.track, ep.other if ep.kind in HIDING_KINDS else None) if t)
        out.append(Explanation(explain_episode(scene, ep), ep.start, tracks))
    return out


def _canvas(scene: Scene) -> tuple[float, float]:
    if scene.image_size:
        return float(scene.image_size[0]), float(scene.image_size[1])
    width = height = 100.0
    for t in scene.tracks:
        for _, (x, y, w, h) in (*t.observed, *t.halted):
            width, height = max(width, x + w), max(height, y + h)
    return width, height


def build_report(scene: Scene, frame: int | None = None) -> Report:
    """The report of a scene, showing ``frame`` first (default: :func:`default_frame`)."""
    if scene.last_frame < scene.first_frame:
        raise SceneError(f"scene {scene.name} has no frames")
    if frame is not None and not scene.first_frame <= frame <= scene.last_frame:
        raise SceneError(f"frame {frame} is outside the scene ({scene.first_frame}-{scene.last_frame})")
    states = frame_states(scene)
    chosen = default_frame(scene, states) if frame is None else frame
    by_id = {t.id: t for t in scene.tracks}
    relations = []
    for f in range(scene.first_frame, scene.last_frame + 1):
        present = [by_id[b.track] for b in states[f]]
        relations.append(tuple(frame_relation_lines(scene, f, present)))
    region = EgoRegion().pixels(scene.image_size) if scene.image_size else None
    return Report(scene.name, scene.first_frame, scene.last_frame, scene.image_size, scene.fps, _canvas(scene),
                  tuple(float(v) for v in region) if region else None, chosen,
                  tuple(tuple(states[f]) for f in range(scene.first_frame, scene.last_frame + 1)),
                  tuple(relations), tuple(track_timelines(scene)), tuple(explanations(scene)), len(scene.events))
