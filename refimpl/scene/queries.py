"""Queries on a scene: the relation registry between tracks (Table 2), track summaries and the
query language (:data:`QUERIES`, :func:`query`)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Callable, Sequence

from ..knowledge import relations as rel
from ..knowledge.events import EventState
from ..knowledge.event_table import HALT_KINDS, HIDING_KINDS
from .anticipation import DEFAULT_CONFIG, ReasoningConfig, anticipate, no_anticipation_reason
from .episodes import ENDINGS, episodes
from .model import Box, Scene, SceneError, frame_runs, track_id
from .situations import situations
from ..core.constants import default_constants


# ---------------------------------------------------------------------------------------
# Relations between tracks (Table 2)
# ---------------------------------------------------------------------------------------

RCC_SHORT_NAME = dict(rel.RCC8_CODE)
"""topology()'s answer -> its short code, from the relation code table (refimpl.knowledge.relations)."""
_RCC_SHORT = {code: full for full, code in RCC_SHORT_NAME.items()}

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
            out.append((t.id, frame_runs(frames)))
    return out


# ---------------------------------------------------------------------------------------
# Queries
# ---------------------------------------------------------------------------------------

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
        if ep.track == trk and ep.kind in HALT_KINDS:
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
        what = f"{h['kind']} behind {h['behind']}" if h["kind"] in HIDING_KINDS else h["kind"]
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


def _answer_tracks(scene: Scene, config: ReasoningConfig) -> tuple[list[str], object]:
    data = [track_summary(scene, t.id) for t in scene.tracks]
    lines = []
    for s in data:
        hidden = sum(1 for h in s["halts"] if h["kind"] in HIDING_KINDS)
        lines.append(f"{s['track']} ({s['type']}): frames {s['first_frame']}-{s['last_frame']}, observed "
                     f"{s['observed_frames']}, hidden {hidden} time{'s' if hidden != 1 else ''}"
                     + (f", {s['ended_by'] or 'ended'} at {s['ended_at']}" if s["ended_at"] is not None else ""))
    return lines, data


def _answer_track(scene: Scene, config: ReasoningConfig, x: str) -> tuple[list[str], object]:
    data = track_summary(scene, x)
    return _summary_lines(data), data


def _answer_hidden_by(scene: Scene, config: ReasoningConfig, x: str) -> tuple[list[str], object]:
    lines, data = [], []
    for t in scene.tracks:
        runs = [(a, b) for a, b, v in scene.timeline(f"hidden_by({t.id},{x})") if v == "true"]
        if runs:
            data.append({"track": t.id, "frames": [list(r) for r in runs]})
            lines.append(f"{t.id} hidden by {x}: {_frames_of(runs)}")
    if not data:
        lines.append(f"no track was hidden by {x}")
    return lines, data


def _answer_holds_at(scene: Scene, config: ReasoningConfig, x: str, f: int) -> tuple[list[str], object]:
    data = holds_at(scene, x, f)
    lines = [f"{k} = {' | '.join(v)}" for k, v in data.items()]
    hidden = [k for k in data if k.startswith("hidden_by")]
    if not hidden:
        lines.append(f"hidden_by({x},X) = false for every other track X")
    where = scene.track(x).box_at(f)
    lines.append(f"{x} at {f}: " + (f"{where[0]} box {_fmt_box(where[1])}" if where else "no box"))
    return lines, data


def _answer_events(scene: Scene, config: ReasoningConfig, a: int, b: int,
                   who: str | None = None) -> tuple[list[str], object]:
    sel = [e for e in scene.events if a <= e.time <= b
           and (who is None or who in (str(x) for x in e.event.args))]
    data = [{"time": e.time, "event": str(e.event)} for e in sel]
    return [str(e) for e in sel] or [f"no events in frames {a}-{b}"], data


def _answer_relation(scene: Scene, config: ReasoningConfig, x: str, rel_name: str) -> tuple[list[str], object]:
    name = rel_name.lower()
    if name not in RELATION_NAMES:
        raise SceneError(f"unknown relation {rel_name!r} (relations: {', '.join(RELATION_NAMES)})")
    found = related(scene, x, name)
    data = [{"track": y, "frames": [list(r) for r in runs]} for y, runs in found]
    return [f"{y} {name} {x}: {_frames_of(runs)}" for y, runs in found] or [f"no track is {name} {x}"], data


