"""Anticipation of hidden entities (paper Section 4.1.2): the reasoning parameters, the ego region,
box predictors and ``anticipate(unhides_from_behind(T1,T2),T)``."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Sequence

from ..knowledge import relations as rel
from ..knowledge.event_table import EVENT_TABLE
from .episodes import hiding_end, hiding_episodes
from .model import Box, Scene, SceneError, SceneTrack


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
            end = ep.resumed_at if ep.resumed_at is not None else hiding_end(scene, ep)
            if end is None or t < end:
                return ep.hider
    return None


_UNHIDE = next(e.name for e in EVENT_TABLE.values() if e.unhides)
"""The event anticipated: the one that resumes a track by coming out from behind (unhides_from_behind)."""


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
        out = [f"anticipate({_UNHIDE}({self.track},{self.hider}),{self.at})",
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
