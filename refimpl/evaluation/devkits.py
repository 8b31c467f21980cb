"""The two evaluation devkits of ``refimpl eval`` and the one-line convention each applied.

* ``refimpl`` (the default): ``refimpl.evaluation.evaluate`` -- a simplified devkit (distractor and KITTI
  DontCare removal as refimpl.io's package doc says, no KITTI truncation / occlusion / height
  filter); CLEAR MOT and IDF1 from motmetrics, HOTA from TrackEval's metric on the same rows.
  Every tracker in refimpl's tables is scored by it.
* ``trackeval``: TrackEval's own dataset pipeline (``refimpl.evaluation.trackeval_devkit``: Kitti2DBox /
  MotChallenge2DBox with HOTA, CLEAR and Identity), the numbers a TrackEval-based leaderboard gives.

:func:`evaluate_sequences` scores loaded sequences (``refimpl.evaluation.folder_eval``) with either and
returns the scores with the convention ``refimpl eval`` prints above its table (``Scores.header``):
which rules were applied, and how many hypotheses they removed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

from .. import io
from ..io.formats import KITTI_DEVKIT
from . import DEVKITS, REFIMPL, TRACKEVAL  # noqa: F401  (the --devkit choices, re-exported)
from .evaluate import DONTCARE_MIN_COVER, evaluate_many
from .trackeval_devkit import KITTI_CLASSES, MOT15, MOT_CLASS, mot_benchmark, trackeval_scores

if TYPE_CHECKING:
    from .folder_eval import LoadedSequence

IOU_THRESHOLD = 0.5
"""The match threshold of CLEAR MOT, IDF1 and the distractor matching (both devkits)."""


@dataclass(frozen=True)
class Scores:
    """Per-sequence and overall scores (``refimpl.evaluation.evaluate``'s keys) and the convention that made them."""

    devkit: str
    per_sequence: dict[str, dict]
    overall: dict
    rules: str
    """What the devkit applied, in one phrase (:func:`refimpl_rules`, ``TrackEvalScores.rules``)."""
    hypotheses: int
    """Result rows scored (for KITTI: of the class)."""
    removed: int
    """Of them, removed before counting (distractor hits, ignore regions, too small)."""

    @property
    def convention(self) -> str:
        """``<rules>; N of M hypotheses removed``."""
        return f"{self.rules}; {self.removed} of {self.hypotheses} hypotheses removed"

    @property
    def header(self) -> str:
        """The line ``refimpl eval`` prints above its table."""
        return f"convention: {self.convention}"


def check_devkit(devkit: str, data_format: str, object_class: str | None) -> None:
    """ValueError (one line) if the devkit cannot score this format / class."""
    if devkit not in DEVKITS:
        raise ValueError(f"unknown devkit {devkit!r} (known: {', '.join(DEVKITS)})")
    conventions = io.get_format(data_format).devkit
    if devkit == TRACKEVAL and conventions is None:
        raise ValueError(f"--devkit trackeval has no dataset for --format {data_format}: use --devkit refimpl")
    if devkit == TRACKEVAL and conventions == KITTI_DEVKIT and object_class not in KITTI_CLASSES:
        raise ValueError(f"--devkit trackeval scores KITTI Car and Pedestrian only (TrackEval's Kitti2DBox), "
                         f"not {str(object_class).capitalize()}: use --devkit refimpl")


def _names(types: Sequence[str]) -> str:
    return " / ".join(types)


def refimpl_rules(data_format: str, object_class: str | None, sequences: Sequence[LoadedSequence]) -> str:
    """What refimpl.evaluation.evaluate does with these sequences, in one phrase (refimpl.io's package doc)."""
    cover = f"{100 * DONTCARE_MIN_COVER:g}%"
    fmt = io.get_format(data_format)
    if fmt.devkit is None:
        return f"{fmt.title}, simplified devkit (refimpl): targets and distractors as its reader flags them"
    if fmt.devkit == KITTI_DEVKIT:
        targets, distractors = fmt.gt_classes[str(object_class)]
        cls = _names(targets)
        matched = (f"hypotheses matched (IoU >= {IOU_THRESHOLD:g}) to {_names(distractors)} rows, "
                   if distractors else "")
        return (f"KITTI {cls}, simplified devkit (refimpl): targets {cls} rows; removed: {matched}unmatched "
                f"hypotheses at least {cover} inside DontCare; no truncation/occlusion filter, no minimum height")
    kinds = sorted({"MOT15" if mot_benchmark(s) == MOT15 else "MOT16/17/20" for s in sequences})
    parts = []
    for kind in kinds:
        if kind == "MOT15":
            parts.append("MOT15 ground truth: targets rows with flag != 0; no distractors")
        else:
            parts.append(f"{kind} ground truth: targets rows with flag != 0 and class 1; removed: hypotheses "
                         f"matched (IoU >= {IOU_THRESHOLD:g}) to rows of class "
                         f"{', '.join(map(str, fmt.gt_classes[MOT_CLASS][1]))}")
    return "MOTChallenge, simplified devkit (refimpl): " + " | ".join(parts)


def evaluate_sequences(sequences: Sequence[LoadedSequence], data_format: str, object_class: str | None,
                       devkit: str = REFIMPL) -> Scores:
    """Score the sequences with the devkit; ``Scores.convention`` says what it applied."""
    check_devkit(devkit, data_format, object_class)
    if devkit == TRACKEVAL:
        te = trackeval_scores(sequences, data_format, object_class)
        return Scores(devkit, te.per_sequence, te.overall, te.rules, te.hypotheses, te.removed)
    per_sequence, overall = evaluate_many([(s.name, s.gt, s.results) for s in sequences], IOU_THRESHOLD)
    return Scores(devkit, per_sequence, overall, refimpl_rules(data_format, object_class, sequences),
                  sum(len(s.results) for s in sequences), overall["removed_distractor"] + overall["removed_dontcare"])
