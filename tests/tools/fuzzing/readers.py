"""The fuzzed readers (targets): each reads one input in-process and checks what it accepted."""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from refimpl import io as rio
from refimpl.core.spec import ProblemFormatError, write_facts
from refimpl.core.facts import parse_facts, read_problem


class CheckFailed(Exception):
    """An accepted input whose result is wrong."""


def _check_boxes(boxes: np.ndarray, what: str) -> None:
    if boxes.ndim != 2 or boxes.shape[1] != 4:
        raise CheckFailed(f"{what}: boxes of shape {boxes.shape}")
    if not np.all(np.isfinite(boxes)):
        raise CheckFailed(f"{what}: non-finite box")
    if np.any(boxes[:, 2:] <= 0):
        raise CheckFailed(f"{what}: box with width or height <= 0")


def _data_lines(data: bytes) -> list[str]:
    text = data.decode("utf-8-sig")
    return [l.strip() for l in re.split(r"\r\n|\r|\n", text) if l.strip()]


def _check_detections(seq: rio.DetectionSequence, first: int, expect_conf, tolerance: int) -> None:
    numbers = [f.frame for f in seq.frames]
    if numbers != list(range(first, first + len(numbers))) or not numbers:
        raise CheckFailed("frames not numbered consecutively from the first frame")
    for f in seq.frames:
        _check_boxes(np.asarray(f.boxes, dtype=float).reshape(-1, 4), f"frame {f.frame}")
        if not (len(f.boxes) == len(f.scores) == len(f.confidences) == len(f.types)):
            raise CheckFailed(f"frame {f.frame}: inconsistent lengths")
        if not np.all(np.isfinite(f.scores)):
            raise CheckFailed(f"frame {f.frame}: non-finite score")
    scores = [s for f in seq.frames for s in f.scores.tolist()]
    confidences = [c for f in seq.frames for c in f.confidences.tolist()]
    for s, c, want in zip(scores, confidences, expect_conf(scores)):
        if not 0 <= c <= 100 or abs(c - want) > tolerance:
            raise CheckFailed(f"score {s!r} has confidence {c}, expected {want}")


def _mot_conf(scores: list[float]) -> list[int]:
    """The fixed scales of refimpl.io: round(100 score) (probability) if every score is in [0, 1],
    else clip(round(score), 0, 100) (raw)."""
    if all(0.0 <= v <= 1.0 for v in scores):
        return [math.floor(100.0 * s + 0.5) for s in scores]
    return [int(min(100.0, max(0.0, math.floor(s + 0.5)))) for s in scores]


def _kitti_conf(scores: list[float]) -> list[int]:
    """round(100 sigmoid(score)), computed another way (so +-1 for rounding at .5)."""
    return [math.floor(100.0 / (1.0 + math.exp(-s)) + 0.5) if s > -700 else 0 for s in scores]


def _check_gt(gt: rio.GroundTruth) -> None:
    n = len(gt.frames)
    _check_boxes(np.asarray(gt.boxes, dtype=float).reshape(-1, 4), "ground truth")
    if n and (gt.frames.min() < gt.first_frame or gt.frames.max() > gt.last_frame):
        raise CheckFailed("ground-truth frame outside first..last frame")
    pairs = list(zip(gt.frames.tolist(), gt.ids.tolist()))
    if len(set(pairs)) != len(pairs):
        raise CheckFailed("duplicate (frame, id) accepted")
    if pairs != sorted(pairs):
        raise CheckFailed("ground truth not sorted by (frame, id)")
    if gt.num_frames < 1:
        raise CheckFailed("ground truth with no frames")


def _check_results(a: np.ndarray, data: bytes) -> None:
    if a.ndim != 2 or a.shape[1] != 6 or not np.all(np.isfinite(a)):
        raise CheckFailed("results not a finite (n, 6) array")
    if len(a) != len(_data_lines(data)):
        raise CheckFailed(f"{len(a)} result rows from {len(_data_lines(data))} data lines")
    _check_boxes(a[:, 2:6], "results")
    pairs = list(zip(a[:, 0].tolist(), a[:, 1].tolist()))
    if len(set(pairs)) != len(pairs):
        raise CheckFailed("duplicate (frame, id) accepted in results")


def read_facts(path: Path, data: bytes, ctx: dict) -> None:
    p = read_problem(str(path))
    text = write_facts(p)
    try:
        again = parse_facts(text, "<round trip>")
    except ProblemFormatError as exc:
        raise CheckFailed(f"written facts do not parse: {exc}") from None
    if again != p or write_facts(again) != text:
        raise CheckFailed("write/parse round trip differs")


