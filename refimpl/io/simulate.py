"""A simulated pedestrian detector for sequences whose public detections we do not have.

The MOT17 public detections (DPM / FRCNN / SDP ``det/det.txt``) and every MOT20 detection file
are missing from the benchmark data (see /work/shared/data/PROVENANCE.md); only the ground
truth is there.  To still run the tracker on MOT17 train and MOT20-01, this module turns the
ground truth into a plausible detection stream.  **Results on it are not public-detection
results**: every simulated sequence is named ``"<seq> (simulated dets, seed <s>)"`` so that a
table can never mix them up.

The detector model (all parameters in :class:`DetectorParams`)
--------------------------------------------------------------
* Sources: only the ``considered`` ground-truth rows (for MOT16/17/20: flag 1 and class 1,
  pedestrians).  Distractors, static persons, vehicles etc. are never detected as such (they
  may attract false positives only by chance).
* Misses driven by occlusion: a source with visibility ``v`` is detected with probability
  ``p = p_max * clip((v - v0) / (1 - v0), 0, 1)``: at or below ``v0`` visible it is never
  detected, fully visible it is detected with ``p_max``, linear in between.  Real detectors
  miss heavily occluded people in just this way, which is what makes occlusion reasoning
  (hides_behind / unhides_from_behind) matter on these sequences.
* Localisation noise: the centre moves by ``N(0, centre_sigma * w)`` / ``N(0, centre_sigma * h)``
  and the size by ``exp(N(0, size_sigma))`` on width and height independently.
* False positives: ``Poisson(fp_per_frame)`` per frame.  A share ``fp_near_share`` of them sit
  near a random source of the same frame (a double or badly placed detection: centre moved by
  ``N(0, fp_shift)`` box sizes, size scaled by ``exp(N(0, fp_scale_sigma))``); the others (and
  all of them on frames without sources) lie anywhere in the image with a pedestrian-like box
  (height log-uniform in ``[fp_min_height, fp_max_height_frac * image height]``, aspect
  ``fp_aspect * exp(N(0, 0.15))``).
* Scores: true positives ``Beta(tp_score_a, tp_score_b)`` (skewed high), false positives
  ``Beta(fp_score_a, fp_score_b)`` (skewed low); confidence ``= round_half_up(100 * score)``,
  the same mapping io uses for [0, 1] scores.
* Boxes are clipped to the image (a detector sees nothing outside it); a box whose clipped width
  or height is below ``min_size`` pixels is dropped.  Within a frame detections are sorted by
  descending score (as detectors output them), so their order says nothing about identities.

Determinism: everything is drawn from ``numpy.random.default_rng(seed)`` in one fixed order,
each step one vectorised call over the whole sequence (sources in (frame, id) order): (1) a
uniform per source for the detection decision, (2) 4 normals of jitter per source, (3) a TP
score per source, (4) the FP count of every frame, then for all m FPs (5) uniforms (near or
anywhere), (6) uniforms (which source), (7) m x 4 normals, (8) m x 2 uniforms (position),
(9) uniforms (height), (10) normals (aspect) and (11) scores.  The draws for a source happen whether it is
detected or not, so changing ``p_max`` or ``v0`` changes which sources are detected but not
the boxes and scores of the others.  The same (gt, seed, params) gives byte-identical arrays.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .detections import DEFAULT_SCORE_RULE, calibrated, resolve_rule
from . import DetectionFrame, DetectionSequence, GroundTruth, InputFormatError, read_mot_ground_truth, read_seqinfo

MOT17_TRAIN = ("MOT17-02", "MOT17-04", "MOT17-05", "MOT17-09", "MOT17-10", "MOT17-11", "MOT17-13")
MOT17_GT_VARIANT = "FRCNN"
"""Which of the identical gt copies to read: MOT17-02-DPM's gt is incomplete (PROVENANCE.md)."""


@dataclass(frozen=True)
class SimulatedBenchmark:
    """The ground truth a simulated dataset draws its detections from: (sequence name, its
    MOTChallenge folder under the data root, holding gt/gt.txt and seqinfo.ini) per sequence.  The
    simulated part of a row of refimpl.io.datasets.CATALOGUE (which names every dataset)."""

    sequences: tuple[tuple[str, str], ...]


MOT17 = SimulatedBenchmark(tuple((s, f"MOT17/train/{s}-{MOT17_GT_VARIANT}") for s in MOT17_TRAIN))
"""The 7 MOT17 train sequences (ground truth of the -FRCNN folders; the gt is the same in all
variants except the broken MOT17-02-DPM copy)."""
MOT20_01 = SimulatedBenchmark((("MOT20-01", "MOT20/train/MOT20-01"),))


