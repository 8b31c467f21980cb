"""TrackEval's own dataset pipeline on refimpl's files: what ``refimpl eval --devkit trackeval`` runs.

refimpl's scorer (``refimpl.evaluation.evaluate``) applies a simplified devkit: the same CLEAR / IDF1 / HOTA
metrics on rows it preprocesses itself.  This module instead hands the files to TrackEval's
dataset classes, which preprocess them by their own rules, so a number printed here is the number
TrackEval (and so a leaderboard using it) gives:

* KITTI: ``trackeval.datasets.Kitti2DBox`` (the KITTI devkit's rules: targets truncated > 0 or
  occluded > 2 are ignored, unmatched hypotheses up to 25 px high are removed, besides the
  distractor classes and DontCare regions refimpl handles too); classes Car and Pedestrian only.
* MOTChallenge: ``trackeval.datasets.MotChallenge2DBox`` with the BENCHMARK whose rules fit the
  ground truth (:func:`mot_benchmark`): MOT15 for 10-field files (no distractors), MOT20 for a
  sequence named ``MOT20-*`` (class 6, non-MOT vehicle, is a distractor too), MOT17 otherwise
  (MOT16's rules are MOT17's).

The files are laid out in a temporary folder as TrackEval expects them (``GT_FOLDER/label_02/``
and a seqmap for KITTI, ``GT_FOLDER/<seq>/gt/gt.txt`` with ``SEQ_INFO`` for MOTChallenge,
``TRACKERS_FOLDER/refimpl/data/<seq>.txt``), under neutral sequence names: the ground-truth files
and KITTI tracking-format results as refimpl's readers see their lines (blank lines, a BOM and
``\\r`` dropped), results in MOTChallenge lines as the rows refimpl read from them, written with
every digit (``repr``), for KITTI in the KITTI tracking format with x2 = x + w, y2 = y + h.  Then
every sequence goes through TrackEval's ``get_raw_seq_data`` -> ``get_preprocessed_seq_data`` ->
``HOTA`` / ``CLEAR`` / ``Identity`` ``eval_sequence``, and the sequences are combined by each
metric's ``combine_sequences`` -- the steps of ``trackeval.Evaluator.evaluate``, without its
printing, timing and output files (nothing is printed: every TrackEval config sets
``PRINT_CONFIG`` False).  No network, nothing written outside the temporary folder.

The inputs are read and checked by refimpl first (``refimpl.evaluation.folder_eval.load_sequence``), so a
file TrackEval would refuse is normally refused earlier with refimpl's one-line error; a refusal
by TrackEval itself becomes an ``InputFormatError`` naming the results file.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from .. import io
from ..io.formats import KITTI_DEVKIT
from .hota import trackeval_package

if TYPE_CHECKING:  # the type only: importing this module stays light (the command line reads KITTI_CLASSES)
    from .folder_eval import LoadedSequence

TRACKER = "refimpl"
"""The tracker folder name under TRACKERS_FOLDER."""
KITTI_SPLIT = "refimpl"
"""SPLIT_TO_EVAL of the KITTI layout: the seqmap is ``evaluate_tracking.seqmap.refimpl``."""
MOT15, MOT17, MOT20 = "MOT15", "MOT17", "MOT20"
MOT_DISTRACTOR_CLASSES = {MOT15: (), MOT17: (2, 7, 8, 12), MOT20: (2, 6, 7, 8, 12)}
"""The gt classes whose matched hypotheses MotChallenge2DBox removes, by BENCHMARK (TrackEval 1.3.0,
``get_preprocessed_seq_data``: person_on_vehicle, static_person, distractor, reflection, and for
MOT20 non_mot_vehicle; MOT15 is not preprocessed)."""
MOT_CLASS = "pedestrian"
"""The class MotChallenge2DBox evaluates."""
KITTI_CLASSES = ("car", "pedestrian")
"""The classes Kitti2DBox evaluates."""
KITTI_DISTRACTORS = {"car": "Van", "pedestrian": "Person"}
"""Kitti2DBox's distractor class of each evaluated class."""


@dataclass(frozen=True)
class TrackEvalScores:
    """Per-sequence and combined scores from TrackEval, keyed like ``refimpl.evaluation.evaluate``'s results."""

    per_sequence: dict[str, dict]
    overall: dict
    hypotheses: int
    """Result rows read (of the evaluated class)."""
    removed: int
    """Of them, removed by the dataset's preprocessing (distractor hits, ignore regions, too small)."""
    rules: str
    """What the dataset class did, in one phrase (the convention line of ``refimpl eval``)."""


def mot_benchmark(seq: LoadedSequence) -> str:
    """The TrackEval BENCHMARK whose rules fit a MOTChallenge sequence's ground truth (module doc)."""
    if len(io.data_lines(seq.gt_path)[0].split(",")) == 10:
        return MOT15
    return MOT20 if seq.gt.name.startswith("MOT20") or seq.name.startswith("MOT20") else MOT17


