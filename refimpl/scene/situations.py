"""Safety-critical situations of the paper's Table 5 that boxes support: HIDDEN_ENTITY and SUDDEN_STOP."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..core.spec import natural_key
from .anticipation import DEFAULT_CONFIG, ReasoningConfig
from .episodes import hiding_end, hiding_episodes
from .model import Box, Scene, frame_runs


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


def hidden_entity_situations(scene: Scene, config: ReasoningConfig = DEFAULT_CONFIG) -> list[Situation]:
    """HIDDEN_ENTITY (T1, T2): T1 is hidden behind T2 (its halted frames between hides_behind and
    the resume or end) while T1's Kalman-predicted box stands in the ego region."""
    out = []
    for ep in hiding_episodes(scene):
        t1 = scene.track(ep.track) if scene.has_track(ep.track) else None
        if t1 is None:
            continue
        end = ep.resumed_at if ep.resumed_at is not None else hiding_end(scene, ep)
        frames = [f for f, b in t1.halted if f >= ep.hidden_at and (end is None or f < end)
                  and config.region.contains(b, scene.image_size)]
        out += [Situation("HIDDEN_ENTITY", (ep.track, ep.hider), a, b) for a, b in frame_runs(frames)]
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
        out += [Situation("SUDDEN_STOP", (t.id,), a, b) for a, b in frame_runs(frames)]
    return out


def situations(scene: Scene, config: ReasoningConfig = DEFAULT_CONFIG) -> list[Situation]:
    """HIDDEN_ENTITY and SUDDEN_STOP situations, by start frame."""
    found = hidden_entity_situations(scene, config) + sudden_stop_situations(scene, config)
    return sorted(found, key=lambda s: (s.start, s.kind, tuple(natural_key(o) for o in s.objects)))
