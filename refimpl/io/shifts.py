"""Detector and camera shifts of a benchmark's own sequences: how a tracker holds when the detector
or the camera changes (``refimpl benchmark NAME... --shift all``).

Each shift is one row of :data:`SHIFTS`: a function of one sequence's detections and ground truth
(and a seeded generator) that returns both shifted, the detections then read again by the default
score rule, as a file of the shifted rows would be read (refimpl.io.detections).  The family:

* score rescales, every one strictly increasing, so a detection's rank among the scores is kept:
  ``scores-x0.6`` (every score times 0.6: a detector whose scores sit lower; on logits an affine
  map), ``scores-power3`` (sign(s) |s|^3), ``scores-0-100`` (times 100), ``scores-logit``
  (probabilities given as logits, log(p / (1 - p)); scores that are not probabilities go the other
  way, through a sigmoid);
* ``recall-bursty``: about a fifth of the detections missed, in bursts: a detection whose
  predecessor (IoU >= 0.3 in the frame before) was missed is missed with probability 0.6, any other
  with 0.12 (stationary share 0.12 / (1 - 0.6 + 0.12) = 23 %);
* ``fp-extra``: Poisson(a quarter of the mean detections per frame) extra false detections a
  frame, each the size of a random detection of the sequence, anywhere in the image, with a score
  drawn from the sequence's lower half;
* ``half-fps``: every second frame (frame rate halved, ground truth of the kept frames);
* ``half-res``: every box, the image size and the ground truth at half the resolution.

``all`` is that family (issue 39's).  Named only, outside ``all``: ``scores-same``, every score the
same (1.0): a detector that writes none, or one number for all (docs/model.md 3.19, "Scores that
say nothing"); ``box-noise``, a detector that localizes worse: every box's centre moved by
N(0, 0.1) of its width and height, its width and height each multiplied by exp(N(0, 0.1)) (at
least 1 px), the ground truth as it was; ``fp-static``, a detector that fires on the background:
false detections that persist at fixed places (a sign, a pole, a reflection), a quarter as many
places as the mean detections per frame (at least one), each the size of a random detection of the
sequence, anywhere in the image, seen in a frame with probability 0.5, its centre moved by N(0,
0.05) of its size, with a score drawn from the sequence's lower half; ``fp-duplicate``, a detector
whose non-maximum suppression is weak: beside three in ten detections a second, weaker box on the
same object, its centre moved by N(0, 0.3) of the box's width and height (kept in the image), its width
and height each multiplied by exp(N(0, 0.2)) (at least 1 px), with a score drawn from the sequence's lower half.

Names joined by ``+`` apply one after the other (``box-noise+fp-duplicate``).  Deterministic: one
``numpy.random.default_rng(seed)`` per sequence, seeded by its index (and a joined name's k-th part,
k >= 1, by k too).  The
table of their scores is refimpl.experiments.shift_table's; the command line reads the names here
(``--shift``'s help) without importing the benchmarks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np

from ..core.geometry import iou_matrix
from ..io import DetectionFrame, DetectionSequence, GroundTruth
from ..io.datasets import calibrated_together
from ..io.detections import DEFAULT_SCORE_RULE, read_again, resolve_rule

Shifted = tuple[DetectionSequence, GroundTruth]

@dataclass(frozen=True)
class Shift:
    name: str
    what: str
    apply: Callable[[DetectionSequence, GroundTruth, np.random.Generator], Shifted]
    in_all: bool = True
    """Part of ``--shift all`` (the family every default is chosen by); False: by name only."""


def _rescored(seq: DetectionSequence, f: Callable[[np.ndarray], np.ndarray]) -> DetectionSequence:
    return replace(seq, frames=tuple(replace(fr, scores=f(np.asarray(fr.scores, dtype=float))) for fr in seq.frames))


def _logit_or_sigmoid(seq: DetectionSequence) -> Callable[[np.ndarray], np.ndarray]:
    scores = np.concatenate([f.scores for f in seq.frames]) if seq.frames else np.zeros(0)
    if len(scores) and ((scores >= 0.0) & (scores <= 1.0)).all():
        eps = 1e-6
        return lambda s: np.log(np.clip(s, eps, 1 - eps) / (1 - np.clip(s, eps, 1 - eps)))
    return lambda s: 0.5 * (1.0 + np.tanh(0.5 * s))


def _score_shift(f: Callable[[np.ndarray], np.ndarray]) -> Callable[..., Shifted]:
    return lambda seq, gt, rng: (_rescored(seq, f), gt)


def _logit_shift(seq: DetectionSequence, gt: GroundTruth, rng: np.random.Generator) -> Shifted:
    return _rescored(seq, _logit_or_sigmoid(seq)), gt


def _frame(fr: DetectionFrame, keep: np.ndarray) -> DetectionFrame:
    return DetectionFrame(fr.frame, fr.boxes[keep], fr.scores[keep], fr.confidences[keep],
                          tuple(t for t, k in zip(fr.types, keep) if k))


def _bursty_recall(seq: DetectionSequence, gt: GroundTruth, rng: np.random.Generator) -> Shifted:
    frames, prev_boxes, prev_missed = [], np.zeros((0, 4)), np.zeros(0, dtype=bool)
    for fr in seq.frames:
        boxes = np.asarray(fr.boxes, dtype=float).reshape(-1, 4)
        u = rng.random(len(boxes))
        p = np.full(len(boxes), 0.12)
        if len(boxes) and len(prev_boxes):
            iou = iou_matrix(prev_boxes, boxes)
            best = iou.argmax(axis=0)
            linked = iou[best, np.arange(len(boxes))] >= 0.3
            p[linked & prev_missed[best]] = 0.6
        missed = u < p
        frames.append(_frame(fr, ~missed))
        prev_boxes, prev_missed = boxes, missed
    return replace(seq, frames=tuple(frames)), gt


def _false_box_source(seq: DetectionSequence) -> tuple[np.ndarray, np.ndarray, float, float, str] | None:
    """What a false detection of ``fp-extra``, ``fp-static`` or ``fp-duplicate`` is drawn from: the sequence's boxes
    (sizes), the lower half of its scores, the image's width and height and the sequence's type;
    None for a sequence without detections."""
    every = np.concatenate([np.asarray(f.boxes, dtype=float).reshape(-1, 4) for f in seq.frames]) \
        if seq.frames else np.zeros((0, 4))
    if not len(every):
        return None
    scores = np.sort(np.concatenate([f.scores for f in seq.frames]))
    width, height = seq.image_size or (float(np.max(every[:, 0] + every[:, 2])), float(np.max(every[:, 1] + every[:, 3])))
    kind = next((f.types[0] for f in seq.frames if len(f)), "pedestrian")
    return every, scores[: max(1, len(scores) // 2)], width, height, kind


def _with_false(fr: DetectionFrame, extra: np.ndarray, scores: np.ndarray, kind: str) -> DetectionFrame:
    k = len(extra)
    return DetectionFrame(fr.frame, np.vstack([fr.boxes, extra]), np.concatenate([fr.scores, scores]),
                          np.concatenate([fr.confidences, np.zeros(k, dtype=np.int64)]), tuple(fr.types) + (kind,) * k)


def _extra_false_positives(seq: DetectionSequence, gt: GroundTruth, rng: np.random.Generator) -> Shifted:
    source = _false_box_source(seq)
    if source is None:
        return seq, gt
    every, low, width, height, kind = source
    rate = 0.25 * len(every) / max(1, len(seq.frames))
    frames = []
    for fr in seq.frames:
        k = int(rng.poisson(rate))
        size = every[rng.integers(0, len(every), size=k), 2:]
        xy = rng.random((k, 2)) * np.maximum(np.array([width, height]) - size, 1.0)
        frames.append(_with_false(fr, np.column_stack([xy, size]), rng.choice(low, size=k), kind))
    return replace(seq, frames=tuple(frames)), gt


STATIC_SEEN = 0.5
"""``fp-static``: the probability that a false place is detected in a frame."""
STATIC_JITTER = 0.05
"""``fp-static``: the standard deviation of a false place's centre, as a share of its width and height."""