@dataclass(frozen=True)
class DetectorParams:
    """Parameters of the simulated detector.

    The defaults are chosen by hand to resemble a decent public pedestrian detector (a Faster
    R-CNN of the MOT17 kind); they are **not fitted** to any detector's output.  With them, on
    the 7 MOT17 train sequences (seed 0, one-to-one matching at IoU >= 0.5) recall is about 0.52
    (MOT17 is heavily occluded: about 15 % of its pedestrian boxes are at most 10 % visible,
    a quarter at most 26 %) and precision about 0.83 (0.66 on the small 640x480 MOT17-05,
    where the fixed false-positive rate meets only ~8 people per frame).
    """

    p_max: float = 0.95
    """Detection probability of a fully visible person: even easy people are missed now and then."""
    v0: float = 0.1
    """Visibility at or below which a person is never detected (p rises linearly from v0 to 1)."""
    centre_sigma: float = 0.05
    """Std. dev. of the centre offset as a fraction of the box width (x) and height (y)."""
    size_sigma: float = 0.05
    """Std. dev. of the log-width and log-height noise (about +-5 % size error)."""
    fp_per_frame: float = 2.0
    """Poisson mean of false positives per frame."""
    fp_near_share: float = 0.5
    """Share of false positives placed near a true person of the same frame (the rest anywhere)."""
    fp_shift: float = 0.6
    """Std. dev. of a near false positive's centre offset, in box widths / heights."""
    fp_scale_sigma: float = 0.3
    """Std. dev. of a near false positive's log-scale relative to its person's box."""
    fp_min_height: float = 40.0
    """Smallest height in pixels of a false positive placed anywhere."""
    fp_max_height_frac: float = 0.5
    """Largest height of a false positive placed anywhere, as a fraction of the image height."""
    fp_aspect: float = 0.41
    """Median width/height of a false positive placed anywhere (a standing person's box)."""
    tp_score_a: float = 6.0
    tp_score_b: float = 1.5
    """True-positive scores ~ Beta(6, 1.5): mean 0.8, mostly above 0.5."""
    fp_score_a: float = 1.5
    fp_score_b: float = 4.0
    """False-positive scores ~ Beta(1.5, 4): mean 0.27, rarely above 0.6."""
    clip_to_image: bool = True
    """Clip boxes to the image (when its size is known), as detectors output them."""
    min_size: float = 2.0
    """Drop boxes whose (clipped) width or height is below this many pixels."""

    def __post_init__(self) -> None:
        if not 0.0 <= self.p_max <= 1.0:
            raise ValueError(f"p_max must be within [0, 1], got {self.p_max}")
        if not 0.0 <= self.v0 < 1.0:
            raise ValueError(f"v0 must be within [0, 1), got {self.v0}")
        if not 0.0 <= self.fp_near_share <= 1.0:
            raise ValueError(f"fp_near_share must be within [0, 1], got {self.fp_near_share}")
        for name in ("centre_sigma", "size_sigma", "fp_per_frame", "fp_shift", "fp_scale_sigma", "min_size"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        for name in ("fp_min_height", "fp_max_height_frac", "fp_aspect", "tp_score_a", "tp_score_b",
                     "fp_score_a", "fp_score_b"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")

    def detection_probability(self, visibility: np.ndarray) -> np.ndarray:
        """p = p_max * clip((visibility - v0) / (1 - v0), 0, 1), elementwise."""
        v = np.asarray(visibility, dtype=float)
        return self.p_max * np.clip((v - self.v0) / (1.0 - self.v0), 0.0, 1.0)


def simulated_name(name: str, seed: int) -> str:
    """The name a simulated sequence carries: '<name> (simulated dets, seed <seed>)'."""
    return f"{name} (simulated dets, seed {int(seed)})"


def simulate_detections(gt: GroundTruth, seed: int = 0, params: DetectorParams = DetectorParams(),
                        image_size: tuple[int, int] | None = None, fps: float | None = None,
                        name: str | None = None, object_type: str = "pedestrian") -> DetectionSequence:
    """Simulated detections for every frame of gt (first_frame .. last), see the module docstring.

    image_size (w, h) bounds the boxes and places image-wide false positives; without it the
    extent of the ground-truth boxes (from 0, 0) stands in for the image, and the sequence's
    image_size stays None.  name defaults to gt.name; the result is named
    simulated_name(name, seed).  All detections get type object_type.
    """
    rng = np.random.default_rng(seed)
    first, count = int(gt.first_frame), int(gt.num_frames)
    src = np.flatnonzero(np.asarray(gt.considered, dtype=bool))
    src = src[np.lexsort((np.asarray(gt.ids)[src], np.asarray(gt.frames)[src]))]
    s_frames = np.asarray(gt.frames, dtype=np.int64)[src]
    s_boxes = np.asarray(gt.boxes, dtype=float).reshape(-1, 4)[src]
    s_vis = np.asarray(gt.visibility, dtype=float)[src]
    if len(src) and (s_frames.min() < first or s_frames.max() >= first + count):
        raise ValueError(f"{gt.name}: ground-truth frames outside {first}..{first + count - 1}")
    if image_size is not None:
        width, height = float(image_size[0]), float(image_size[1])
        if width <= 0 or height <= 0:
            raise ValueError(f"image_size must be positive, got {image_size}")
    else:
        all_boxes = np.asarray(gt.boxes, dtype=float).reshape(-1, 4)
        width = float(max(1.0, (all_boxes[:, 0] + all_boxes[:, 2]).max())) if len(all_boxes) else 1920.0
        height = float(max(1.0, (all_boxes[:, 1] + all_boxes[:, 3]).max())) if len(all_boxes) else 1080.0
    p = params
    n = len(src)

    # (1)-(3) true positives
    u_det = rng.random(n)
    z_tp = rng.standard_normal((n, 4))
    tp_scores = rng.beta(p.tp_score_a, p.tp_score_b, n)
    detected = u_det < p.detection_probability(s_vis)
    tp_boxes = _perturb(s_boxes, z_tp, p.centre_sigma, p.size_sigma)

    # (4)-(5) false positives
    fp_counts = rng.poisson(p.fp_per_frame, count)
    m = int(fp_counts.sum())
    fp_frames = np.repeat(np.arange(first, first + count, dtype=np.int64), fp_counts)
    u_near = rng.random(m)
    u_pick = rng.random(m)
    z_fp = rng.standard_normal((m, 4))
    u_pos = rng.random((m, 2))
    u_height = rng.random(m)
    z_aspect = rng.standard_normal(m)
    fp_scores = rng.beta(p.fp_score_a, p.fp_score_b, m)

    # near false positives: a random source of the same frame, shifted and rescaled
    lo = np.searchsorted(s_frames, fp_frames, side="left")
    hi = np.searchsorted(s_frames, fp_frames, side="right")
    has_src = hi > lo
    near = has_src & (u_near < p.fp_near_share)
    pick = np.minimum(lo + np.floor(u_pick * (hi - lo)).astype(np.int64), np.maximum(hi - 1, 0))
    fp_boxes = np.zeros((m, 4))
    if near.any():
        fp_boxes[near] = _perturb(s_boxes[pick[near]], z_fp[near], p.fp_shift, p.fp_scale_sigma)
    far = ~near
    if far.any():
        h_max = max(p.fp_max_height_frac * height, p.fp_min_height)
        h = np.exp(np.log(p.fp_min_height) + u_height[far] * (np.log(h_max) - np.log(p.fp_min_height)))
        w = h * p.fp_aspect * np.exp(0.15 * z_aspect[far])
        x = u_pos[far, 0] * np.maximum(width - w, 0.0)
        y = u_pos[far, 1] * np.maximum(height - h, 0.0)
        fp_boxes[far] = np.column_stack([x, y, w, h])

    frames = np.concatenate([s_frames[detected], fp_frames])
    boxes = np.concatenate([tp_boxes[detected], fp_boxes]).reshape(-1, 4)
    scores = np.concatenate([tp_scores[detected], fp_scores])
    if p.clip_to_image:
        x1 = np.clip(boxes[:, 0], 0.0, width)
        y1 = np.clip(boxes[:, 1], 0.0, height)
        x2 = np.clip(boxes[:, 0] + boxes[:, 2], 0.0, width)
        y2 = np.clip(boxes[:, 1] + boxes[:, 3], 0.0, height)
        boxes = np.column_stack([x1, y1, x2 - x1, y2 - y1])
    keep = (boxes[:, 2] >= max(p.min_size, 1e-9)) & (boxes[:, 3] >= max(p.min_size, 1e-9))
    frames, boxes, scores = frames[keep], boxes[keep], scores[keep]
    order = np.lexsort((np.arange(len(frames)), -scores, frames))
    frames, boxes, scores = frames[order], boxes[order], scores[order]
    conf = np.clip(np.floor(100.0 * scores + 0.5), 0, 100).astype(np.int64)

    numbers = np.arange(first, first + count)
    starts = np.searchsorted(frames, numbers, side="left")
    ends = np.searchsorted(frames, numbers, side="right")
    out = tuple(
        DetectionFrame(frame=int(f), boxes=boxes[a:b].copy(), scores=scores[a:b].copy(),
                       confidences=conf[a:b].copy(), types=(object_type,) * int(b - a))
        for f, a, b in zip(numbers, starts, ends))
    return DetectionSequence(
        name=simulated_name(gt.name if name is None else name, seed),
        frames=out,
        first_frame=first,
        image_size=None if image_size is None else (int(image_size[0]), int(image_size[1])),
        fps=None if fps is None else float(fps),
    )


def _perturb(boxes: np.ndarray, z: np.ndarray, centre_sigma: float, size_sigma: float) -> np.ndarray:
    """xywh boxes with the centre moved by z[:, :2]*centre_sigma*(w, h) and the size scaled by exp(z[:, 2:]*size_sigma)."""
    b = np.asarray(boxes, dtype=float).reshape(-1, 4)
    w, h = b[:, 2], b[:, 3]
    cx = b[:, 0] + w / 2 + z[:, 0] * centre_sigma * w
    cy = b[:, 1] + h / 2 + z[:, 1] * centre_sigma * h
    w2 = w * np.exp(z[:, 2] * size_sigma)
    h2 = h * np.exp(z[:, 3] * size_sigma)
    return np.column_stack([cx - w2 / 2, cy - h2 / 2, w2, h2])


def simulated_sequence_rows(seq: DetectionSequence) -> np.ndarray:
    """The detections as an (n, 10) MOTChallenge det array: frame, -1, x, y, w, h, score, -1, -1, -1."""
    rows = [np.column_stack([np.full(len(f), float(f.frame)), np.full(len(f), -1.0),
                             np.asarray(f.boxes, dtype=float).reshape(-1, 4),
                             np.asarray(f.scores, dtype=float), np.full((len(f), 3), -1.0)])
            for f in seq.frames]
    return np.concatenate(rows) if rows else np.zeros((0, 10))


def _require(path: Path, what: str, root: Path) -> Path:
    if not path.is_file():
        raise InputFormatError(
            f"missing {what}; is {root} the benchmark data root (holding MOT17/ and MOT20/)? "
            "See PROVENANCE.md for which files exist", path)
    return path


def simulated_benchmark_sequences(benchmark: SimulatedBenchmark, data_root: str | os.PathLike, seed: int = 0,
                                  params: DetectorParams = DetectorParams(), name: str = "simulated benchmark"
                                  ) -> list[tuple[str, DetectionSequence, GroundTruth]]:
    """(name, simulated DetectionSequence, GroundTruth) for every sequence of a simulated benchmark
    (:data:`MOT17`, :data:`MOT20_01`; by dataset name: refimpl.io.datasets.load_dataset).

    Names are the plain sequence names ('MOT17-02'); the detections are named
    'MOT17-02 (simulated dets, seed 0)'.  Every sequence uses default_rng(seed), so one sequence
    is reproduced by simulate_detections(gt, seed) with the seqinfo's image size, its confidences
    then computed by the default score rule, as a file of these rows would be read.  A missing
    file raises io.InputFormatError naming it; ``name`` (the dataset's) is what a message calls it.
    """
    root = Path(data_root)
    folders = [(s, root / folder) for s, folder in benchmark.sequences]
    if not root.is_dir():
        raise InputFormatError(f"data root for {name!r} not found", root)
    paths = [(s, _require(f / "gt" / "gt.txt", f"ground truth of {s}", root),
              _require(f / "seqinfo.ini", f"seqinfo.ini of {s}", root)) for s, f in folders]
    out = []
    for seq_name, gt_path, info_path in paths:
        info = read_seqinfo(info_path)
        gt = dataclasses.replace(read_mot_ground_truth(gt_path, seqinfo=info), name=seq_name)
        dets = simulate_detections(gt, seed=seed, params=params,
                                   image_size=(int(info["imWidth"]), int(info["imHeight"])),
                                   fps=float(info["frameRate"]), name=seq_name)
        # confidences as a file of these rows gets them by default (--scores auto: refimpl.core.confidence)
        out.append((seq_name, calibrated(dets, resolve_rule(DEFAULT_SCORE_RULE)), gt))
    return out
