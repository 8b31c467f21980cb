"""Detections: DetectionSequence, what every format's detection reader makes of a file (the readers:
refimpl.io.formats.mot, .kitti), and the confidence rule (refimpl.io's package doc)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..core.confidence import EVIDENCE, RANK, RunEvidence, online_rule, pooled, sequence_evidence
from .errors import InputFormatError, InputFormatWarning
from .lines import MAX_DET_AREA, MIN_DET_SIZE, _first_bad, _round_half_up


@dataclass(frozen=True)
class DetectionFrame:
    """The detections of one frame: xywh boxes, raw scores, 0..100 confidences and types."""

    frame: int
    boxes: np.ndarray
    scores: np.ndarray
    confidences: np.ndarray
    types: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.types)


@dataclass(frozen=True)
class DetectionSequence:
    """All frames of a sequence from first to last, empty frames included, in order."""

    name: str
    frames: tuple[DetectionFrame, ...]
    first_frame: int
    image_size: tuple[int, int] | None
    fps: float | None
    dropped: tuple[tuple[int, str], ...] = ()
    """(line, reason) of rows skipped by a documented policy (KITTI zero-area boxes)."""

    @property
    def num_frames(self) -> int:
        return len(self.frames)

    @property
    def num_detections(self) -> int:
        return sum(len(f) for f in self.frames)

    @property
    def confidence_range(self) -> tuple[int, int] | None:
        """The smallest and largest confidence of its detections (None: there are none)."""
        conf = [int(c) for f in self.frames for c in f.confidences]
        return (min(conf), max(conf)) if conf else None

    def frame(self, number: int) -> DetectionFrame:
        """The frame with this frame number (numbering as in the file)."""
        i = number - self.first_frame
        if not 0 <= i < len(self.frames):
            raise KeyError(number)
        return self.frames[i]


@dataclass(frozen=True)
class _Rows:
    """The validated detections of some lines (a whole file, or one line of a stream), in line order:
    what a reader keeps of them (KITTI: the requested class, degenerate boxes dropped)."""

    frames: np.ndarray
    """int64 frame numbers."""
    boxes: np.ndarray
    """(n, 4) x, y, w, h."""
    scores: np.ndarray
    linenos: tuple[int, ...]
    dropped: tuple[tuple[int, str], ...] = ()
    """(line, reason) of rows dropped by the documented policy (KITTI's degenerate boxes)."""


def _build_frames(frames: np.ndarray, boxes: np.ndarray, scores: np.ndarray, conf: np.ndarray,
                  types: Sequence[str], first: int, count: int) -> tuple[DetectionFrame, ...]:
    """One DetectionFrame per frame first..first+count-1, keeping file order within a frame."""
    order = np.argsort(frames, kind="stable")
    frames, boxes, scores, conf = frames[order], boxes[order], scores[order], conf[order]
    types = [types[i] for i in order]
    numbers = np.arange(first, first + count)
    starts = np.searchsorted(frames, numbers, side="left")
    ends = np.searchsorted(frames, numbers, side="right")
    out = []
    for n, a, b in zip(numbers, starts, ends):
        out.append(DetectionFrame(
            frame=int(n),
            boxes=boxes[a:b].copy(),
            scores=scores[a:b].copy(),
            confidences=conf[a:b].copy(),
            types=tuple(types[a:b]),
        ))
    return tuple(out)


SCORE_RULES = ("auto", EVIDENCE, RANK, "probability", "sigmoid", "raw")
"""How a file's scores become confidences, the same rules for every format (refimpl.core.confidence;
docs/model.md 3.19): ``auto`` (the default) is ``evidence``, the scores calibrated on how persistent
the detections of each score are in the sequence itself (any detector, any scale: only the order of
the scores matters); ``rank`` (a score's place among those seen so far, mapped onto 20..100); and the fixed scales
``probability`` (scores in 0..1, times 100), ``sigmoid`` (logits, such as KITTI's PointRCNN
scores, through a sigmoid, times 100) and ``raw`` (0..100 as they are, clipped)."""
DEFAULT_SCORE_RULE = "auto"
ONLINE_RULES = (EVIDENCE, RANK)
"""The rules that read a frame's confidences from the frames up to it (refimpl.core.confidence)."""


def resolve_rule(rule: str, auto: str = EVIDENCE) -> str:
    """The rule ``rule`` names (``auto`` is the format's own, ``auto``: ``evidence`` for every
    built-in format, refimpl.io.formats.DataFormat.score_rule); ValueError naming the rules otherwise."""
    _check_rule(rule, SCORE_RULES)
    return auto if rule == "auto" else rule


def _check_rule(rule: str, allowed: Sequence[str]) -> None:
    if rule not in allowed:
        raise ValueError(f"scores must be one of {', '.join(allowed)}, got {rule!r}")


def calibrated(seq: DetectionSequence, rule: str, seed: RunEvidence | None = None) -> DetectionSequence:
    """An online rule (``evidence`` or ``rank``) applied to the sequence's frames in order: each
    frame's confidences from the frames <= it, as a stream and the library compute them; ``seed``:
    what the run's other files showed the rule (``calibrated_together``)."""
    state = online_rule(rule, seed)
    if state is None:
        return seq
    frames = tuple(replace(f, confidences=state.confidences(f.boxes, f.scores, f.types)) for f in seq.frames)
    return replace(seq, frames=frames)


def calibrated_together(seqs: Sequence[DetectionSequence], rule: str) -> list[DetectionSequence]:
    """A run's files read by an online rule, each calibrated on its own frames so far and on the
    other files whole (docs/model.md 3.19, "A run's files pooled"): one detector's scores mean the
    same in every file of a run, so a file whose best detections are false (a sequence without a
    pedestrian) no longer calls them the top of the evidence.  The same confidences in any order of
    the files; one file (or a fixed scale) as read."""
    if rule not in ONLINE_RULES or len(seqs) < 2:
        return list(seqs)
    each = [sequence_evidence(s.frames) for s in seqs]
    return [calibrated(s, rule, pooled(each[:k] + each[k + 1:])) for k, s in enumerate(seqs)]


def probability_scale(seq: DetectionSequence) -> DetectionSequence:
    """The sequence with its scores as a caller of a probability-scale tracker (SORT, ByteTrack,
    OC-SORT: refimpl.experiments.peers) puts them, times 100: probabilities as they are (every score
    in 0..1), logits (some score negative: KITTI's PointRCNN) through a sigmoid, any other scale
    (ACF's 0..139) by its rank."""
    scores = np.concatenate([f.scores for f in seq.frames]) if seq.frames else np.zeros(0)
    if len(scores) and ((scores >= 0.0) & (scores <= 1.0)).all():
        rule = "probability"
    elif len(scores) and (scores < 0.0).any():
        rule = "sigmoid"
    else:
        rule = RANK
    return read_again(seq, rule)


def read_again(seq: DetectionSequence, rule: str) -> DetectionSequence:
    """The sequence's confidences computed again from its scores by ``rule`` (a resolved rule), as a
    reader would compute them for a file of its rows."""
    seq = replace(seq, frames=tuple(replace(f, confidences=scale_confidences(seq.name, (), f.scores, rule))
                                    for f in seq.frames))
    return calibrated(seq, rule)


def scale_confidences(path, linenos: Sequence[int], scores: np.ndarray, rule: str, hint: str = "") -> np.ndarray:
    """The 0..100 confidences of scores on a fixed scale (``probability``, ``sigmoid``, ``raw``);
    zeros for an online rule (filled in frame by frame).  ``hint`` ends the message of a score that
    is not a probability."""
    if rule in ONLINE_RULES:
        return np.zeros(len(scores), dtype=np.int64)
    if rule == "probability":
        bad = _first_bad(~((scores >= 0.0) & (scores <= 1.0)))
        if bad is not None:
            raise InputFormatError(f"score {scores[bad]:g} is not a probability in 0..1{hint} "
                                   "(--scores auto reads any scale)", path, linenos[bad])
        return _round_half_up(100.0 * scores)
    if rule == "sigmoid":
        return _sigmoid(scores)
    return _round_half_up(np.clip(scores, 0.0, 100.0))  # raw; clip first: huge scores overflow int64


def _sigmoid(scores: np.ndarray) -> np.ndarray:
    """Logits as 0..100 confidences: round(100 * sigmoid(score)), overflow-free."""
    return _round_half_up(100.0 * 0.5 * (1.0 + np.tanh(0.5 * scores)))


def _check_area(path: Path, linenos: Sequence[int], w: np.ndarray, h: np.ndarray) -> None:
    """A detection's area must fit the solvers' 32-bit arithmetic (refimpl.core.ranges): w*h <= MAX_DET_AREA."""
    bad = _first_bad(np.round(w) * np.round(h) > MAX_DET_AREA)
    if bad is not None:
        raise InputFormatError(f"box area w*h = {w[bad]:g}*{h[bad]:g} exceeds {MAX_DET_AREA} px^2 "
                               "(the solvers compute 100 * area in 32-bit integers)", path, linenos[bad])


def _warn_dropped(path, dropped: Sequence[tuple[int, str]], stacklevel: int = 3) -> None:
    """One warning naming every line of a degenerate KITTI box that was dropped."""
    warnings.warn(
        f"{path}: dropped {len(dropped)} zero-area (or thinner than {MIN_DET_SIZE:g} px) detection "
        f"box(es) on line(s) {', '.join(str(n) for n, _ in dropped)}", InputFormatWarning, stacklevel=stacklevel)