def _static_false_positives(seq: DetectionSequence, gt: GroundTruth, rng: np.random.Generator) -> Shifted:
    source = _false_box_source(seq)
    if source is None:
        return seq, gt
    every, low, width, height, kind = source
    places = max(1, int(round(0.25 * len(every) / max(1, len(seq.frames)))))
    size = every[rng.integers(0, len(every), size=places), 2:]
    xy = rng.random((places, 2)) * np.maximum(np.array([width, height]) - size, 1.0)
    sites = np.column_stack([xy, size])
    frames = []
    for fr in seq.frames:
        seen = rng.random(places) < STATIC_SEEN
        extra = sites[seen].copy()
        extra[:, :2] += rng.normal(0.0, STATIC_JITTER, size=(len(extra), 2)) * extra[:, 2:]
        frames.append(_with_false(fr, extra, rng.choice(low, size=len(extra)), kind))
    return replace(seq, frames=tuple(frames)), gt


DUPLICATE_SHARE = 0.3
"""``fp-duplicate``: the probability that a detection gets a second, false box beside it."""
DUPLICATE_SHIFT = 0.3
"""``fp-duplicate``: the standard deviation of the second box's centre offset, as a share of the
detection's width and height (its log width and height: two thirds of this)."""


def _duplicate_false_positives(seq: DetectionSequence, gt: GroundTruth, rng: np.random.Generator) -> Shifted:
    source = _false_box_source(seq)
    if source is None:
        return seq, gt
    low, image, kind = source[1], np.array(source[2:4]), source[4]
    frames = []
    for fr in seq.frames:
        boxes = np.asarray(fr.boxes, dtype=float).reshape(-1, 4)
        twin = boxes[rng.random(len(boxes)) < DUPLICATE_SHARE].copy()
        n = rng.normal(0.0, 1.0, size=twin.shape)
        # a detector's box lies on its image: a second box is centred in it (beside an object at the
        # border, on the border), as every real detection of the benchmark sets is (tracking/camera.py)
        centre = np.clip(twin[:, :2] + twin[:, 2:] * (0.5 + DUPLICATE_SHIFT * n[:, :2]), 0.0, image)
        twin[:, 2:] = np.maximum(twin[:, 2:] * np.exp(DUPLICATE_SHIFT * 2 / 3 * n[:, 2:]), 1.0)
        twin[:, :2] = centre - twin[:, 2:] / 2
        frames.append(_with_false(fr, twin, rng.choice(low, size=len(twin)), kind))
    return replace(seq, frames=tuple(frames)), gt


