"""The confidence of a detection in VO_t: a detector's score as the model's integer 0..100.

The paper gives every detection of VO_t an integer confidence (``det(det_0, car, 99)``), and the
model's thresholds (``conf_thresh_new_track``, ``conf_thresh_assign``, ``conf_thresh_resume``,
``bridge_conf``) compare against it.  A detector's raw score says nothing by its scale: PointRCNN
writes logits, SORT's Faster R-CNN probabilities, MOT15's ACF values of 0..139.

refimpl's default rule, ``evidence`` (a refimpl decision, docs/model.md 3.19), calibrates the
scores on what the sequence itself shows, without labels: a detection is *persistent* when a
detection of the same type overlaps it (IoU >= PERSIST_IOU) in the frame before it and in the
frame after it.  A false detection flickers; an object persists.  The confidence of a score is
how persistent the detections of that score have been so far, relative to the most persistent
ones (:class:`PersistenceEvidence`): it depends on the order of the scores alone, so any strictly
increasing rescale of a detector's scores (x 0.6, a power, logits for probabilities) gives the
same confidences and the same tracks, and a threshold of 50 means "half as persistent as this
detector's best" whatever the detector.  Its prior, before the sequence has shown enough, is a
score's bare rank among the scores seen so far (times 100, :class:`OnlineRank`), never below
EVIDENCE_FLOOR.

A detector that writes one score for every detection (or none) says nothing by it: while every
score seen is the same, the evidence rule reads a detection's streak instead, how many of the
frames just before it showed a detection of its type on it (:class:`StreakEvidence`, STREAK_MAX).

The rank rule (``rank``) maps each score's place among every score the sequence has shown so far,
this frame included, linearly onto RANK_LOW..100:

    confidence(s) = floor(RANK_LOW + (100 - RANK_LOW) * #{scores seen so far <= s} / #{scores seen so far} + 1/2)

so the weakest detection a detector has written so far is about 20 and its strongest 100, whatever
the detector: the presets start a track above 50 (the top five eighths of the scores) and let all but
the lowest eighth continue one (assign and resume at 30; docs/model.md 3.19, "The rank rule's
map").  The rule is online (frame t uses frames <= t only, so a file run and the library's
``update`` see the same numbers) and depends on the order of scores alone: any strictly increasing
rescale of a detector's scores gives the same confidences, hence the same tracks.

``probability`` (scores in 0..1, times 100) and ``raw`` (scores already 0..100) stay as explicit
rules (``--scores``); the file readers apply them (refimpl.io).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .geometry import iou_matrix

RANK = "rank"
EVIDENCE = "evidence"
PERSIST_IOU = 0.3
"""A detection persists into a neighbouring frame where a detection of its type overlaps it by
IoU >= 0.3 (SORT's association threshold)."""
EVIDENCE_BINS = 20
"""The persistence curve is estimated on this many equal-count bins of the scores seen so far."""
EVIDENCE_PRIOR = 50
"""The prior counts as this many detections: with n labelled detections the confidence is
(n * learned + EVIDENCE_PRIOR * prior) / (n + EVIDENCE_PRIOR)."""
RANK_PRIOR = 50
"""The tracker option write_peak's ranks count this many scores below every real one
(OnlineRank's ``prior``), as the evidence rule's prior weighs as much as EVIDENCE_PRIOR labelled
detections: a sequence's first detections rank high until it has shown lower scores (a clean
detector's second-best object is not "below the median" of four scores).  Chosen with
write_peak on mot15 (docs/tracking.md, "Written once the detector was sure of it")."""
EVIDENCE_FLOOR = 40
"""The prior is a score's bare rank (OnlineRank, times 100), never below this: before the sequence has shown
evidence, no detection is taken for less than 40 % as persistent as the detector's best, which
every preset lets continue a track (assign and resume at 30) and not start one (a new track needs
more than 50).  Rank alone called the lowest 30 % of a sparse, clean sequence's first detections
(KITTI pedestrians) unfit even to continue a track.  Chosen among 0 (rank alone), 40, 50, 55, 60 by the
worst case over the shifts on the tuning sets (docs/model.md 3.19)."""
STREAK_MAX = 2
"""Scores that say nothing (every score the evidence rule has seen the same, at least EVIDENCE_BINS
of them: a detector that writes no score, or one number for all): a detection's *streak* is 0 when
no detection of its type overlapped it (IoU >= PERSIST_IOU) in the frame before, else 1 + the
streak of the best one that did, at most 2 (seen in each of the two frames before).  Its confidence
is how often detections of its streak were seen again in the next frame, relative to streak 2
(:class:`StreakEvidence`; docs/model.md 3.19, "Scores that say nothing").  Chosen among streaks of
at most 1 and 2 and fixed confidences for a lone detection (20, 40, 50) by the worst case over the
tuning sets with every score made the same."""
RANK_LOW = 20
"""The rank rule (``--scores rank``) maps the ranks 0..1 linearly onto 20..100 (module doc).  Chosen
on the tuning sets (kitti-car-train, kitti-ped-train, mot15, each against its format's own scale)
by the worst gap, among maps low + (100 - low) * rank ** p (docs/model.md 3.19, "The rank rule's
map")."""


SCORE_WINDOW = 2 ** 17
"""The online rules remember the last 131,072 scores (the rank rule's scores seen, the evidence
rule's labelled ones), so their memory is bounded on a stream of any length (~1 MB per array,
docs/robustness.md "Long streams"): a window above the detections of the largest shared sequence
(MOT17-04's ground truth as detections, 108,004 rows), so no sequence refimpl is measured on
reaches it and every answer there is what "every score so far" gives."""


class SortedWindow:
    """The last ``size`` values added (default SCORE_WINDOW), sorted, each with an aligned flag (``flags``,
    when every ``add`` gives them).  ``add``
    takes one frame's values, sorted; beyond ``size`` the oldest go.  Equal values are kept in the
    order they came (each new one to the right of its equals), so the oldest of equal values is
    the leftmost, and going removes exactly it, with its flag."""

    def __init__(self, size: int | None = None) -> None:
        self.size = SCORE_WINDOW if size is None else int(size)
        self.values = np.zeros(0, dtype=float)
        self.flags = np.zeros(0, dtype=float)
        self._arrived = np.zeros(0, dtype=float)  # the values in the order they came

    def add(self, values: np.ndarray, flags: np.ndarray | None = None) -> None:
        at = np.searchsorted(self.values, values, side="right")
        self.values = np.insert(self.values, at, values)
        if flags is not None:  # the rank rule's window has none
            self.flags = np.insert(self.flags, at, flags)
        self._arrived = np.concatenate([self._arrived, values])
        excess = len(self._arrived) - self.size
        if excess > 0:
            old = np.sort(self._arrived[:excess], kind="stable")
            self._arrived = self._arrived[excess:].copy()
            nth = np.arange(len(old)) - np.searchsorted(old, old, side="left")  # k-th of its equals among old
            gone = np.searchsorted(self.values, old, side="left") + nth
            self.values = np.delete(self.values, gone)
            if len(self.flags):
                self.flags = np.delete(self.flags, gone)

    def __len__(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class RunEvidence:
    """What other files of a run showed the online rules, whole (``sequence_evidence``, ``pooled``):
    every score seen, sorted, and the labelled scores, sorted, with their persistence flags (1.0:
    persistent).  A rule seeded with it (``online_rule(rule, seed)``) starts as if it had seen them
    before the sequence's first frame (docs/model.md 3.19, "A run's files pooled")."""

    seen: np.ndarray
    labelled: np.ndarray
    persistent: np.ndarray
    streaks: np.ndarray | None = None
    """(STREAK_MAX + 1, 2) counts while the scores said nothing: detections of each streak, and how
    many of them were seen again in the next frame (StreakEvidence); None: none counted."""


SEED_SIZE = 1000
"""A seed (the run's other files) counts as at most this many scores seen and this many labelled
detections, every k-th in score order where it has more: the shape of the detector's scores, not
their weight against a sequence's own."""


def _thinned(values: np.ndarray, *aligned: np.ndarray) -> tuple[np.ndarray, ...]:
    """Every k-th of sorted values (and the aligned arrays), evenly, where there are more than SEED_SIZE."""
    if len(values) <= SEED_SIZE:
        return (values, *aligned)
    keep = (np.arange(SEED_SIZE) * len(values)) // SEED_SIZE
    return (values[keep], *(a[keep] for a in aligned))


def pooled(evidence: Sequence[RunEvidence]) -> RunEvidence | None:
    """Several files' evidence as one (None for none): the scores merged in order."""
    if not evidence:
        return None
    seen = np.concatenate([e.seen for e in evidence])
    labelled = np.concatenate([e.labelled for e in evidence])
    persistent = np.concatenate([e.persistent for e in evidence])
    order = np.lexsort((persistent, labelled))  # by score, equal scores by flag: the same in any file order
    counted = [e.streaks for e in evidence if e.streaks is not None]
    return RunEvidence(np.sort(seen, kind="stable"), labelled[order], persistent[order],
                       sum(counted[1:], counted[0].copy()) if counted else None)


def sequence_evidence(frames) -> RunEvidence:
    """One sequence's evidence, whole: its frames (each with ``boxes``, ``scores``, ``types``) through
    the evidence rule; the last frame's detections stay unlabelled (no frame after them)."""
    state = PersistenceEvidence()
    for f in frames:
        state.confidences(f.boxes, f.scores, f.types)
    return RunEvidence(state._rank._seen.values.copy(), state._labelled.values.copy(),
                       state._labelled.flags.copy(), state.streak_counts())


def _percent(k, n):
    """floor(100 k / n + 1/2), exact in integers: the bare rank of k of n scores, times 100."""
    return (200 * k + n) // (2 * n)


class OnlineRank:
    """A score's bare rank among the last SCORE_WINDOW scores seen (kept sorted), the rank rule's
    and the evidence prior's state.  ``confidences(scores)`` adds one frame's scores and returns
    their ranks times 100.  ``prior``: that many scores taken to
    have been seen below every real one (0: none), so that the first scores of a sequence
    rank high until it has shown lower ones.  ``seed``: scores taken to have been seen before the
    first frame (other files of the run, RunEvidence.seen)."""

    def __init__(self, prior: int = 0, seed: np.ndarray | None = None) -> None:
        self.prior = int(prior)
        self._seed = seed
        self.reset()

    def confidences(self, scores) -> np.ndarray:
        at_most, n = self.counts(scores)
        return _percent(at_most, n)

    def counts(self, scores) -> tuple[np.ndarray, int]:
        """Adds one frame's scores; returns, for each, how many scores seen so far are <= it (itself
        and the prior included) and how many have been seen (k and n of the rank k / n)."""
        s = np.asarray(scores, dtype=float).reshape(-1)
        if not len(s):
            return np.zeros(0, dtype=np.int64), 1
        if not np.isfinite(s).all():
            raise ValueError("a detection score is NaN or infinite")
        self._seen.add(np.sort(s, kind="stable"))
        seen = self._seen.values
        at_most = np.searchsorted(seen, s, side="right") + self.prior  # scores seen so far <= s, itself included
        return at_most.astype(np.int64), len(seen) + self.prior

    def rank_of(self, score: float) -> int:
        """A score's rank among the scores seen so far (the prior included), times 100, rounded half
        up, without adding it: floor(100 k / n + 1/2)."""
        k = int(np.searchsorted(self._seen.values, score, side="right")) + self.prior
        n = len(self._seen) + self.prior
        return int(_percent(k, n)) if n else 100

    def reset(self) -> None:
        self._seen = SortedWindow()
        if self._seed is not None and len(self._seed):
            self._seen.add(_thinned(self._seed)[0])


class RankFrames:
    """The rank rule with the evidence rule's call: ``confidences(boxes, scores, types)``: each
    score's rank k / n so far mapped linearly onto RANK_LOW..100, rounded half up."""

    def __init__(self, seed: RunEvidence | None = None) -> None:
        self._rank = OnlineRank(seed=None if seed is None else seed.seen)

    def confidences(self, boxes, scores, types=None) -> np.ndarray:
        k, n = self._rank.counts(scores)
        # floor(RANK_LOW + (100 - RANK_LOW) * k / n + 1/2), exact in integers
        return (2 * (RANK_LOW * n + (100 - RANK_LOW) * k) + n) // (2 * n)

    def reset(self) -> None:
        self._rank.reset()


def one_score(frames) -> float | None:
    """The score every detection of these frames (each with ``scores``) has, when they are at least
    EVIDENCE_BINS and all the same: the evidence rule then reads streaks (STREAK_MAX); else None."""
    scores = [np.asarray(f.scores, dtype=float).reshape(-1) for f in frames]
    every = np.concatenate(scores) if scores else np.zeros(0)
    return float(every[0]) if len(every) >= EVIDENCE_BINS and (every == every[0]).all() else None


def same_score_message(name: str, score: float, run: bool = False) -> str:
    """The one line ``refimpl track`` and the API give when every score is the same (one_score)."""
    whose = f"{name} and the run's other files, calibrated together:" if run else f"{name}:"
    return (f"{whose} every detection has the score {score:g}: the scores say nothing, so a detection's "
            f"confidence is read from the frames before it (one that continues no detection of the frame "
            f"before counts as weak, one seen in each of the two frames before as strong; docs/model.md "
            f"3.19, \"Scores that say nothing\")")


def online_rule(rule: str, seed: RunEvidence | None = None) -> "PersistenceEvidence | RankFrames | None":
    """A fresh state of an online rule (``evidence``, ``rank``), or None for a fixed scale; ``seed``:
    what the run's other files showed it."""
    return PersistenceEvidence(seed) if rule == EVIDENCE else RankFrames(seed) if rule == RANK else None


def _increasing(values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The weighted least-squares non-decreasing fit of ``values`` (pool adjacent violators)."""
    level: list[float] = []
    weight: list[float] = []
    size: list[int] = []
    for v, w in zip(values.tolist(), weights.tolist()):
        level.append(v)
        weight.append(w)
        size.append(1)
        while len(level) > 1 and level[-2] > level[-1]:
            v2, w2, n2 = level.pop(), weight.pop(), size.pop()
            v1, w1, n1 = level.pop(), weight.pop(), size.pop()
            level.append((v1 * w1 + v2 * w2) / (w1 + w2))
            weight.append(w1 + w2)
            size.append(n1 + n2)
    return np.repeat(np.array(level), size)


def _near(a: np.ndarray, ta: tuple[str, ...], b: np.ndarray, tb: tuple[str, ...]) -> np.ndarray:
    """(len(a), len(b)): whether box i of a overlaps box j of b by IoU >= PERSIST_IOU, of one type."""
    if not len(a) or not len(b):
        return np.zeros((len(a), len(b)), dtype=bool)
    near = iou_matrix(a, b) >= PERSIST_IOU
    if len(set(ta) | set(tb)) > 1:
        near &= np.array(ta, dtype=object)[:, None] == np.array(tb, dtype=object)[None, :]
    return near


class StreakEvidence:
    """The evidence rule while the scores say nothing (STREAK_MAX), online: ``frame(boxes, types)``
    takes one frame in order, counts which detections of the frame before were seen again in it,
    and returns its detections' streaks; ``confidences(streaks)`` gives them 0..100: the share of
    detections of that streak seen again, divided by streak STREAK_MAX's, blended with the prior
    (100 for streak STREAK_MAX, EVIDENCE_FLOOR otherwise) as the score curve is, rounded half up.
    ``seed``: the counts of the run's other files (RunEvidence.streaks)."""

    def __init__(self, seed: np.ndarray | None = None) -> None:
        self._seed = seed
        self.reset()

    def reset(self) -> None:
        counts = np.zeros((STREAK_MAX + 1, 2)) if self._seed is None else np.asarray(self._seed, dtype=float)
        total = counts[:, 0].sum()
        self.counts = counts * (SEED_SIZE / total) if total > SEED_SIZE else counts.copy()  # a seed weighs <= SEED_SIZE
        self._previous: tuple[np.ndarray, tuple[str, ...], np.ndarray] | None = None

    def frame(self, boxes: np.ndarray, types: tuple[str, ...]) -> np.ndarray:
        streaks = np.zeros(len(boxes), dtype=np.int64)
        if self._previous is not None and len(self._previous[0]):
            before, kinds, counted = self._previous
            near = _near(before, kinds, boxes, types)
            np.add.at(self.counts[:, 0], counted, 1.0)
            np.add.at(self.counts[:, 1], counted[near.any(axis=1)], 1.0)
            if len(boxes):
                streaks = np.minimum(np.where(near, counted[:, None] + 1, 0).max(axis=0), STREAK_MAX)
        self._previous = (boxes, types, streaks)
        return streaks

    def confidences(self, streaks: np.ndarray) -> np.ndarray:
        total, again = self.counts[:, 0], self.counts[:, 1]
        prior = np.where(streaks == STREAK_MAX, 100, EVIDENCE_FLOOR)
        if not total[STREAK_MAX] or not again[STREAK_MAX]:
            return prior.astype(np.int64)
        share = np.divide(again, total, out=np.zeros(STREAK_MAX + 1), where=total > 0)
        share /= share[STREAK_MAX]
        learned = np.where(total[streaks] > 0, np.minimum(share[streaks], 1.0), prior / 100.0)
        n = total.sum()
        return np.floor((n * 100.0 * learned + EVIDENCE_PRIOR * prior) / (n + EVIDENCE_PRIOR) + 0.5).astype(np.int64)


class PersistenceEvidence:
    """The evidence rule's state (module doc), online: ``confidences(boxes, scores, types)`` takes
    one frame (xywh boxes) in order and returns its 0..100 confidences from frames <= it.

    At frame t the detections of frame t-1 are labelled (persistent: overlapped in t-2 and in t);
    the labelled scores, sorted, fall into EVIDENCE_BINS equal-count bins; the share of persistent
    detections per bin, made non-decreasing in the score (isotonic) and divided by the highest
    bin's share, is the learned curve; a score's confidence is the curve at its bin, blended with
    the prior (EVIDENCE_PRIOR: the bare rank, at least EVIDENCE_FLOOR), times 100, rounded half up.
    While every score seen is the same (at least EVIDENCE_BINS of them), :class:`StreakEvidence`
    gives the confidences instead (STREAK_MAX).
    ``seed``: the run's other files, seen and labelled before the first frame."""

    def __init__(self, seed: RunEvidence | None = None) -> None:
        self._seed = seed
        self.reset()

    def reset(self) -> None:
        seed = self._seed
        self._rank = OnlineRank(seed=None if seed is None else seed.seen)
        self._labelled = SortedWindow()  # the last SCORE_WINDOW labelled scores, sorted; flag 1.0: persistent
        if seed is not None and len(seed.labelled):
            self._labelled.add(*_thinned(seed.labelled, seed.persistent))
        self._recent: list[tuple[np.ndarray, np.ndarray, tuple[str, ...]]] = []  # the last two frames
        same = seed is None or not len(seed.seen) or seed.seen[0] == seed.seen[-1]
        self._streaks = StreakEvidence(None if seed is None else seed.streaks) if same else None

    @property
    def streak_score(self) -> float | None:
        """While the scores say nothing and StreakEvidence gives the confidences (STREAK_MAX): the one
        score seen; else None."""
        seen = self._rank._seen.values
        return float(seen[0]) if self._streaks is not None and len(seen) >= EVIDENCE_BINS else None

    def streak_counts(self) -> np.ndarray | None:
        """StreakEvidence's counts while every score seen has been the same (None once two differed)."""
        return None if self._streaks is None else self._streaks.counts.copy()

    @staticmethod
    def _overlapped(a: np.ndarray, ta: tuple[str, ...], b: np.ndarray, tb: tuple[str, ...]) -> np.ndarray:
        """For every box of b, whether a box of a of its type overlaps it by IoU >= PERSIST_IOU."""
        return _near(a, ta, b, tb).any(axis=0)

    def _label(self, boxes: np.ndarray, types: tuple[str, ...]) -> None:
        """Label the previous frame's detections now that the frame after it is here."""
        if len(self._recent) == 2:
            (b0, _, t0), (b1, s1, t1) = self._recent
            if len(b1):
                flags = self._overlapped(b0, t0, b1, t1) & self._overlapped(boxes, types, b1, t1)
                order = np.argsort(s1, kind="stable")
                self._labelled.add(s1[order], flags[order].astype(float))
            self._recent.pop(0)

    def _learned(self, scores: np.ndarray) -> np.ndarray | None:
        """The learned curve at each score, or None while too little is labelled (or nothing persisted)."""
        n = len(self._labelled)
        if n < EVIDENCE_BINS:
            return None
        edges = (np.arange(EVIDENCE_BINS + 1) * n) // EVIDENCE_BINS
        persistent = np.concatenate([[0.0], np.cumsum(self._labelled.flags)])
        sizes = np.diff(edges).astype(float)
        curve = _increasing((persistent[edges[1:]] - persistent[edges[:-1]]) / sizes, sizes)
        if curve[-1] <= 0.0:
            return None
        at_most = np.searchsorted(self._labelled.values, scores, side="right")  # labelled scores <= s
        bin_of = np.clip(np.searchsorted(edges[1:], at_most, side="left"), 0, EVIDENCE_BINS - 1)
        return curve[bin_of] / curve[-1]

    def confidences(self, boxes, scores, types: tuple[str, ...] | None = None) -> np.ndarray:
        s = np.asarray(scores, dtype=float).reshape(-1)
        b = np.asarray(boxes, dtype=float).reshape(-1, 4)
        kinds = tuple(types) if types is not None else ("",) * len(s)
        prior = np.maximum(self._rank.confidences(s), EVIDENCE_FLOOR)  # (OnlineRank checks the scores are finite)
        self._label(b, kinds)
        self._recent.append((b, s, kinds))
        seen = self._rank._seen.values
        if self._streaks is not None and len(seen) and seen[0] != seen[-1]:
            self._streaks = None  # two scores differ: the scores say something, from now on
        if self._streaks is not None:
            streaks = self._streaks.frame(b, kinds)
            if self.streak_score is not None:
                return self._streaks.confidences(streaks)
        if not len(s):
            return np.zeros(0, dtype=np.int64)
        learned = self._learned(s)
        if learned is None:
            return prior
        n = len(self._labelled)
        blended = (n * 100.0 * learned + EVIDENCE_PRIOR * prior) / (n + EVIDENCE_PRIOR)
        return np.floor(blended + 0.5).astype(np.int64)