def kitti_rules(object_class: str, min_height: float = 25, max_truncation: float = 0,
                max_occlusion: float = 2) -> str:
    cls = object_class.capitalize()
    return (f"KITTI {cls}, TrackEval Kitti2DBox (the KITTI devkit's rules): targets {cls} rows with truncation "
            f"<= {max_truncation:g} and occlusion <= {max_occlusion:g}; removed: hypotheses matched (IoU >= 0.5) "
            f"to {KITTI_DISTRACTORS[object_class]} rows or to truncated/occluded {cls} rows, unmatched ones up to "
            f"{min_height:g} px high or more than 50% inside DontCare")


def mot_rules(benchmarks: Sequence[str]) -> str:
    parts = []
    for bm in sorted(set(benchmarks)):
        classes = MOT_DISTRACTOR_CLASSES[bm]
        if classes:
            parts.append(f"BENCHMARK {bm}: targets rows with flag != 0 and class 1; removed: hypotheses matched "
                         f"(IoU >= 0.5) to rows of class {', '.join(map(str, classes))}")
        else:
            parts.append(f"BENCHMARK {bm}: targets rows with flag != 0; no distractors")
    return "MOTChallenge, TrackEval MotChallenge2DBox " + " | ".join(parts)


def _lines_or_empty(path: Path) -> list[str]:
    try:
        return io.data_lines(path)
    except io.InputFormatError as exc:
        if exc.reason.startswith("empty file"):
            return []  # an empty results file means "no tracks" (refimpl.evaluation.folder_eval)
        raise


def _write(path: Path, lines: Sequence[str]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(line + "\n" for line in lines), encoding="utf-8")


def _dense_ids(ids) -> dict[int, int]:
    """Each id -> its rank among the non-negative ids (0..K-1); a negative id (KITTI's DontCare -1)
    stays as it is.  TrackEval sizes an array by the largest id of a sequence (its relabelling,
    ``np.ones(max(ids) + 1)``), so a track id of 2^40 asked for 8 TiB; the map is monotone, so
    TrackEval's own relabelling, and every score, is what it would be on the ids given."""
    ids = sorted({int(i) for i in ids})
    dense = {i: k for k, i in enumerate(i for i in ids if i >= 0)}
    return {i: dense.get(i, i) for i in ids}


def _relabel(lines: list[str], sep: str | None) -> list[str]:
    """Lines whose second field is an id (a ground-truth file, KITTI tracking lines) with dense ids
    (``_dense_ids``); the lines were read and checked by refimpl's readers."""
    rows = [line.split(sep) for line in lines]
    ids = _dense_ids(int(float(r[1])) for r in rows)
    glue = sep if sep is not None else " "
    return [glue.join([r[0], str(ids[int(float(r[1]))]), *r[2:]]) for r in rows]


def _kitti_result_lines(seq: LoadedSequence, object_class: str) -> list[str]:
    """The results file as KITTI tracking lines: as is if it is one (ids made dense), else from the rows read."""
    lines = _lines_or_empty(seq.results_path)
    if lines and "," not in lines[0]:
        return _relabel(lines, None)  # KITTI tracking format (refimpl.io reads it the same way)
    kind = object_class.capitalize()
    ids = _dense_ids(seq.results[:, 1])
    return [f"{int(f)} {ids[int(i)]} {kind} -1 -1 -10 {float(x)!r} {float(y)!r} {float(x + w)!r} {float(y + h)!r} "
            "-1 -1 -1 -1000 -1000 -1000 -10 1" for f, i, x, y, w, h in seq.results]


def _mot_result_lines(seq: LoadedSequence) -> list[str]:
    ids = _dense_ids(seq.results[:, 1])
    return [f"{int(f)},{ids[int(i)]},{float(x)!r},{float(y)!r},{float(w)!r},{float(h)!r},1,-1,-1,-1"
            for f, i, x, y, w, h in seq.results]


def _metrics(trackeval):
    return [trackeval.metrics.HOTA(), trackeval.metrics.CLEAR({"THRESHOLD": 0.5, "PRINT_CONFIG": False}),
            trackeval.metrics.Identity({"THRESHOLD": 0.5, "PRINT_CONFIG": False})]


def _row(res: dict) -> dict:
    """TrackEval's HOTA / CLEAR / Identity results as refimpl.evaluation.evaluate's keys (fractions, counts)."""
    h, c, i = res["HOTA"], res["CLEAR"], res["Identity"]
    return {"hota": float(np.mean(h["HOTA"])), "deta": float(np.mean(h["DetA"])), "assa": float(np.mean(h["AssA"])),
            "mota": float(c["MOTA"]), "motp": float(c["MOTP"]), "idf1": float(i["IDF1"]),
            "mt": int(c["MT"]), "ml": int(c["ML"]), "fp": int(c["CLR_FP"]), "fn": int(c["CLR_FN"]),
            "idsw": int(c["IDSW"]), "frag": int(c["Frag"]), "num_gt": int(c["CLR_TP"] + c["CLR_FN"])}