BOX_NOISE = 0.1
"""``box-noise``'s standard deviation: of a box's width and height for its centre, of the log of its
width and height for its size."""


def _box_noise(seq: DetectionSequence, gt: GroundTruth, rng: np.random.Generator) -> Shifted:
    frames = []
    for fr in seq.frames:
        b = np.asarray(fr.boxes, dtype=float).reshape(-1, 4)
        n = rng.normal(0.0, BOX_NOISE, size=b.shape)
        w = np.maximum(b[:, 2] * np.exp(n[:, 2]), 1.0)
        h = np.maximum(b[:, 3] * np.exp(n[:, 3]), 1.0)
        cx = b[:, 0] + b[:, 2] / 2 + n[:, 0] * b[:, 2]
        cy = b[:, 1] + b[:, 3] / 2 + n[:, 1] * b[:, 3]
        frames.append(replace(fr, boxes=np.column_stack([cx - w / 2, cy - h / 2, w, h])))
    return replace(seq, frames=tuple(frames)), gt


def _half_fps(seq: DetectionSequence, gt: GroundTruth, rng: np.random.Generator) -> Shifted:
    first = seq.first_frame
    frames = tuple(replace(f, frame=first + (f.frame - first) // 2) for f in seq.frames if (f.frame - first) % 2 == 0)
    keep = (gt.frames - gt.first_frame) % 2 == 0
    care = (gt.dontcare[:, 0] - gt.first_frame) % 2 == 0 if len(gt.dontcare) else np.zeros(0, dtype=bool)
    dontcare = gt.dontcare[care].copy()
    if len(dontcare):
        dontcare[:, 0] = gt.first_frame + (dontcare[:, 0] - gt.first_frame) // 2
    shifted_gt = replace(gt, frames=gt.first_frame + (gt.frames[keep] - gt.first_frame) // 2, ids=gt.ids[keep],
                         boxes=gt.boxes[keep], considered=gt.considered[keep], distractor=gt.distractor[keep],
                         dontcare=dontcare, num_frames=math.ceil(gt.num_frames / 2), visibility=gt.visibility[keep])
    return replace(seq, frames=frames, fps=None if seq.fps is None else seq.fps / 2), shifted_gt


def _half_res(seq: DetectionSequence, gt: GroundTruth, rng: np.random.Generator) -> Shifted:
    frames = tuple(replace(f, boxes=np.asarray(f.boxes, dtype=float) * 0.5) for f in seq.frames)
    size = None if seq.image_size is None else (seq.image_size[0] // 2, seq.image_size[1] // 2)
    dontcare = gt.dontcare.astype(float).copy()
    if len(dontcare):
        dontcare[:, 1:] *= 0.5
    return (replace(seq, frames=frames, image_size=size),
            replace(gt, boxes=np.asarray(gt.boxes, dtype=float) * 0.5, dontcare=dontcare))


SHIFTS: dict[str, Shift] = {s.name: s for s in (
    Shift("none", "the benchmark as it is", lambda seq, gt, rng: (seq, gt)),
    Shift("scores-x0.6", "every score x 0.6", _score_shift(lambda s: 0.6 * s)),
    Shift("scores-power3", "every score s as sign(s)|s|^3", _score_shift(lambda s: np.sign(s) * np.abs(s) ** 3)),
    Shift("scores-0-100", "every score x 100", _score_shift(lambda s: 100.0 * s)),
    Shift("scores-logit", "probabilities as logits (other scores through a sigmoid)", _logit_shift),
    Shift("recall-bursty", "about 23 % of the detections missed, in bursts", _bursty_recall),
    Shift("fp-extra", "a quarter more detections, false, anywhere", _extra_false_positives),
    Shift("half-fps", "every second frame", _half_fps),
    Shift("half-res", "half the resolution (boxes, image size, ground truth)", _half_res),
    Shift("scores-same", "every score the same (a detector that writes none)",
          _score_shift(lambda s: np.ones_like(s)), in_all=False),
    Shift("box-noise", "every box moved and resized by about 10 % of its size at random", _box_noise, in_all=False),
    Shift("fp-static", "false detections that persist at fixed places, seen every other frame",
          _static_false_positives, in_all=False),
    Shift("fp-duplicate", "a second, weaker box beside three in ten detections (weak suppression)",
          _duplicate_false_positives, in_all=False),
)}
"""The shifts by name (``--shift all`` or a comma-separated list), ``none`` first."""


def parse_shifts(text: str) -> tuple[str, ...]:
    """``all`` (every shift with ``in_all``) or a comma-separated list of SHIFTS names (``none`` is
    always run first, the reference); a name may join shifts with ``+``, applied one after the
    other (``box-noise+fp-duplicate``: a detector that localizes worse and suppresses weakly)."""
    names = [n for n, s in SHIFTS.items() if s.in_all] if text.strip() == "all" else \
        [n.strip() for n in text.split(",") if n.strip()]
    unknown = [part for n in names for part in n.split("+")
               if part not in SHIFTS or (part == "none" and n != "none")]
    if unknown or not names:
        raise ValueError(f"unknown shift {unknown[0] if unknown else text!r} (choose from all, {', '.join(SHIFTS)}, "
                         "or several joined by '+')")
    return ("none", *[n for n in names if n != "none"])


def shifted_dataset(dataset: Sequence[tuple[str, DetectionSequence, GroundTruth]], shift: str,
                    seed: int = 0) -> list[tuple[str, DetectionSequence, GroundTruth]]:
    """Every sequence of a loaded dataset under one shift (or several joined by ``+``, one after the
    other), its detections read again by the default score rule (as one run over files of the
    shifted rows would read them: calibrated together).  The k-th part of a joined shift draws from
    ``default_rng([seed, index, k])``, the first from ``[seed, index]`` as the shift alone does."""
    if shift == "none":
        return list(dataset)
    rule = resolve_rule(DEFAULT_SCORE_RULE)
    out = []
    for index, (name, seq, gt) in enumerate(dataset):
        dets, truth = seq, gt
        for k, part in enumerate(shift.split("+")):
            dets, truth = SHIFTS[part].apply(dets, truth, np.random.default_rng([seed, index] if k == 0 else [seed, index, k]))
        out.append((name, read_again(dets, rule), truth))
    return calibrated_together(out)