def _in_range(scores: list[float]) -> list[int]:
    """The default rule (evidence) gives any confidence 0..100: 50 +- 50."""
    return [50] * len(scores)


def read_mot_det(path: Path, data: bytes, ctx: dict) -> None:
    seq = rio.read_mot_detections(path)  # the default rule: any scale accepted, confidences 0..100
    _check_detections(seq, 1, _in_range, 50)
    scores = [s for f in seq.frames for s in f.scores.tolist()]
    fixed = "probability" if all(0.0 <= v <= 1.0 for v in scores) else "raw"
    # the same rows on the fixed scale _mot_conf computes (another way)
    _check_detections(rio.read_mot_detections(path, scores_rule=fixed), 1, _mot_conf, 0)
    if seq.num_detections != len(_data_lines(data)):
        raise CheckFailed(f"{seq.num_detections} detections from {len(_data_lines(data))} data lines")
    info = ctx.get("seqinfo")
    if info is not None and seq.num_frames != info:
        raise CheckFailed(f"{seq.num_frames} frames, seqinfo.ini says {info}")


def read_mot_gt(path: Path, data: bytes, ctx: dict) -> None:
    gt = rio.read_mot_ground_truth(path)
    _check_gt(gt)
    if len(gt.frames) != len(_data_lines(data)):
        raise CheckFailed(f"{len(gt.frames)} gt rows from {len(_data_lines(data))} data lines")


def read_mot_res(path: Path, data: bytes, ctx: dict) -> None:
    a = rio.read_mot_results(path, first_frame=ctx["first_frame"])
    _check_results(a, data)
    if np.any(np.abs(a[:, 2:6]) > 1e15):
        return  # beyond 2-decimal precision; the round trip is not meaningful
    if not np.all(np.round(a[:, 4:6], 2) > 0):
        return  # sub-0.005 sizes: readable, but write_mot_results refuses them by design
    out = path.with_name("roundtrip.txt")
    rio.write_mot_results(out, a, first_frame=ctx["first_frame"])
    b = rio.read_mot_results(out, first_frame=ctx["first_frame"])
    order = np.lexsort((a[:, 1], a[:, 0]))
    if not np.array_equal(b[:, :2], a[order, :2]) or not np.allclose(b[:, 2:], a[order, 2:6], atol=0.0051, rtol=0):
        raise CheckFailed("results write/read round trip differs")


def read_kitti_det(path: Path, data: bytes, ctx: dict) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rio.InputFormatWarning)
        seq = rio.read_kitti_detections(path, ctx["class"])
        fixed = rio.read_kitti_detections(path, ctx["class"], scores_rule="sigmoid")
    _check_detections(seq, 0, _in_range, 50)
    _check_detections(fixed, 0, _kitti_conf, 1)
    want = {"pedestrian": 1, "car": 2, "cyclist": 3}[ctx["class"]]
    rows = [l for l in _data_lines(data) if float(l.split(",")[1]) == want]
    if seq.num_detections + len(seq.dropped) != len(rows):
        raise CheckFailed(f"{seq.num_detections} + {len(seq.dropped)} dropped detections from {len(rows)} rows")


def read_kitti_gt(path: Path, data: bytes, ctx: dict) -> None:
    gt = rio.read_kitti_ground_truth(path, ctx["class"])
    _check_gt(gt)
    if gt.dontcare.ndim != 2 or gt.dontcare.shape[1] != 5:
        raise CheckFailed("dontcare table not (k, 5)")


@dataclass(frozen=True)
class Target:
    name: str
    sep: str | None
    reader: Callable[[Path, bytes, dict], None]
    errors: tuple[type[BaseException], ...]


TARGETS = (
    Target("facts", None, read_facts, (ProblemFormatError,)),
    Target("mot_det", ",", read_mot_det, (rio.InputFormatError,)),
    Target("mot_gt", ",", read_mot_gt, (rio.InputFormatError,)),
    Target("mot_results", ",", read_mot_res, (rio.InputFormatError,)),
    Target("kitti_det", ",", read_kitti_det, (rio.InputFormatError,)),
    Target("kitti_gt", " ", read_kitti_gt, (rio.InputFormatError,)),
)

# errors about the file as a whole (no line to name)
FILE_LEVEL = ("empty file", "not a UTF-8", "file not found", "cannot read", "missing '#const curr_time",
              "is a directory")
