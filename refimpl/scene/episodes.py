"""Episodes: what the event log says happened to each track, and the same as English sentences."""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..knowledge.event_table import EVENT_TABLE, HIDING_KINDS, explaining, halting
from ..core.spec import natural_key
from .model import Scene, track_id


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
            open_halt[trk] = Episode(_HALTS[name].halt_kind, trk, e.time, args[1] if len(args) > 1 else None)
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
        if ep.kind not in HIDING_KINDS:
            continue
        resumed = ep.end if ep.end_event in _RESUMES else None
        out.append(HidingEpisode(ep.track, ep.other or "", ep.start, resumed, ep.end_event or "open"))
    return out


def hiding_end(scene: Scene, ep: HidingEpisode) -> int | None:
    """The frame of the event that ended a hiding episode without a resume (lost, noise, leaves_fov), else None."""
    if ep.how == "open":
        return None
    for e in scene.events:
        if e.time >= ep.hidden_at and e.event.name == ep.how and e.event.args and str(e.event.args[0]) == ep.track:
            return e.time
    return None


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
    """One plain-English sentence for an episode (phrases from the event table, refimpl.knowledge.event_table)."""
    who = _who(scene, ep.track, True) if ep.track else ""
    halt = halting(ep.kind)
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
    if spec.says_since and ep.track in scene._by_id:
        since = f", seen since frame {scene._by_id[ep.track].first_frame},"
    other = f" {_who(scene, ep.other or '?', False)}" if spec.arity == 2 else ""
    return f"{who}{since} {spec.phrase}{other} at frame {ep.start}."


def explain(scene: Scene, track: str | None = None) -> list[str]:
    """The event sequence as sentences, one per episode, in time order; ``track`` keeps the
    episodes of that track and those in which it hides another."""
    if track is not None:
        track = track_id(scene, track)  # 13 or trk_13; an unknown id is a SceneError
    out = []
    for ep in episodes(scene):
        if track is None or ep.track == track or (ep.kind in HIDING_KINDS and ep.other == track):
            out.append(explain_episode(scene, ep))
    return out
