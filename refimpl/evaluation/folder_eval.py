"""Evaluation of a folder of results files (one per sequence) against a ground-truth root.

Results: every ``<SEQ>.txt`` directly inside the results folder is the results file of sequence
SEQ (hidden files, other extensions and subfolders are ignored); sequences are scored in sorted
name order.  Ground truth of SEQ under the root ROOT:

* ``mot``: the MOTChallenge layout ``ROOT/<SEQ>/gt/gt.txt``, with ``ROOT/<SEQ>/seqinfo.ini``
  giving the sequence length when present (as in MOTChallenge's ``train/`` folders);
* ``kitti``: ``ROOT/label_02/<SEQ>.txt`` when ROOT has a ``label_02`` folder (ROOT is KITTI's
  ``tracking/training``, TrackEval's GT_FOLDER), otherwise ``ROOT/<SEQ>.txt`` (ROOT is the
  ``label_02`` folder itself).

A results file without ground truth is an error (one line naming the paths looked at); ground
truth without a results file is allowed (e.g. scoring only KITTI's validation sequences) and
listed in ``FolderEvaluation.unscored``.  An empty results file means "no tracks" (all FN).

The scores are ``refimpl.evaluation.evaluate``'s (HOTA from TrackEval, CLEAR and IDF1 from motmetrics, on
the same preprocessed rows), and ``metrics_json`` names them as the MOT literature does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import io
from .evaluate import evaluate_many, refuse_misfit

JSON_METRICS = (("HOTA", "hota"), ("DetA", "deta"), ("AssA", "assa"), ("MOTA", "mota"), ("MOTP", "motp"),
                ("IDF1", "idf1"), ("IDs", "idsw"), ("Frag", "frag"), ("FP", "fp"), ("FN", "fn"),
                ("MT", "mt"), ("ML", "ml"))
"""(name in the JSON output, key of refimpl.evaluation.evaluate's result) of every metric reported."""


@dataclass(frozen=True)
class SequenceFiles:
    """One sequence of a results folder: its results file and ground-truth file."""

    name: str
    results: Path
    gt: Path


@dataclass(frozen=True)
class FolderEvaluation:
    """Per-sequence and overall scores of a results folder, and ground-truth sequences without results."""

    per_sequence: dict
    overall: dict
    unscored: tuple[str, ...]


def pair_folder(results_dir: str | Path, gt_root: str | Path, data_format: str) -> tuple[list[SequenceFiles], tuple[str, ...]]:
    """The (results, ground truth) file pairs of a results folder, and the gt sequences left unscored."""
    results_dir, gt_root = Path(results_dir), Path(gt_root)
    fmt = io.get_format(data_format)
    if not results_dir.is_dir():
        raise io.InputFormatError("not a folder of results files", results_dir)
    if not gt_root.is_dir():
        raise io.InputFormatError("with a results folder, --gt must be the ground-truth root folder "
                                  f"(holding {fmt.gt_layout})", gt_root)
    files = sorted(p for p in results_dir.glob("*.txt") if p.is_file() and not p.name.startswith("."))
    if not files:
        raise io.InputFormatError("no results files (<SEQ>.txt) in this folder", results_dir)
    pairs = []
    for f in files:
        candidates = fmt.gt_candidates(gt_root, f.stem)
        found = next((c for c in candidates if c.is_file()), None)
        if found is None:
            raise io.InputFormatError(f"no ground truth for sequence {f.stem!r} (looked for "
                                      f"{', '.join(str(c) for c in candidates)})", f)
        pairs.append(SequenceFiles(f.stem, f, found))
    scored = {p.name for p in pairs}
    unscored = tuple(n for n in fmt.gt_names(gt_root) if n not in scored)
    return pairs, unscored


def read_ground_truth(path: str | Path, data_format: str, object_class: str | None) -> io.GroundTruth:
    """Ground truth of one sequence: MOTChallenge gt.txt (seqinfo.ini beside gt/ if any) or KITTI label_02."""
    return io.get_format(data_format).read_ground_truth(path, object_class=object_class)


@dataclass(frozen=True)
class LoadedSequence:
    """One sequence to score: its files and what refimpl's readers read from them (checked to fit)."""

    name: str
    results_path: Path
    gt_path: Path
    gt: io.GroundTruth
    results: np.ndarray
    """(n, 6) ``frame, id, x, y, w, h`` rows of the results file (for KITTI: the rows of the class)."""


def load_sequence(name: str | None, results: str | Path, gt: str | Path, data_format: str,
                  object_class: str | None, allow_empty: bool = False) -> LoadedSequence:
    """Read one results file and its ground truth (``name`` None: the ground truth's sequence name); refuse
    results that do not fit it (refuse_misfit)."""
    truth = read_ground_truth(gt, data_format, object_class)
    rows = io.read_results(results, data_format, object_class, allow_empty=allow_empty)
    refuse_misfit(truth, rows, results)  # rows past the last frame, or another sequence's results
    return LoadedSequence(name or truth.name, Path(results), Path(gt), truth, rows)


def load_folder(results_dir: str | Path, gt_root: str | Path, data_format: str,
                object_class: str | None = None) -> tuple[list[LoadedSequence], tuple[str, ...]]:
    """Every results file of a folder with its ground truth (module doc), and the gt sequences left unscored."""
    pairs, unscored = pair_folder(results_dir, gt_root, data_format)
    loaded = [load_sequence(p.name, p.results, p.gt, data_format, object_class, allow_empty=True) for p in pairs]
    return loaded, unscored


def evaluate_folder(results_dir: str | Path, gt_root: str | Path, data_format: str,
                    object_class: str | None = None, iou_threshold: float = 0.5) -> FolderEvaluation:
    """Score every results file of a folder against its ground truth (module doc for the layouts)."""
    loaded, unscored = load_folder(results_dir, gt_root, data_format, object_class)
    per_sequence, overall = evaluate_many([(s.name, s.gt, s.results) for s in loaded], iou_threshold)
    return FolderEvaluation(per_sequence, overall, unscored)


def _json_value(v):
    if isinstance(v, float):
        return None if math.isnan(v) else v
    return int(v)


def metrics_json(per_sequence: dict, overall: dict) -> dict:
    """``{"sequences": {name: {HOTA, DetA, AssA, MOTA, MOTP, IDF1, IDs, Frag, FP, FN, MT, ML}}, "overall": {...}}``.

    Ratios are fractions in [0, 1] (null when undefined, e.g. MOTA without targets), counts integers.
    """
    def one(r: dict) -> dict:
        return {name: _json_value(r[key]) for name, key in JSON_METRICS}

    return {"sequences": {n: one(r) for n, r in per_sequence.items()}, "overall": one(overall)}
