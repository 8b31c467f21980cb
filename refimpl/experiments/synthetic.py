"""Synthetic frame problems for the scalability benchmark (the paper's Section 6.3, Fig. "Scalability").

The paper times the abduction step on "a synthetic dataset with controlled number of tracks and
percentage of overlapping tracks per frame" (5 .. 100 tracks).  The dataset itself was not
published, so refimpl generates its own: one frame problem <VO_t, P_t, ML_t> plus an event
history, built to exercise every part of the model (docs/model-spec.md):

- **Overlap share.**  ``overlap`` is the share of tracks that some other track covers by more
  than 10 % of their box area while standing in front (its bottom edge strictly lower): exactly
  the tracks for which ``hides_behind`` is spatially possible (``overlapping_top`` with the
  default ``hide_overlap=10``).  The tracks are laid out in *clusters*: depth trees whose root
  is the frontmost box and in which every other box stands behind its parent (the parent covers
  20..80 % of it, the child's bottom edge is higher).  A cluster of k tracks holds k-1 such
  tracks (all but the root), so ``n - round(overlap*n)`` clusters give the requested count
  exactly; clusters never touch each other.  The count is at most n-1 (a depth order has a
  frontmost track), so ``overlap=1`` means "all but one", in a single cluster.
- **Halted tracks** (``round(halted_rate*n)`` of them): a halted track behind another track
  is, with probability 3/4, halted by ``hides_behind(trk, parent)``, otherwise (and always when
  nothing can hide it) by ``missing_detections(trk)``, at a time 1..40 frames back, so that
  ``lost`` is possible for some (the default thresholds are 3 and 30 frames) and not for others.
- **History**: ``enters_fov(trk)`` at every track's start time (as the tracker logs it), the
  halting event of each halted track, and for a fifth of the active tracks a finished earlier
  episode (``hides_behind`` + ``unhides_from_behind``, or ``missing_detections`` + ``recover``),
  which leaves the fluents where an active track needs them.  Some tracks start at most 3
  frames back, so ``noise`` is possible for them.  Histories only contain event sequences the
  model's preconditions allow (a track hides only behind a track that is not itself hidden).
- **Detections**: every active track not missed (probability ``miss_rate``) and every halted
  track that reappears (probability ``reappear_rate``) yields its predicted box with Gaussian
  jitter (centre 5 % of the size, log-size 0.05) and a high confidence; ``Poisson(fp_rate*n)``
  false positives (half near a track, half anywhere) get low confidences; ``Poisson(new_rate*n)``
  new objects appear anywhere with high confidence (for ``start`` / ``enters_fov``).
  Detections are shuffled, so det_i says nothing about trk_i.
- Types ``pedestrian`` (70 %, aspect ~0.41) and ``car`` (aspect ~1.8); box sizes shrink with n
  so that 200 tracks still fit a 1920x1080 image (the boxes take about a quarter of it).
- Matching likelihood: ``geometry.iou_matrix`` + ``scale_iou`` on the *integer* boxes written to
  the problem, only pairs with IoU > 0, tracks in order then detections in order.
- Constants: ``img_width`` / ``img_height`` (as the tracker sets them), so ``leaves_fov`` is
  testable for tracks near the border.

Dense crowds (:func:`dense_frame`, ``refimpl bench-scale --dense``) are the other kind: the
frames above decompose into components of a few dozen nodes, these are one component each (see
its docstring).

Everything is drawn from one ``numpy.random.Generator`` seeded with (seed, n_tracks, overlap, ...)
in a fixed order: the same arguments give the same problem, byte for byte (numpy's Generator
streams do not depend on the platform).  Counts from shares ("round(overlap*n)" etc.) round half
up, as everywhere in refimpl.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..core.geometry import integer_box, intersection_area, iou_matrix, scale_iou
from ..knowledge.relations import overlapping_top
from ..core.spec import Box, Detection, FrameProblem, HistoryEvent, Term, TrackPrediction
from ..knowledge.event_table import EventType, explaining
from ..solvers.common import components

HIDE_OVERLAP = 10
"""The overlap (percent of the back box's area) the generator builds for: model/constants.lp's default."""

TYPES = ("pedestrian", "car")
_TYPE_P = (0.7, 0.3)
_ASPECT = {"pedestrian": 0.41, "car": 1.8}  # width / height
_FILL = 0.25  # share of the image area the track boxes take together (before overlaps)
_MAX_HEIGHT_FRAC = 0.3  # no box taller than 30 % of the image height
_MIN_TIME = 4  # start < halt < resume < time needs a few time points
_MIN_W, _MIN_H = 4.0, 8.0  # smallest box in pixels, so that integer rounding keeps the geometry


def _check_arguments(n_tracks: int, overlap: float, time: int, image_size: tuple[int, int], miss_rate: float,
                     halted_rate: float, fp_rate: float, reappear_rate: float, new_rate: float) -> None:
    """synthetic_frame's arguments, each in its range; ValueError naming the first that is not."""
    if int(n_tracks) < 0:
        raise ValueError(f"n_tracks must be >= 0, got {n_tracks}")
    if not 0.0 <= overlap <= 1.0:
        raise ValueError(f"overlap must be within [0, 1], got {overlap}")
    for name, rate in (("miss_rate", miss_rate), ("halted_rate", halted_rate),
                       ("reappear_rate", reappear_rate)):
        if not 0.0 <= rate <= 1.0:
            raise ValueError(f"{name} must be within [0, 1], got {rate}")
    if fp_rate < 0 or new_rate < 0:
        raise ValueError("fp_rate and new_rate must be >= 0")
    if time < _MIN_TIME:
        raise ValueError(f"time must be >= {_MIN_TIME} (histories need earlier time points), got {time}")
    if int(image_size[0]) <= 0 or int(image_size[1]) <= 0:
        raise ValueError(f"image_size must be positive, got {image_size}")


def _detections(rng: np.random.Generator, trk_types: list[str], trk_boxes: list[Box], halted: set[int],
                width: int, height: int, miss_rate: float, fp_rate: float, reappear_rate: float,
                new_rate: float) -> tuple[Detection, ...]:
    """The frame's detections, in random order: the tracks' seen ones (jittered), false positives
    near a track or anywhere, and new objects (synthetic_frame's step 3, drawn from its generator)."""
    n = len(trk_boxes)
    dets: list[tuple[str, int, Box]] = []
    for i in range(n):
        u = rng.random()
        seen = u < reappear_rate if i in halted else u >= miss_rate
        jitter = rng.standard_normal(4)
        conf = _confidence(rng.beta(8.0, 1.5))
        if seen:
            dets.append((trk_types[i], conf, _jitter(trk_boxes[i], jitter, 0.05, 0.05)))
    n_fp = int(rng.poisson(fp_rate * n))
    for _ in range(n_fp):
        near = n > 0 and rng.random() < 0.5
        ty = TYPES[int(rng.choice(len(TYPES), p=_TYPE_P))]
        if near:
            k = int(rng.integers(n))
            box = _jitter(trk_boxes[k], rng.standard_normal(4), 0.5, 0.3)
        else:
            box = _random_box(rng, ty, n, width, height)
        dets.append((ty, _confidence(rng.beta(2.0, 5.0)), box))
    n_new = int(rng.poisson(new_rate * n))
    for _ in range(n_new):
        ty = TYPES[int(rng.choice(len(TYPES), p=_TYPE_P))]
        dets.append((ty, _confidence(rng.beta(8.0, 1.5)), _random_box(rng, ty, n, width, height)))
    perm = rng.permutation(len(dets))
    detections = tuple(Detection(f"det_{j}", dets[p][0], dets[p][1], dets[p][2]) for j, p in enumerate(perm))
    return detections


def synthetic_frame(n_tracks: int, overlap: float, seed: int, time: int = 100,
                    image_size: tuple[int, int] = (1920, 1080), miss_rate: float = 0.1,
                    halted_rate: float = 0.1, fp_rate: float = 0.1, with_history: bool = True,
                    reappear_rate: float = 0.5, new_rate: float = 0.05) -> FrameProblem:
    """One synthetic frame problem with n_tracks tracks of which round(overlap*n) can hide behind another.

    Parameters (rates are per track; see the module docstring for the construction):
      n_tracks: number of tracks (>= 0).
      overlap: share of tracks in [0, 1] that another track covers by > 10 % from the front;
        realised exactly as min(round(overlap*n), n-1) tracks.
      seed: the random seed, >= 0 (together with the other arguments it fixes the problem).
      time: curr_time (>= 4); history events lie in 0 .. time-1.
      image_size: (width, height) in pixels; written as the img_width/img_height constants.
      miss_rate: probability that an active track has no detection.
      halted_rate: share of tracks that are halted, realised as round(halted_rate*n).
      fp_rate: mean number of false positives per track (Poisson).
      with_history: False gives an empty event history (the fluents then take initial values).
      reappear_rate: probability that a halted track has a detection again.
      new_rate: mean number of new, confidently detected objects per track (Poisson).
    """
    n = int(n_tracks)
    _check_arguments(n_tracks, overlap, time, image_size, miss_rate, halted_rate, fp_rate, reappear_rate, new_rate)
    width, height = int(image_size[0]), int(image_size[1])

    rng = np.random.default_rng(
        [int(seed), n, int(round(overlap * 1000)), int(time), width, height])
    n_overlap = overlapping_count(n, overlap)

    # -- 1. tracks: clusters (depth trees) laid out without touching each other -----------------
    types = [TYPES[i] for i in rng.choice(len(TYPES), size=n, p=_TYPE_P)]
    cluster_sizes = _cluster_sizes(rng, n, n_overlap)
    boxes, front_of = _layout(rng, types, cluster_sizes, width, height)
    order = rng.permutation(n)  # track ids in random order, so trk_0 is not always a back box
    inv = np.empty(n, dtype=int)
    inv[order] = np.arange(n)
    # renumber: track k of the layout becomes trk_{inv[k]}
    trk_boxes: list[Box] = [boxes[order[i]] for i in range(n)]
    trk_types = [types[order[i]] for i in range(n)]
    trk_front = [None if front_of[order[i]] is None else int(inv[front_of[order[i]]]) for i in range(n)]
    # -- 2. states and histories -----------------------------------------------------------------
    n_halted = _round_half_up(halted_rate * n)
    halted = set(int(i) for i in rng.choice(n, size=n_halted, replace=False)) if n else set()
    events = _histories(rng, trk_front, halted, time)
    history = tuple(e for evs in events for e in evs) if with_history else ()

    tracks = tuple(
        TrackPrediction(f"trk_{i}", trk_types[i], "halted" if i in halted else "active", trk_boxes[i])
        for i in range(n))

    # -- 3. detections ---------------------------------------------------------------------------
    detections = _detections(rng, trk_types, trk_boxes, halted, width, height, miss_rate, fp_rate, reappear_rate,
                             new_rate)

    return FrameProblem(
        time=int(time),
        detections=detections,
        tracks=tracks,
        iou=iou_facts(tracks, detections),
        constants=(("img_width", width), ("img_height", height)),
        history=history,
    )


def overlapping_count(n_tracks: int, overlap: float) -> int:
    """How many tracks synthetic_frame places behind another: round(overlap*n), at most n-1."""
    if n_tracks <= 0:
        return 0
    return min(_round_half_up(overlap * n_tracks), n_tracks - 1)


def iou_facts(tracks: Sequence[TrackPrediction], detections: Sequence[Detection]) -> tuple[tuple[str, str, int], ...]:
    """iou/3 facts of the integer boxes: every (track, detection) pair with IoU > 0, in input order."""
    if not tracks or not detections:
        return ()
    ml = scale_iou(iou_matrix(np.array([t.box for t in tracks], dtype=float),
                              np.array([d.box for d in detections], dtype=float)))
    return tuple((t.id, d.id, int(ml[a, b]))
                 for a, t in enumerate(tracks) for b, d in enumerate(detections) if ml[a, b] > 0)


# ---------------------------------------------------------------------------------------------
# construction helpers
# ---------------------------------------------------------------------------------------------

def _round_half_up(x: float) -> int:
    return int(math.floor(x + 0.5))


def _confidence(score: float) -> int:
    return int(min(100, max(0, math.floor(score * 100 + 0.5))))


def _jitter(box: Box, z: np.ndarray, centre_sigma: float, size_sigma: float) -> Box:
    """A box moved by z[0:2]*centre_sigma*size and rescaled by exp(z[2:4]*size_sigma)."""
    x, y, w, h = (float(v) for v in box)
    cx = x + w / 2 + z[0] * centre_sigma * w
    cy = y + h / 2 + z[1] * centre_sigma * h
    w2 = w * math.exp(z[2] * size_sigma)
    h2 = h * math.exp(z[3] * size_sigma)
    return integer_box(np.array([cx - w2 / 2, cy - h2 / 2, w2, h2]))


def _base_height(ty: str, n: int, width: int, height: int) -> float:
    """Typical box height: n boxes of this type would fill _FILL of the image, capped at 30 % of its height."""
    area = _FILL * width * height / max(n, 1)
    return min(math.sqrt(area / _ASPECT[ty]), _MAX_HEIGHT_FRAC * height)


def _box_size(rng: np.random.Generator, ty: str, n: int, width: int, height: int,
              scale: float = 1.0) -> tuple[float, float]:
    h = _base_height(ty, n, width, height) * math.exp(rng.normal(0.0, 0.25)) * scale
    w = h * _ASPECT[ty] * math.exp(rng.normal(0.0, 0.1))
    return max(w, _MIN_W), max(h, _MIN_H)


def _random_box(rng: np.random.Generator, ty: str, n: int, width: int, height: int) -> Box:
    w, h = _box_size(rng, ty, n, width, height)
    x = rng.uniform(-0.2 * w, width - 0.8 * w)
    y = rng.uniform(-0.1 * h, height - 0.9 * h)
    return integer_box(np.array([x, y, w, h]))


def _cluster_sizes(rng: np.random.Generator, n: int, n_overlap: int) -> list[int]:
    """n - n_overlap clusters whose sizes sum to n (each cluster has one frontmost, unhidden track)."""
    clusters = n - n_overlap
    if clusters <= 0:
        return []
    extra = rng.multinomial(n_overlap, np.full(clusters, 1.0 / clusters))
    return [1 + int(e) for e in extra]


def _cluster(rng: np.random.Generator, types: Sequence[str], n: int, width: int, height: int,
             scale: float) -> tuple[list[Box], list[int | None]] | None:
    """One cluster as a depth tree, relative to its first box at (0, 0).

    Member 0 is the frontmost; member k > 0 stands behind a random earlier member (its parent):
    the parent covers 20..80 % of member k's box and member k's bottom edge is 2 px .. a quarter
    of the parent's height higher (farther from the camera), so bottom edges strictly decrease
    from the root and only the root is covered by nobody in front of it.  Returns the boxes and
    each member's parent (None for the root), or None when the boxes are too small to build it.
    """
    boxes: list[Box] = []
    parent: list[int | None] = []
    for k, ty in enumerate(types):
        if k == 0:
            w, h = _box_size(rng, ty, n, width, height, scale)
            boxes.append(integer_box(np.array([0.0, 0.0, w, h])))
            parent.append(None)
            continue
        p = int(rng.integers(k))
        xp, yp, wp, hp = boxes[p]
        for _attempt in range(50):
            w, h = _box_size(rng, ty, n, width, height, scale)
            # farther objects look smaller: at most 1.25 times the area of the box in front
            shrink = math.sqrt(min(1.0, 1.25 * wp * hp / (w * h)))
            w, h = max(w * shrink, _MIN_W), max(h * shrink, _MIN_H)
            d = rng.uniform(2.0, max(3.0, 0.25 * hp))  # how much higher the bottom edge is
            bottom = yp + hp - d
            ov_y = min(h, bottom - yp)
            if ov_y <= 0:
                continue
            ov_x = min(rng.uniform(0.2, 0.8) * w * h / ov_y, w, wp)
            x = xp + wp - ov_x if rng.random() < 0.5 else xp + ov_x - w
            box = integer_box(np.array([x, bottom - h, w, h]))
            if overlapping_top(box, boxes[p], HIDE_OVERLAP) and box[1] + box[3] < yp + hp:
                boxes.append(box)
                parent.append(p)
                break
        else:
            return None
    return boxes, parent


def _layout(rng: np.random.Generator, types: Sequence[str], sizes: Sequence[int], width: int,
            height: int) -> tuple[list[Box], list[int | None]]:
    """Place the clusters without any two touching; returns boxes (layout order) and, per box,
    the index of the box directly in front of it (None for the frontmost of a cluster).

    Clusters are placed largest first by rejection sampling; if one does not fit, every box is
    shrunk by 15 % and the layout starts again (deterministically: the same draws follow).
    """
    n = len(types)
    members: list[list[int]] = []
    k = 0
    for s in sizes:
        members.append(list(range(k, k + s)))
        k += s
    scale = 1.0
    for _round in range(30):
        built = [_cluster(rng, [types[i] for i in m], n, width, height, scale) for m in members]
        boxes: list[Box | None] = [None] * n
        placed: list[tuple[int, int, int, int]] = []  # x1, y1, x2, y2 of placed cluster extents
        ok = all(b is not None for b in built)
        order = sorted(range(len(built)), key=lambda c: -_extent_area(built[c][0])) if ok else []
        for c in order:
            ex = _extent(built[c][0])
            bw, bh = ex[2] - ex[0], ex[3] - ex[1]
            if bw > 0.9 * width or bh > 0.9 * height:  # a large cluster that does not fit the image
                ok = False
                break
            for _attempt in range(400):
                ox = int(round(rng.uniform(-0.15 * bw, width - 0.85 * bw))) - ex[0]
                oy = int(round(rng.uniform(-0.1 * bh, height - 0.9 * bh))) - ex[1]
                cand = (ex[0] + ox, ex[1] + oy, ex[2] + ox, ex[3] + oy)
                if all(cand[2] <= q[0] or q[2] <= cand[0] or cand[3] <= q[1] or q[3] <= cand[1]
                       for q in placed):
                    placed.append(cand)
                    for i, b in zip(members[c], built[c][0]):
                        boxes[i] = (b[0] + ox, b[1] + oy, b[2], b[3])
                    break
            else:
                ok = False
                break
        if ok:
            front: list[int | None] = [None] * n
            for m, (_, parent) in zip(members, built):
                for i, p in zip(m, parent):
                    front[i] = None if p is None else m[p]
            return [b for b in boxes if b is not None], front
        scale *= 0.85
    raise ValueError(f"cannot lay out {n} tracks with these overlaps in a {width}x{height} image")


def _extent(boxes: Sequence[Box]) -> tuple[int, int, int, int]:
    return (min(b[0] for b in boxes), min(b[1] for b in boxes),
            max(b[0] + b[2] for b in boxes), max(b[1] + b[3] for b in boxes))


def _extent_area(boxes: Sequence[Box]) -> int:
    x1, y1, x2, y2 = _extent(boxes)
    return (x2 - x1) * (y2 - y1)


_STARTS = explaining("start")
_HIDES = tuple(e for e in explaining("halt") if e.occluder is not None)
_SOLO_HALTS = tuple(e for e in explaining("halt") if e.occluder is None and e.arity == 1)
_UNHIDES = tuple(e for e in explaining("resume") if e.occluder is not None)
_SOLO_RESUMES = tuple(e for e in explaining("resume") if e.occluder is None and e.arity == 1)
"""The event table's roles the histories are drawn from: a new event of one of them is drawn too."""


def _pick(rng: np.random.Generator, events: Sequence[EventType]) -> EventType:
    """One of the events (uniformly); no draw when there is only one, so that the histories of a
    table with one event per role stay those it always gave."""
    return events[0] if len(events) == 1 else events[int(rng.integers(len(events)))]


def _histories(rng: np.random.Generator, front_of: Sequence[int | None], halted: set[int],
               time: int) -> list[list[HistoryEvent]]:
    """Per track: its start event (enters_fov), the halting event of a halted track (hides_behind
    or missing_detections, or another halting event of the table with the same role), and for
    some active tracks a finished occlusion episode (a hide and an unhide, or a one-track halt
    and resume); every list is in time order.

    Tracks are handled front to back, so the track in front of a track (its possible occluder) is
    decided first.  A track hides (now or in an episode) only behind a front track that never hid
    itself and had started before, so every hides_behind / unhides_from_behind in the history had
    its precondition (the occluder visible) when it happened.
    """
    n = len(front_of)
    last = time - 1
    events: list[list[HistoryEvent]] = [[] for _ in range(n)]
    start: dict[int, int] = {}
    hid: set[int] = set()  # tracks with a hides_behind anywhere in their history
    for i in _front_to_back(front_of):
        name = Term(f"trk_{i}")
        f = front_of[i]
        young = rng.random() < 0.1  # started at most 3 frames ago: noise is possible
        hide_draw = rng.random()
        if i in halted:
            halt_t = max(1, last + 1 - int(rng.integers(1, 41)))
            start_t = max(0, halt_t - 2) if young else int(rng.integers(max(0, halt_t - 300), halt_t))
            events[i].append(HistoryEvent(Term(_pick(rng, _STARTS).name, (name,)), start_t))
            if f is not None and f not in hid and start[f] < halt_t and hide_draw < 0.75:
                events[i].append(HistoryEvent(Term(_pick(rng, _HIDES).name, (name, Term(f"trk_{f}"))), halt_t))
                hid.add(i)
            else:
                events[i].append(HistoryEvent(Term(_pick(rng, _SOLO_HALTS).name, (name,)), halt_t))
        else:
            if young:
                start_t = last - int(rng.integers(0, 3))
            else:
                start_t = int(rng.integers(max(0, last - 300), last - 2))
            events[i].append(HistoryEvent(Term(_pick(rng, _STARTS).name, (name,)), start_t))
            if not young and hide_draw < 0.2:
                hide_t = int(rng.integers(start_t + 1, last))
                back_t = int(rng.integers(hide_t + 1, last + 1))
                if f is not None and f not in hid and start[f] < hide_t:
                    front = Term(f"trk_{f}")
                    events[i].append(HistoryEvent(Term(_pick(rng, _HIDES).name, (name, front)), hide_t))
                    events[i].append(HistoryEvent(Term(_pick(rng, _UNHIDES).name, (name, front)), back_t))
                    hid.add(i)
                else:
                    events[i].append(HistoryEvent(Term(_pick(rng, _SOLO_HALTS).name, (name,)), hide_t))
                    events[i].append(HistoryEvent(Term(_pick(rng, _SOLO_RESUMES).name, (name,)), back_t))
        start[i] = start_t
    return events


def _front_to_back(front_of: Sequence[int | None]) -> list[int]:
    """Track indices ordered so that every track comes after the track in front of it."""
    depth: list[int] = []
    for i in range(len(front_of)):
        d, j = 0, front_of[i]
        while j is not None:
            d, j = d + 1, front_of[j]
        depth.append(d)
    return sorted(range(len(front_of)), key=lambda i: (depth[i], i))


# ---------------------------------------------------------------------------------------------
# Dense crowds: the whole frame one component
# ---------------------------------------------------------------------------------------------

DENSE_TYPE = "pedestrian"
"""The one type of a dense frame (two types would split it: match_type pairs equal types only)."""
_DENSE_DEPTH = 8.0  # boxes per box area of the crowd's square: each box overlaps ~4x as many
_DENSE_PILE_IOU = (0.45, 0.85)  # IoU of a piled box with the box it piles on


def dense_frame(n_tracks: int, seed: int, time: int = 100, image_size: tuple[int, int] = (1920, 1080),
                halted_rate: float = 0.1, miss_rate: float = 0.1, reappear_rate: float = 0.5,
                fp_rate: float = 0.1) -> FrameProblem:
    """A crowd in which every track and every detection is one component (``components``).

    Tracks, all of type DENSE_TYPE with boxes of synthetic_frame's size for n tracks (log-size
    jitter 0.1), are drawn uniformly in a square that holds them _DENSE_DEPTH deep, so that each
    box overlaps ~30 others.  Detections follow synthetic_frame's rules (a detected active track
    with probability 1 - miss_rate, a halted one with reappear_rate; jitter 3 %, confidence
    60..100, above conf_thresh_resume), plus ``Poisson(fp_rate*n)`` false positives on tracks
    (jitter 10 %, confidence 5..45).  Then, until the frame is one component: every track outside
    the largest component (the first on a tie) *piles on* the nearest track inside it (centre
    distance, then index): it stands behind it, its bottom edge 2 px .. a quarter of the height
    higher, with IoU 0.45..0.85, so that its detection or the other track's pairs the two (the
    track is detected if neither is); a false positive outside is dropped.  States and histories
    as in synthetic_frame; the track in front of a track is the one it piles on, else the track
    covering it most from the front (bottom edge strictly lower).  The constant iou_thresh_claim =
    100000 switches resume_claimed off (docs/model.md 3.29), which would cut halted tracks out.
    """
    n = int(n_tracks)
    if n < 1:
        raise ValueError(f"n_tracks must be >= 1, got {n_tracks}")
    width, height = int(image_size[0]), int(image_size[1])
    rng = np.random.default_rng([int(seed), n, int(time), width, height])
    h0 = _base_height(DENSE_TYPE, n, width, height)
    w0 = h0 * _ASPECT[DENSE_TYPE]
    side = max(math.sqrt(n * w0 * h0 / _DENSE_DEPTH), 2.0 * h0)  # a few tracks: still a crowd, not one pile
    x0, y0 = (width - side) / 2, (height - side) / 2
    boxes: list[Box] = []
    for _ in range(n):
        w, h = w0 * math.exp(rng.normal(0.0, 0.1)), h0 * math.exp(rng.normal(0.0, 0.1))
        boxes.append(integer_box(np.array([x0 + rng.uniform(0, max(side - w, 0.0)), y0 + rng.uniform(0, max(side - h, 0.0)), w, h])))
    halted = set(int(i) for i in rng.choice(n, size=_round_half_up(halted_rate * n), replace=False))
    seen = [bool(rng.random() < reappear_rate) if i in halted else bool(rng.random() >= miss_rate)
            for i in range(n)]
    det_jitter = [(rng.standard_normal(4), int(rng.integers(60, 101))) for _ in range(n)]
    fps = [(int(rng.integers(n)), rng.standard_normal(4), int(rng.integers(5, 46)))
           for _ in range(int(rng.poisson(fp_rate * n)))]
    piled_on: dict[int, int] = {}
    states = ["halted" if i in halted else "active" for i in range(n)]
    while True:
        problem = _crowd(boxes, states, seen, det_jitter, fps, time, width, height, ())
        comps = components(problem)
        if len(comps) == 1:
            break
        crowd = max(comps, key=lambda c: len(c.tracks) + len(c.detections))
        n_seen = sum(seen)  # false positives come after the tracks' detections (_crowd)
        inside = [int(t[4:]) for t in crowd.tracks]
        for c in comps:
            if c is crowd:
                continue
            for k in sorted(int(t[4:]) for t in c.tracks):
                boxes[k], piled_on[k] = _pile(rng, boxes, inside, boxes[k])
                seen[k] = seen[k] or not seen[piled_on[k]]
                inside.append(k)
        dets_inside = set(crowd.detections)
        fps = [f for j, f in enumerate(fps) if f"det_{n_seen + j}" in dets_inside or f[0] in piled_on]
    front = [piled_on.get(i, _front(boxes, i)) for i in range(n)]
    events = _histories(rng, front, halted, time)
    return _crowd(boxes, states, seen, det_jitter, fps, time, width, height, events)


def _iou(a: Box, b: Box) -> float:
    inter = intersection_area(a, b)
    return inter / (a[2] * a[3] + b[2] * b[3] - inter)


def _front(boxes: Sequence[Box], i: int) -> int | None:
    """The box covering box i most from the front (bottom edge strictly lower), if any."""
    b = boxes[i]
    best = None
    for j, c in enumerate(boxes):
        if j != i and c[1] + c[3] > b[1] + b[3] and overlapping_top(b, c, HIDE_OVERLAP):
            key = (intersection_area(b, c), -j)
            if best is None or key > best[0]:
                best = (key, j)
    return None if best is None else best[1]


def _pile(rng: np.random.Generator, boxes: Sequence[Box], placed: Sequence[int], drawn: Box) -> tuple[Box, int]:
    """A box of ``drawn``'s size standing behind the placed box nearest to it (centre distance,
    then the smallest index), with IoU in _DENSE_PILE_IOU; and that box's index."""
    w, h = drawn[2], drawn[3]
    cx, cy = drawn[0] + w / 2, drawn[1] + h / 2
    p = min(placed, key=lambda i: ((boxes[i][0] + boxes[i][2] / 2 - cx) ** 2
                                   + (boxes[i][1] + boxes[i][3] / 2 - cy) ** 2, i))
    xp, yp, wp, hp = boxes[p]
    while True:
        d = rng.uniform(2.0, max(3.0, 0.25 * hp))  # how much higher the bottom edge is
        dx = rng.uniform(-0.5, 0.5) * wp
        box = integer_box(np.array([xp + wp / 2 + dx - w / 2, yp + hp - d - h, w, h]))
        if (_DENSE_PILE_IOU[0] <= _iou(box, boxes[p]) <= _DENSE_PILE_IOU[1]
                and overlapping_top(box, boxes[p], HIDE_OVERLAP) and box[1] + box[3] < yp + hp):
            return box, p


def _crowd(boxes, states, seen, det_jitter, fps, time, width, height, events) -> FrameProblem:
    """The frame problem: the seen tracks' detections (det_0 ..) then the false positives."""
    tracks = tuple(TrackPrediction(f"trk_{i}", DENSE_TYPE, s, b) for i, (b, s) in enumerate(zip(boxes, states)))
    dets = [(_jitter(boxes[i], det_jitter[i][0], 0.03, 0.03), det_jitter[i][1]) for i in range(len(boxes)) if seen[i]]
    dets += [(_jitter(boxes[k], z, 0.1, 0.05), conf) for k, z, conf in fps]
    detections = tuple(Detection(f"det_{j}", DENSE_TYPE, conf, box) for j, (box, conf) in enumerate(dets))
    # resume_claimed off (docs/model.md 3.29): the histories, drawn once the crowd is one component,
    # would cut halted tracks out of it
    return FrameProblem(time=int(time), detections=detections, tracks=tracks, iou=iou_facts(tracks, detections),
                        constants=(("img_width", width), ("img_height", height), ("iou_thresh_claim", 100000)),
                        history=tuple(e for evs in events for e in evs))