def _answer_anticipate(scene: Scene, config: ReasoningConfig, x: str, f: int) -> tuple[list[str], object]:
    ant = anticipate(scene, x, f, config)
    if ant is None:
        return [no_anticipation_reason(scene, x, f, config)], None
    data = {"track": ant.track, "hider": ant.hider, "now": ant.now, "at": ant.at, "box": list(ant.box),
            "position": list(ant.position), "in_front": ant.in_front, "warning": ant.warning,
            "atoms": ant.atoms()}
    lines = ant.atoms() + [f"({x} predicted to reappear from behind {ant.hider} at frame {ant.at}, "
                           f"{ant.at - f} frame{'' if ant.at - f == 1 else 's'} after {f}, at ({ant.position[0]:.0f}, "
                           f"{ant.position[1]:.0f}) px; {'in front' if ant.in_front else 'not in front'})"]
    return lines, data


def _answer_situations(scene: Scene, config: ReasoningConfig) -> tuple[list[str], object]:
    found = situations(scene, config)
    data = [{"situation": s.kind, "objects": list(s.objects), "from": s.start, "to": s.end} for s in found]
    return [s.describe() for s in found] or ["no safety-critical situations"], data


_ARGUMENT_PARSERS: dict[str, Callable[[Scene, str], object]] = {
    "T": track_id,
    "FRAME": lambda scene, text: _frame(text),
    "FROM": lambda scene, text: _frame(text, "FROM"),
    "TO": lambda scene, text: _frame(text, "TO"),
    "REL": lambda scene, text: text,
}
"""A placeholder of a query form's usage -> how its word is read (a track id, a frame number, a name)."""


@dataclass(frozen=True)
class QueryForm:
    """One row of the query registry: its usage (name, then placeholders of _ARGUMENT_PARSERS, an
    optional one in [brackets]), what it answers, and the handler that answers it from the parsed words."""

    usage: str
    description: str
    answer: Callable[..., tuple[list[str], object]]

    @property
    def name(self) -> str:
        return self.usage.split()[0]

    @property
    def placeholders(self) -> tuple[str, ...]:
        return tuple(w.strip("[]") for w in self.usage.split()[1:])

    @property
    def arity(self) -> tuple[int, int]:
        """(fewest, most) words after the name."""
        words = self.usage.split()[1:]
        return sum(1 for w in words if not w.startswith("[")), len(words)

    def parse(self, scene: Scene, args: Sequence[str]) -> list[object]:
        """The words read left to right by their placeholders' parsers (the first bad word raises)."""
        return [_ARGUMENT_PARSERS[ph](scene, word) for ph, word in zip(self.placeholders, args)]


QUERIES = {q.name: q for q in (
    QueryForm("tracks", "every track: type, life, observed / hidden frames", _answer_tracks),
    QueryForm("track T", "T's life: start, hidden and missing spans, end", _answer_track),
    QueryForm("hidden_by T", "which tracks T hid, and when (frames where hidden_by(X,T) holds)", _answer_hidden_by),
    QueryForm("holds_at T FRAME", "every fluent of T at FRAME (holds_at, events before FRAME)", _answer_holds_at),
    QueryForm("events FROM TO [T]", "the events of frames FROM..TO (of track T only)", _answer_events),
    QueryForm("relation T REL", "which tracks Y were ever in relation 'Y REL T', and at which frames",
              _answer_relation),
    QueryForm("anticipate T FRAME",
              "anticipate(unhides_from_behind(T,T2),T') for T hidden at FRAME, with the warning", _answer_anticipate),
    QueryForm("situations", "safety-critical situations: HIDDEN_ENTITY, SUDDEN_STOP with their frames",
              _answer_situations),
)}
"""The query language: form name -> its row (a new query is one row and its handler)."""

QUERY_FORMS = tuple((q.usage, q.description) for q in QUERIES.values())
"""(usage, description) of every query form, in registry order."""


def query(scene: Scene, text: str, config: ReasoningConfig = DEFAULT_CONFIG) -> Answer:
    """Answer one query (forms: :data:`QUERY_FORMS`); SceneError for a malformed query."""
    words = text.split()
    if not words:
        raise SceneError(f"empty query; {query_usage()}")
    name, args = words[0].lower(), words[1:]
    form = QUERIES.get(name)
    if form is None:
        raise SceneError(f"unknown query {words[0]!r}; {query_usage()}")
    lo, hi = form.arity
    if not lo <= len(args) <= hi:
        raise SceneError(f"query {name!r} takes the form '{form.usage}', got {text.strip()!r}; {query_usage()}")
    lines, data = form.answer(scene, config, *form.parse(scene, args))
    return Answer(text.strip(), tuple(lines), data)


def _fmt_box(b: Sequence[float]) -> str:
    return "(" + ", ".join(f"{v:.0f}" for v in b) + ")"
