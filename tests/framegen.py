"""Seeded random small frame problems for the backend tests (tests/test_backend_equivalence.py, test_cpsat.py)."""

from __future__ import annotations

import random

import numpy as np

from refimpl.core.geometry import iou_matrix, scale_iou
from refimpl.core.spec import Detection, FrameProblem, HistoryEvent, Term, TrackPrediction
from refimpl.knowledge.event_table import EVENT_TABLE, EventType, explaining

TYPES = ("car", "person")
CURR_TIME = 40
_WEIGHT = {"halt": 4, "resume": 2, "start": 2, "end": 1}
"""How often a random history event explains each action: every event of the table is drawn,
a new one too, with its action's weight."""


def _box(rng: random.Random) -> tuple[int, int, int, int]:
    return (rng.randint(-5, 150), rng.randint(-5, 150), rng.randint(5, 60), rng.randint(5, 60))


def _jitter(rng: random.Random, b: tuple[int, int, int, int]) -> tuple[int, int, int, int]:
    s = rng.choice((1, 3, 8, 15))
    return (b[0] + rng.randint(-s, s), b[1] + rng.randint(-s, s),
            max(1, b[2] + rng.randint(-s, s)), max(1, b[3] + rng.randint(-s, s)))


def random_frame(rng: random.Random, with_history: bool = False, n_trk: tuple[int, int] = (2, 6),
                 n_det: tuple[int, int] = (2, 6)) -> FrameProblem:
    """2-6 tracks, 2-6 detections, two types, random states and boxes (many of them overlap).

    Detections are mostly jittered copies of track boxes, so assignments and resumes compete;
    track boxes are sometimes jittered copies of each other, so tracks occlude each other.
    With history: random hides_behind / missing_detections / recover / enters_fov events
    (and a few others) on the current tracks before CURR_TIME, not necessarily consistent.
    """
    nt, nd = rng.randint(*n_trk), rng.randint(*n_det)
    tboxes: list[tuple[int, int, int, int]] = []
    for _ in range(nt):
        tboxes.append(_jitter(rng, rng.choice(tboxes)) if tboxes and rng.random() < 0.35 else _box(rng))
    tracks = tuple(
        TrackPrediction(f"trk_{k}", rng.choice(TYPES), rng.choice(("active", "active", "halted")), tboxes[i])
        for i, k in enumerate(rng.sample(range(1, 20), nt)))
    dboxes = [_jitter(rng, rng.choice(tboxes)) if rng.random() < 0.7 else _box(rng) for _ in range(nd)]
    dets = tuple(Detection(f"det_{j}", rng.choice(TYPES), rng.randint(20, 100), dboxes[j]) for j in range(nd))
    ml = scale_iou(iou_matrix(np.array(tboxes, float), np.array(dboxes, float)))
    iou = tuple((tracks[i].id, dets[j].id, int(ml[i, j]))
                for i in range(nt) for j in range(nd) if ml[i, j] > 0)
    history: tuple[HistoryEvent, ...] = ()
    if with_history:
        history = tuple(_random_history(rng, tracks))
    consts: tuple[tuple[str, int], ...] = ()
    if rng.random() < 0.3:
        consts = (("img_width", 200), ("img_height", 200))
    match_types = (("car", "person"),) if rng.random() < 0.1 else ()
    return FrameProblem(time=CURR_TIME, detections=dets, tracks=tracks, iou=iou, constants=consts,
                        history=history, match_types=match_types)


def _random_history(rng: random.Random, tracks) -> list[HistoryEvent]:
    """Random events on the current tracks (and on a track that has gone, trk_99).

    About one track in seven gets an unconstrained history (often inconsistent with their state:
    the model must still agree on it); the others end theirs tracker-like: an active track's last
    events reset clipped/visibility (recover or unhides), a halted track's last event halts it.
    Times repeat often (the set-valued case) and a few lie before mintime.
    """
    ids = [t.id for t in tracks]
    out: list[HistoryEvent] = []

    def when(lo: int = -3) -> int:
        r = rng.random()
        if r < 0.05:
            return rng.randint(lo, -1)
        if r < 0.5:
            return rng.randint(0, CURR_TIME - 1)
        return rng.randint(CURR_TIME - 6, CURR_TIME - 1)

    def other(a: str) -> str:
        return rng.choice([x for x in ids if x != a] + ["trk_99"])

    def event(spec: EventType, a: str) -> Term:
        return Term(spec.name, (Term(a), Term(other(a))) if spec.arity == 2 else (Term(a),))

    def pick(kinds: list[EventType]) -> EventType:
        return kinds[0] if len(kinds) == 1 else rng.choice(kinds)

    kinds = list(EVENT_TABLE.values())
    weights = [_WEIGHT[e.explains] for e in kinds]
    for t in tracks:
        a = t.id
        if rng.random() < 0.6:
            out.append(HistoryEvent(event(pick(explaining("start")), a), when()))
        for _ in range(rng.randint(0, 3)):
            out.append(HistoryEvent(event(rng.choices(kinds, weights=weights)[0], a), when()))
        if rng.random() < 0.15:
            continue  # unconstrained
        last = max([h.time for h in out if h.event.args[0].name == a], default=CURR_TIME - 8)
        tm = rng.randint(last, CURR_TIME - 1) if last < CURR_TIME - 1 else last
        # the last event: a resume of an active track, a halt of a halted one; with an occluder or not
        action = "resume" if t.state == "active" else "halt"
        behind = rng.random() >= (0.7 if action == "resume" else 0.5)
        spec = pick([e for e in explaining(action) if (e.occluder is not None) == behind]
                    or list(explaining(action)))
        if action == "resume" and behind:  # sometimes a one-track resume before it, at the same time
            out.append(HistoryEvent(event(pick([e for e in explaining("resume") if e.occluder is None]), a), tm))
        out.append(HistoryEvent(event(spec, a), tm))
    rng.shuffle(out)
    return out
