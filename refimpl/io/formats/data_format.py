"""What a file format is: the one frozen row (:class:`DataFormat`) a format module fills in, with
everything refimpl reads from the format instead of comparing its name."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from ...core.confidence import EVIDENCE
from ..detections import DetectionSequence
from ..ground_truth import GroundTruth
from ..stream import DetectionStream

KITTI_DEVKIT = "KITTI"
"""The KITTI devkit's ground-truth conventions (per-class targets and distractors, DontCare regions;
TrackEval's Kitti2DBox): what both ``eval`` devkits (refimpl.evaluation.devkits) score a format by."""
MOTCHALLENGE_DEVKIT = "MOTChallenge"
"""The MOTChallenge devkit's conventions (flag and class columns; TrackEval's MotChallenge2DBox)."""


@dataclass(frozen=True)
class SequenceFiles:
    """Where one sequence of a benchmark is on the data root (a format's ``benchmark_layout``)."""

    name: str
    dets_path: Path
    gt_path: Path
    seqinfo_path: Path | None = None


def need_class(name: str, object_class: str | None) -> str:
    """The object class, or ValueError: a format whose files hold several classes needs it."""
    if object_class is None:
        raise ValueError(f"{name} files hold several classes: reading or writing them needs the object class")
    return object_class


@dataclass(frozen=True)
class DataFormat:
    """One file format: everything it decides (see refimpl.io for the conventions).  A format is one
    module of refimpl.io.formats filling in one DataFormat, and one row of ``FORMATS``."""

    name: str
    title: str
    first_frame: int
    """The number of a sequence's first frame in its files (MOTChallenge 1, KITTI 0)."""
    needs_class: bool
    """Its files hold several object classes: reading (and writing results) needs ``--class``."""
    read_detections: Callable[..., DetectionSequence]
    """(path, object_class=None, seqinfo=None, num_frames=None, scores_rule=DEFAULT_SCORE_RULE)."""
    stream_detections: Callable[..., DetectionStream]
    """(text stream, object_class=None, seqinfo=None, scores_rule=DEFAULT_SCORE_RULE, image_size=None):
    detections read as the lines arrive (``track --dets -``, refimpl.io.stream)."""
    read_ground_truth: Callable[..., GroundTruth]
    """(path, object_class=None, seqinfo=None)."""
    frames_from_gt: Callable[[Path], int] | None
    """ground-truth path -> the sequence's frame count, where the detections cannot tell it (KITTI:
    the label file; MOTChallenge: None, seqinfo.ini says it)."""
    gt_layout: str
    """Where a ground-truth root holds a sequence's file (for messages)."""
    gt_candidates: Callable[[Path, str], list[Path]]
    """(ground-truth root, sequence name) -> the paths its ground truth may have."""
    gt_names: Callable[[Path], list[str]]
    """ground-truth root -> the names of the sequences with ground truth under it."""
    side_file: Callable[[Path], tuple[str, Path]]
    """detections path -> (label, path) of the file read beside it (seqinfo.ini, the label file)."""
    results_formatter: Callable[[int, str | None], Callable[[np.ndarray], str]]
    """(first_frame, object_class) -> a function formatting (n, 6) rows as results lines."""
    write_results: Callable[[str | os.PathLike, np.ndarray, int, str | None], None]
    read_results: Callable[[Path, str | None, bool], np.ndarray]
    """(path, object_class, allow_empty) -> (n, 6) rows, for evaluation on this format."""
    image_size: tuple[int, int] | None = None
    """(width, height) of its images where its files do not say it (KITTI 1242 x 375; MOTChallenge:
    its seqinfo.ini says it, None without one): the field-of-view border of the API and the pipe."""
    fps: float | None = None
    """Its frame rate where its files do not say it (KITTI 10; MOTChallenge: seqinfo.ini's)."""
    score_rule: str = EVIDENCE
    """The rule ``--scores auto`` (the default) reads its scores with (refimpl.core.confidence)."""
    gt_classes: Mapping[str, tuple[tuple, tuple]] = field(default_factory=dict)
    """object class -> (the ground-truth classes of its targets, its distractor classes): a
    hypothesis matched to a distractor row is removed, not counted (refimpl.evaluation)."""
    presets: str | None = None
    """The format its presets are stored under in model/presets.json (the ``kitti`` of
    ``kitti/car``); None: its own name.  A second file layout of KITTI's data names ``kitti``."""
    devkit: str | None = None
    """The devkit conventions its ground truth is scored by (KITTI_DEVKIT, MOTCHALLENGE_DEVKIT;
    refimpl.evaluation.devkits); None: targets and distractors as its reader flags them, and no
    TrackEval dataset scores it."""
    benchmark_layout: Callable[[Path, str, tuple[str, ...], str], list[SequenceFiles]] | None = None
    """(data root, detections, sequence names, split) -> the files of a benchmark of this format on
    the shared data root (refimpl.io.catalogue); None: no benchmark of it is there."""
    val_split: Callable[[Path], tuple[str, ...]] | None = None
    """data root -> the sequences of its benchmark's held-out validation split (KITTI's val
    seqmap), never tuned on; None: it has none (calibrate leaves one sequence out instead)."""

    @property
    def preset_format(self) -> str:
        """The format part of its presets' keys (refimpl.tracking.presets.preset_key)."""
        return self.presets or self.name