def trackeval_scores(sequences: Sequence[LoadedSequence], data_format: str,
                     object_class: str | None = None) -> TrackEvalScores:
    """Score the sequences with TrackEval's dataset pipeline (module doc); KITTI needs car or pedestrian."""
    trackeval = trackeval_package()  # heavy and only needed here
    conventions = io.get_format(data_format).devkit
    if conventions is None:
        raise ValueError(f"TrackEval has no dataset for the {data_format} format (its devkit conventions are none)")
    kitti = conventions == KITTI_DEVKIT  # else MOTChallenge's
    if kitti and object_class not in KITTI_CLASSES:
        raise ValueError(f"TrackEval's Kitti2DBox evaluates {' and '.join(KITTI_CLASSES)} only, not {object_class}")
    if not sequences:
        raise ValueError("no sequences to score")
    metrics = _metrics(trackeval)
    per_seq: dict[str, dict] = {}
    raw_res: dict[str, dict] = {}
    removed = 0
    with tempfile.TemporaryDirectory(prefix="refimpl-trackeval-") as tmp:
        root = Path(tmp)
        if len({seq.name for seq in sequences}) != len(sequences):
            raise ValueError("sequence names must be distinct")
        names = {seq.name: f"{k:04d}" for k, seq in enumerate(sequences)}  # neutral names TrackEval can parse
        gt_dir, trackers, out = root / "gt", root / "trackers", root / "out"
        data_dir = trackers / TRACKER / "data"
        if kitti:
            for seq in sequences:
                _write(gt_dir / "label_02" / f"{names[seq.name]}.txt", _relabel(io.data_lines(seq.gt_path), None))
                _write(data_dir / f"{names[seq.name]}.txt", _kitti_result_lines(seq, object_class))
            _write(gt_dir / f"evaluate_tracking.seqmap.{KITTI_SPLIT}",
                   [f"{names[s.name]} empty 000000 {s.gt.num_frames:06d}" for s in sequences])
            dataset = trackeval.datasets.Kitti2DBox({
                "GT_FOLDER": str(gt_dir), "TRACKERS_FOLDER": str(trackers), "OUTPUT_FOLDER": str(out),
                "TRACKERS_TO_EVAL": [TRACKER], "CLASSES_TO_EVAL": [object_class], "SPLIT_TO_EVAL": KITTI_SPLIT,
                "PRINT_CONFIG": False})
            jobs = [(dataset, seq, object_class) for seq in sequences]
            rules = kitti_rules(object_class, dataset.min_height, dataset.max_truncation, dataset.max_occlusion)
        else:
            benchmark = {seq.name: mot_benchmark(seq) for seq in sequences}
            for seq in sequences:
                _write(gt_dir / names[seq.name] / "gt" / "gt.txt", _relabel(io.data_lines(seq.gt_path), ","))
                _write(data_dir / f"{names[seq.name]}.txt", _mot_result_lines(seq))
            datasets = {bm: trackeval.datasets.MotChallenge2DBox({
                "GT_FOLDER": str(gt_dir), "TRACKERS_FOLDER": str(trackers), "OUTPUT_FOLDER": str(out),
                "TRACKERS_TO_EVAL": [TRACKER], "CLASSES_TO_EVAL": [MOT_CLASS], "BENCHMARK": bm,
                "SPLIT_TO_EVAL": "train", "SKIP_SPLIT_FOL": True, "PRINT_CONFIG": False,
                "SEQ_INFO": {names[s.name]: s.gt.num_frames for s in sequences if benchmark[s.name] == bm}})
                for bm in sorted(set(benchmark.values()))}
            jobs = [(datasets[benchmark[seq.name]], seq, MOT_CLASS) for seq in sequences]
            rules = mot_rules(list(benchmark.values()))
        for dataset, seq, cls in jobs:
            try:
                raw = dataset.get_raw_seq_data(TRACKER, names[seq.name])
                data = dataset.get_preprocessed_seq_data(raw, cls)
            except trackeval.utils.TrackEvalException as exc:
                raise io.InputFormatError(f"TrackEval's {dataset.get_name()} refused it: {exc}",
                                          seq.results_path) from None
            res = {m.get_name(): m.eval_sequence(data) for m in metrics}
            raw_res[seq.name] = res
            kept = int(data["num_tracker_dets"])
            removed += len(seq.results) - kept
            per_seq[seq.name] = {**_row(res), "hypotheses": len(seq.results), "removed": len(seq.results) - kept}
    combined = {m.get_name(): m.combine_sequences({n: r[m.get_name()] for n, r in raw_res.items()})
                for m in metrics}
    return TrackEvalScores(per_seq, _row(combined), sum(len(s.results) for s in sequences), removed, rules)
