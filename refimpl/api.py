"""The library interface in the shape trackers are used in: ``Tracker(...).update(dets) -> tracks``.

One call per frame, in the shapes of the ecosystem:

* an (N, 5) array ``x1, y1, x2, y2, score`` -> (M, 5) rows ``x1, y1, x2, y2, track_id`` (SORT,
  ByteTrack);
* an (N, 6) array ``x1, y1, x2, y2, score, class_id`` and optionally the frame's image,
  ``update(dets, img)`` (BoxMOT's call) -> (M, 6) rows ``x1, y1, x2, y2, track_id, class_id``, the
  class id each track's detection came with;
* a ``supervision.Detections`` (roboflow ``trackers``' ``update(detections)``) -> the same
  detections with ``tracker_id`` set (-1: no reported track) and their own ``class_id``.

Behind it is the paper's Algorithm 1 (refimpl.tracking.tracker.AbductionTracker), so the rows
returned for a frame are exactly the rows ``refimpl track`` writes for that frame, with one
documented exception: the boxes ``refimpl track`` interpolates inside a *bridged* gap (a confirmed
track resumed after at most ``bridge_gap`` unobserved frames, a tracker option) are only known once the track resumes,
so an online caller never gets them, nor (with the tracker options ``backfill`` and
``fill_hidden``) the earlier frames a confirmation writes and the filled frames of an occlusion
episode; ``result().rows`` (or ``interpolated_rows()``, every row ``update`` did not report) has
them after the fact, on a tracker made with ``history=True``.

The history is opt-in: by default a Tracker keeps only what the next frame needs (the streaming
mode of ``refimpl track --dets -``), so its memory stays bounded on a camera stream of any length
(docs/robustness.md, "Long streams": +7 to +10 MB from frame 10,000 to 40,000 of 5 objects, where
the whole history grew by 100 MB).  ``Tracker(..., history=True)`` keeps every frame's
detections, track and event for ``result()``, ``scene()``, ``sequence()``, ``events`` and
``interpolated_rows()``; ``update`` returns the same rows either way.

A Tracker of every backend pickles (``pickle``, ``copy.deepcopy``, a process pool), also
mid-stream; the copy goes on as the original would (clingo's copy starts its own worker process).

Class ids are object types by ``class_types`` (default COCO's 80 classes, refimpl.io.classes):
0 person and 1 bicycle are the model's pedestrian and cyclist, 2 car, and every other class is a
type of its own (a bus is tracked as ``bus``, never in one track with a car); an id the map does
not name is the type ``class_<id>``.

Scores map to the model's integer confidences 0..100 as the file readers map them: by default by
the evidence rule (refimpl.core.confidence: calibrated, without labels, on how persistent the
detections of each score have been so far; any detector, any scale), or on a fixed scale
(``scores="probability"``, ``"sigmoid"``, ``"raw"``), or by rank.  The preset is chosen as ``refimpl track``
chooses it (refimpl.tracking.pipeline.setup_for): ``Tracker(format="kitti", object_type="car")`` runs the
KITTI Car preset, ``preset="none"`` none; KITTI's presets are per class, so ``format="kitti"``
without ``object_type`` is refused (as ``track --format kitti`` without ``--class``).

A box of zero width or height (below MIN_DET_SIZE, 0.01 px: a detector's box clipped at the image
border) is dropped with a warning, as the KITTI reader drops it; a negative width or height
(x2 < x1: boxes in another layout) is an error, as in both readers.
"""

from __future__ import annotations

import logging
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from .core.confidence import RunEvidence, online_rule, pooled, same_score_message, sequence_evidence
from .core.constants import default_constants
from .core.ranges import FPS_RANGE_TEXT, check_constant, fps_fits
from .core.spec import HistoryEvent, track_number
from .io import (COCO_CLASS_TYPES, DetectionFrame, DetectionSequence, FORMATS, InputFormatWarning, MAX_COORD,
                 MAX_DETECTIONS_PER_FRAME, MIN_DET_SIZE, OBJECT_TYPES, class_id_type, class_type, get_format)
from .io.detections import resolve_rule, scale_confidences
from .io.lines import too_many_detections
from .scene import Scene, scene_from_result
from .solvers import BACKENDS, DEFAULT_BACKEND
from .tracking.options import TrackerOptions
from .tracking.camera import image_in_use, warn_if_outside
from .tracking.pipeline import AUTO, new_tracker, setup_for
from .tracking.tracker import DEFAULT_MIN_HITS, ResultSink, TrackingResult

DEFAULT_CLASS_TYPES = COCO_CLASS_TYPES
"""COCO's class ids (what YOLO-family detectors, supervision and BoxMOT use): 0 person (pedestrian),
1 bicycle (cyclist), 2 car, and the other 77 classes each as a type of its own (refimpl.io.classes)."""
LOG = logging.getLogger("refimpl")

__all__ = ["Tracker", "confidences_from_scores"]


def _is_detections(obj) -> bool:
    """A supervision.Detections (duck-typed: supervision is an optional extra)."""
    return all(hasattr(obj, a) for a in ("xyxy", "confidence", "class_id", "tracker_id"))


def confidences_from_scores(scores: ArrayLike) -> np.ndarray:
    """Scores in [0, 1] as the paper's integer confidences 0..100 (round half up, as refimpl.io)."""
    return np.floor(100.0 * np.asarray(scores, dtype=float) + 0.5).astype(np.int64)


@dataclass(frozen=True)
class FrameCounts:
    """How the frames so far were answered (``Tracker.counts``, kept with or without history)."""

    frames: int
    not_optimal_frames: int
    """Frames whose answer is not proven optimal (out of time or out of budget)."""
    budget_hits: int
    """Frames the frame budget stopped (best answer found so far)."""
    over_budget: int
    """Frames that took longer than the budget (a proven answer is kept however late)."""


THIN_SECONDS = 10
"""A Tracker that has reported no row after this many seconds of frames with detections says so once
(``warnings``), as ``refimpl track`` says a run wrote no track."""


class Tracker:
    """Online tracking by abduction, one ``update`` per frame.

    backend: an abduction backend of refimpl.solvers.BACKENDS (default DEFAULT_BACKEND, as
        ``refimpl track``).
    format: a format of refimpl.io.FORMATS ("mot", "kitti"): the file format whose conventions the
        frames follow (frame numbering, its image size and frame rate when ``img_size`` / ``fps`` are
        not given: KITTI's, none for MOTChallenge; what ``scores="auto"`` means) and, with
        ``object_type``, which preset applies.
    preset: "auto" (default: the preset of (format, object_type) by the same rule as
        ``refimpl track``, refimpl.tracking.pipeline.setup_for: its own, else the robust
        "default"), "none" (model/constants.lp and the default tracker options, as
        ``--no-preset``), or a preset's name ("kitti/car", "default").  ``tracker.setup`` says
        what was chosen (``tracker.setup.describe()``, also logged at INFO on the "refimpl" logger).
    constants: model constant overrides (names of model/constants.lp), e.g. {"iou_thresh": 20000},
        on top of the preset.
    img_size: (width, height) of the images in pixels; sets img_width / img_height (the
        field-of-view border) and scales the pixel constants to the image (docs/model.md 3.22).  Without it the first frame's image (``update(dets, img)``) gives
        it; without either the border is not tested, as for a det.txt without seqinfo.ini
        (format "kitti": 1242 x 375 until an image says otherwise).
    min_hits: the abduction tracker's own, as for
        ``refimpl.tracking.pipeline.run_sequence``; time_limit: the per-frame solver limit in seconds
        (``Setup.time_limit``, ``refimpl track --time-limit``).
    **options: tracker option overrides by name (refimpl.tracking.options.TRACKER_OPTIONS), e.g.
        ``written_box="detection"`` or ``bridge_gap=19``, on top of the preset.
    scores: how a score becomes the model's confidence, as the file readers do it (refimpl.io.SCORE_RULES,
        the same on every format): "auto" (default) is "evidence" (refimpl.core.confidence), or
        "rank", "probability" (scores in 0..1, times 100), "sigmoid" (logits), "raw" (0..100).
    calibrate_with: detection files of the same detector, other videos (paths, read with this
        tracker's ``format`` and ``object_type``): the score rule ("evidence" or "rank") learns from
        them, whole, before the first frame, as ``refimpl track`` with several --dets calibrates
        each file on the others (docs/model.md 3.19, "A run's files pooled"): a video whose best
        detections are false no longer takes them for the detector's best.  Default: none.
    object_type: the class of the detections when ``update`` gets no classes (any class name:
        "car", "Pedestrian", "person", "bus"; refimpl.io.class_type), and with ``format`` the
        preset.  Default: "pedestrian" for format "mot" (MOTChallenge's class, as ``refimpl
        track`` reads a det.txt); format "kitti" needs it (its presets are per class).
    class_types: integer class id -> class name, for (N, 6) arrays and ``supervision.Detections``
        (default DEFAULT_CLASS_TYPES: COCO's 80).  Detections whose types differ never share a
        track (the model's type match, docs/model.md 3.2); an id without an entry is a type of
        its own, ``class_<id>``.
    first_frame: the number of the first frame (default: 1 for MOTChallenge, 0 for KITTI).
    name: carried into ``scene()``.
    fps: the frame rate, a finite number > 0 (default: none for "mot", as a det.txt without
        seqinfo.ini; 10 for "kitti"): the preset's durations become the same seconds at this rate
        (docs/model.md 3.22) and a halt is bounded at 10 s (lost_after_hidden_max), as a
        seqinfo.ini's frameRate or ``refimpl track --fps``.
    history: False (default): the tracker runs in the streaming mode of ``refimpl track --dets -``
        (it forgets finished tracks and all but the boxes a later frame reads), so memory stays
        bounded on a stream of any length, and ``result()``, ``scene()``, ``sequence()``,
        ``events`` and ``interpolated_rows()`` raise ValueError.  True: every frame's detections,
        every track's boxes and every event are kept for those five, so memory grows with the
        stream (1.2-3.3 MB per 1,000 frames of 5 objects): ask for it to look back at a video.
        ``update`` returns the same rows either way.
    frame_budget: milliseconds an ``update`` may take for its frame problem and its solve
        (wall-clock), as ``refimpl track --frame-budget``: "auto" (default: 25 ms,
        refimpl.tracking.pipeline.DEFAULT_FRAME_BUDGET_MS, for the real-time backend ``cpsat``;
        none for the oracles), None (no budget) or a number >= 0.  A frame that reaches it gets
        the best answer found so far, flagged not proven optimal; ``counts.budget_hits`` counts
        them, ``counts.over_budget`` the frames that took longer (the fast path, exact and
        never interrupted, answers however late).  A caller with a deadline per frame may also
        want ``gc.freeze()`` after its set-up: a full garbage collection walks every object the
        process keeps (docs/benchmarks.md, "The slowest frames").
    """

    def __init__(self, backend: str = DEFAULT_BACKEND, *, format: str = "mot", preset: str | None = AUTO,
                 constants: Mapping[str, int] | None = None, img_size: tuple[int, int] | None = None,
                 min_hits: int = DEFAULT_MIN_HITS, time_limit: float | None = None,
                 object_type: str | None = None, first_frame: int | None = None, name: str = "sequence",
                 fps: float | None = None, scores: str = "auto",
                 class_types: Mapping[int, str] | None = None, history: bool = False,
                 frame_budget: float | None | str = AUTO, calibrate_with: Sequence[str | Path] = (),
                 **options: object) -> None:
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {', '.join(BACKENDS)}, got {backend!r}")
        if format not in FORMATS:
            raise ValueError(f"format must be one of {', '.join(FORMATS)}, got {format!r}")
        resolve_rule(scores)  # ValueError naming the rules
        fmt = get_format(format)
        if object_type is None and fmt.needs_class:
            raise ValueError(f"format={format!r} needs object_type= ({', '.join(map(repr, OBJECT_TYPES))} or any "
                             f"class name): its presets are per class, as `refimpl track --format {format}` needs "
                             "--class")
        self.object_type = self._type("pedestrian" if object_type is None else object_type, "object_type")
        self.class_types = self._class_types(class_types)
        """Integer class id (column 6 of an (N, 6) array, ``Detections.class_id``) -> object type."""
        overrides = self._constants(constants)
        self._given_size = None if img_size is None else self._img_size(img_size)
        self._format_size = fmt.image_size
        if fps is None:
            fps = fmt.fps
        if fps is not None:
            fps = self._fps(fps)
        if first_frame is None:
            first_frame = fmt.first_frame
        for label, value in (("min_hits", min_hits), ("first_frame", first_frame)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
                raise ValueError(f"{label} must be a non-negative integer, got {value!r}")
        if time_limit is not None and not time_limit > 0:
            raise ValueError(f"time_limit must be > 0 seconds or None, got {time_limit!r}")
        TrackerOptions.from_mapping(options, "Tracker")  # ValueError naming what is wrong
        self.setup = setup_for(fmt.preset_format, self.object_type, backend, overrides, options, preset, time_limit,
                               frame_budget)  # ValueError for a bad budget
        """What this tracker runs with (refimpl.tracking.pipeline.Setup): backend, constants, options, preset."""
        LOG.info("refimpl.Tracker: %s", self.setup.describe())
        self.backend = backend
        self.name, self.fps = name, fps
        self.first_frame = int(first_frame)
        self.scores = resolve_rule(scores, fmt.score_rule)
        """The score rule in use: ``auto`` is the format's own scale, as the file readers read it."""
        self._evidence = self._read_evidence(calibrate_with, fmt, object_type)
        self._min_hits = int(min_hits)
        if not isinstance(history, bool):
            raise ValueError(f"history must be True or False, got {history!r}")
        self.history = history
        """Whether the whole history is kept (``result()``, ``scene()``, ...), or only what the next frame needs."""
        self.reset()

    def reset(self) -> None:
        """Start a new sequence: forget every track, event and score seen, and an image size learnt
        from the last video's images (the same results as a fresh Tracker with the same arguments)."""
        self.image_size = self._given_size or self._format_size
        """(width, height) the field-of-view border is tested with (None: not tested)."""
        self._tracker = self._new_tracker(self.image_size)
        self._rule = online_rule(self.scores, self._evidence)
        self._count = 0  # frames tracked
        self._frames: list[DetectionFrame] = []  # with history only
        self._reported: set[tuple[int, int]] = set()  # (frame, track number) returned by update
        self._class_of: dict[int, int] = {}  # track number -> the class id of its latest detection
        self._size_warned = False
        self._same_warned = False  # every score the same: said once (docs/model.md 3.19)
        self._outside_said = False  # a detection centred outside the image: said once (camera.warn_if_outside)
        self._seen = [0, 0, 101, -1]  # detections, rows reported, smallest and largest confidence so far

    def _new_tracker(self, size):
        if self.history:
            return new_tracker(self.setup, size, self.fps, self._min_hits)
        # the pipe's streaming mode: rows handed to a sink that keeps none (update reports them)
        return new_tracker(self.setup, size, self.fps, self._min_hits, sink=ResultSink(), keep_records=False)

    def _kept(self, what: str) -> None:
        if not self.history:
            raise ValueError(f"{what}: this Tracker keeps no history (the default, for bounded memory on an "
                             "endless stream); make it with Tracker(..., history=True) to have it")

    def __repr__(self) -> str:
        return f"refimpl.Tracker({self.setup.describe()}, image size {self.image_size}, fps {self.fps})"

    # -- validation --------------------------------------------------------------------------
    @staticmethod
    def _read_evidence(paths: Sequence[str | Path], fmt, object_type: str | None) -> RunEvidence | None:
        """What the files of ``calibrate_with`` show the score rule, pooled (None: no file)."""
        if isinstance(paths, (str, Path)):
            raise ValueError("calibrate_with must be a list of detection files, got one path: "
                             f"calibrate_with=[{str(paths)!r}]")
        seqs = []
        for path in paths:
            try:
                seqs.append(fmt.read_detections(str(path), object_class=object_type if fmt.needs_class else None))
            except (OSError, ValueError) as exc:  # the readers' InputFormatError is a ValueError naming the file
                raise ValueError(f"calibrate_with: {exc}") from None
        return pooled([sequence_evidence(seq.frames) for seq in seqs])

    @staticmethod
    def _constants(constants: Mapping[str, int] | None) -> dict[str, int]:
        known = default_constants()
        out: dict[str, int] = {}
        for key, value in dict(constants or {}).items():
            if key not in known:
                raise ValueError(f"unknown model constant {key!r} (known: {', '.join(sorted(known))})")
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise ValueError(f"model constant {key} must be an integer, got {value!r}")
            check_constant(key, int(value), "refimpl.Tracker(constants=...)")  # its range, now, not at a frame
            out[key] = int(value)
        return out

    @staticmethod
    def _img_size(img_size: object) -> tuple[int, int]:
        try:
            w, h = img_size
        except (TypeError, ValueError):
            raise ValueError(f"img_size must be (width, height), got {img_size!r}") from None
        if any(isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v <= 0 for v in (w, h)):
            raise ValueError(f"img_size must be two positive integers (width, height), got {img_size!r}")
        return int(w), int(h)

    @staticmethod
    def _fps(fps: object) -> float:
        ok = not isinstance(fps, bool) and isinstance(fps, (int, float, np.integer, np.floating))
        if not ok or not math.isfinite(fps) or not fps_fits(fps):
            raise ValueError(f"fps must be {FPS_RANGE_TEXT}, got {fps!r}")
        return float(fps)

    @staticmethod
    def _type(name: object, what: str) -> str:
        try:
            return class_type(name)
        except ValueError as exc:
            raise ValueError(f"{what}: {exc}") from None

    def _class_types(self, class_types: Mapping[int, str] | None) -> dict[int, str]:
        if class_types is None:
            return dict(DEFAULT_CLASS_TYPES)
        if not isinstance(class_types, Mapping):
            raise ValueError(f"class_types must map integer class ids to class names, got {class_types!r}")
        out = {}
        for k, v in class_types.items():
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
                raise ValueError(f"class_types: class id {k!r} is not a non-negative integer")
            out[int(k)] = self._type(v, f"class_types[{k}]")
        return out

    def _check(self, dets: ArrayLike, classes: Sequence[str] | None):
        """The detections to track: (boxes xywh, scores, types, class ids or None, rows kept), the
        rows of degenerate boxes left out (``dropped``, their row numbers)."""
        try:
            a = np.asarray(dets, dtype=float)
        except (TypeError, ValueError):
            raise ValueError("dets must be a numeric (N, 5) array x1,y1,x2,y2,score") from None
        if a.size == 0 and (a.ndim < 2 or a.shape[0] == 0):  # no rows: an empty frame, (0,), (0, 4) or (0, 5)
            a = a.reshape(0, 5)
        if a.ndim != 2 or a.shape[1] not in (5, 6):  # (5, 0) is five rows without their columns, as (2, 4)
            raise ValueError(f"dets must be an (N, 5) array x1,y1,x2,y2,score or (N, 6) "
                             f"x1,y1,x2,y2,score,class_id; got shape {a.shape}")
        if len(a) > MAX_DETECTIONS_PER_FRAME:
            raise ValueError(too_many_detections(self.frame))
        ids = None
        if a.shape[1] == 6:
            if classes is not None:
                raise ValueError("an (N, 6) array carries its classes in column 6: give no classes= too")
            ids = self._class_ids(a[:, 5])
            classes = [class_id_type(c, self.class_types) for c in ids]
            a = a[:, :5]
        bad = ~np.isfinite(a).all(axis=1)
        if bad.any():
            raise ValueError(f"dets row {int(np.flatnonzero(bad)[0])} contains NaN or inf")
        bad = (np.abs(a[:, :4]) > MAX_COORD).any(axis=1)
        if bad.any():
            raise ValueError(f"dets row {int(np.flatnonzero(bad)[0])}: a coordinate beyond {MAX_COORD:g} px")
        scores = a[:, 4]
        bad = ((scores < 0.0) | (scores > 1.0)) if self.scores == "probability" else np.zeros(len(a), bool)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"dets row {k}: score {scores[k]:g} is outside 0..1 (scores=\"auto\", the "
                             "default, takes a detector's scores of any scale)")
        boxes = np.column_stack([a[:, 0], a[:, 1], a[:, 2] - a[:, 0], a[:, 3] - a[:, 1]])
        bad = (boxes[:, 2] < 0) | (boxes[:, 3] < 0)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"dets row {k}: x2 < x1 or y2 < y1 (width {boxes[k, 2]:g}, height {boxes[k, 3]:g}): "
                             "boxes go in as x1, y1, x2, y2 with x2 > x1, y2 > y1")
        if classes is None:
            types = (self.object_type,) * len(a)
        else:
            if isinstance(classes, str) or len(classes) != len(a):
                n = "a string" if isinstance(classes, str) else f"{len(classes)} entries"
                raise ValueError(f"classes must be a sequence of one class per detection: {len(a)} detections, "
                                 f"got {n}")
            types = tuple(self._type(c, f"classes[{i}]") for i, c in enumerate(classes))
        # zero width or height (a box clipped at the border): dropped, as the KITTI reader drops it
        keep = np.flatnonzero((boxes[:, 2] >= MIN_DET_SIZE) & (boxes[:, 3] >= MIN_DET_SIZE))
        dropped = sorted(set(range(len(a))) - set(keep.tolist()))
        return (boxes[keep], scores[keep], tuple(types[i] for i in keep),
                None if ids is None else [ids[i] for i in keep], keep, dropped)

    @staticmethod
    def _class_ids(values) -> list[int]:
        """The integer class ids of column 6; ValueError naming a row that holds none."""
        out = []
        for k, v in enumerate(np.asarray(values, dtype=float)):
            if not np.isfinite(v) or v != int(v) or v < 0:
                raise ValueError(f"dets row {k}: class id {v:g} is not a non-negative integer")
            out.append(int(v))
        return out

    def _image(self, img) -> None:
        """The frame's image (BoxMOT's ``update(dets, img)``): on a video's first frame its size is
        the image size unless ``img_size`` was given."""
        shape = getattr(img, "shape", None)
        if shape is None or len(shape) not in (2, 3) or shape[0] < 1 or shape[1] < 1:
            raise ValueError("img must be the frame's image as an H x W x 3 array (BoxMOT's update(dets, img)); "
                             "give classes by name as update(dets, classes=[...])")
        size = (int(shape[1]), int(shape[0]))
        if size == self.image_size:
            return
        if not self._count and self._given_size is None:
            self.image_size = size
            self._tracker = self._new_tracker(size)
        elif not self._size_warned:
            self._size_warned = True
            if self.image_size is None:
                had = "no image came with the first frame, so the field-of-view border is not tested"
            else:
                why = "img_size" if self._given_size is not None else "the first frame's image"
                had = f"{why} gave {self.image_size[0]} x {self.image_size[1]}, which the border keeps"
            warnings.warn(f"frame {self.frame}: the image is {size[0]} x {size[1]} but {had}", stacklevel=3)

    # -- tracking ----------------------------------------------------------------------------
    @property
    def frame(self) -> int:
        """The number of the next frame ``update`` will process."""
        return self.first_frame + self._count

    def update(self, dets, img=None, *, classes: Sequence[str] | None = None):
        """Track one frame.

        * an (N, 5) array x1, y1, x2, y2, score: the (M, 5) rows x1, y1, x2, y2, track_id reported
          for this frame, by track id;
        * an (N, 6) array x1, y1, x2, y2, score, class_id (BoxMOT's layout): (M, 6) rows with the
          class id of each track's detection as column 6;
        * a ``supervision.Detections`` (extra ``supervision``): the same Detections with
          ``tracker_id`` set, as roboflow ``trackers`` returns them: the id of the track each
          detection was assigned to, resumed or started, where that track's row is reported this
          frame; -1 otherwise.  ``class_id`` (if any) gives each detection's type by
          ``class_types`` and comes back as it came.

        ``img``: the frame's image (H x W x 3 array; BoxMOT's ``update(dets, img)``), optional: the
        first frame's gives the image size when ``img_size`` was not.  ``classes``: each
        detection's class by name (with an (N, 5) array).  A box of zero width or height is left
        out with a warning (the module doc).
        """
        if img is not None:
            self._image(img)
        if _is_detections(dets):
            if classes is not None:
                raise ValueError("Detections carry their classes in class_id: give no classes= too")
            return self._update_detections(dets)
        with_class = np.ndim(dets) == 2 and np.shape(dets)[1] == 6
        rows, _ = self._step(dets, classes)
        if not with_class:
            return rows
        cls = np.array([self._class_of.get(int(n), -1) for n in rows[:, 4]], dtype=float)
        return np.column_stack([rows, cls]).reshape(-1, 6)

    def _say_if_thin(self, conf: np.ndarray, reported: int) -> None:
        """One warning, as ``refimpl track`` says "no track written", when THIN_SECONDS of video (at
        the tracker's fps, else 10 fps) with detections have reported no row: the evidence is thin."""
        at = max(1, round(THIN_SECONDS * (self.fps or 10)))
        if self._count > at:
            return  # said or not, once: nothing to count on the hot path after it
        seen = self._seen
        seen[0] += len(conf)
        seen[1] += reported
        if len(conf):
            seen[2], seen[3] = min(seen[2], int(conf.min())), max(seen[3], int(conf.max()))
        if self._count != at or seen[1] or not seen[0]:
            return
        need = dict(default_constants(), **dict(self.setup.constants))["conf_thresh_new_track"]
        why = "" if self.setup.baseline else f" (a new track needs > {need}: conf_thresh_new_track)"
        seeded = ", calibrated beside the calibrate_with files" if self._evidence is not None else ""
        warnings.warn(f"{self.name}: {self._count} frames, {seen[0]} detections and no track reported yet: their "
                      f"confidences are {seen[2]}..{seen[3]}{why}{seeded}; the evidence is thin (scores= says how "
                      "scores are read)", UserWarning, stacklevel=4)

    def _step(self, dets, classes) -> tuple[np.ndarray, dict[int, str]]:
        """Track one frame: its reported rows by track id, and {row of dets: track id} of the
        detections assigned."""
        boxes, scores, types, ids, kept, dropped = self._check(dets, classes)
        frame = self.frame
        if dropped:
            warnings.warn(f"frame {frame}: dropped {len(dropped)} detection(s) of zero width or height (below "
                          f"{MIN_DET_SIZE:g} px), dets row(s) {', '.join(map(str, dropped))}", InputFormatWarning,
                          stacklevel=3)
        if not self._outside_said and len(boxes) and not self.setup.baseline:
            image = image_in_use(dict(self.setup.constants), self.image_size)
            self._outside_said = image is not None and warn_if_outside(frame, boxes, image, stacklevel=4)
        conf = self._confidences(boxes, scores, types)
        ended = len(self._tracker.finished)
        self._tracker.step(frame, boxes, conf, types, scores=scores)
        self._count += 1
        if self.history:
            self._frames.append(DetectionFrame(frame, boxes, scores, conf, types))
        owners = {int(kept[j]): trk for j, trk in self._tracker.owners.items()}
        if ids is not None:
            for j, trk in self._tracker.owners.items():
                self._class_of[track_number(trk)] = ids[j]
        rows = []
        # a frame's rows are those of live tracks and of tracks ended in it (an ended track is one
        # not observed, so it has none; looked at all the same), not of every track ever finished
        for trk in [*self._tracker.tracks.values(), *self._tracker.finished[ended:]]:
            if frame in trk.confirmed:
                x, y, w, h = trk.observed[frame]
                rows.append((x, y, x + w, y + h, float(track_number(trk.id))))
        out = np.array(rows, dtype=float).reshape(-1, 5)
        self._say_if_thin(conf, len(out))
        if self.history:
            self._reported.update((frame, int(n)) for n in out[:, 4])
        elif ids is not None:  # the class of live tracks only
            live = {track_number(t) for t in self._tracker.tracks}
            self._class_of = {n: c for n, c in self._class_of.items() if n in live}
        return out[np.argsort(out[:, 4], kind="stable")], owners

    def _confidences(self, boxes: np.ndarray, scores: np.ndarray, types: tuple[str, ...]) -> np.ndarray:
        """The frame's confidences by the score rule, exactly as the file readers compute them."""
        if self._rule is not None:
            conf = self._rule.confidences(boxes, scores, types)
            same = getattr(self._rule, "streak_score", None)
            if same is not None and not self._same_warned:
                self._same_warned = True
                warnings.warn(same_score_message(self.name, same), UserWarning, stacklevel=4)
            return conf
        return scale_confidences("update", range(len(scores)), scores, self.scores)  # scores checked above

    def _update_detections(self, detections):
        xyxy = np.asarray(detections.xyxy, dtype=float).reshape(-1, 4)
        if detections.confidence is None:
            raise ValueError("Detections need a confidence per detection (the model's conf_obs)")
        score = np.asarray(detections.confidence, dtype=float).reshape(-1, 1)
        if detections.class_id is not None:
            dets = np.column_stack([xyxy, score, np.asarray(detections.class_id, dtype=float)])
        else:
            dets = np.column_stack([xyxy, score])
        rows, owners = self._step(dets, None)
        reported = {int(n) for n in rows[:, 4]}
        ids = np.full(len(xyxy), -1, dtype=int)
        for j, trk_id in owners.items():
            number = track_number(trk_id)
            if number in reported:
                ids[j] = number
        out = detections[np.arange(len(xyxy))]  # a copy, never the caller's object
        out.tracker_id = ids
        return out

    @property
    def events(self) -> tuple[HistoryEvent, ...]:
        """The abduced events so far, occurs_at(E, t) in time order (the paper's event sequence);
        ``history=True`` only."""
        self._kept("events")
        return tuple(self._tracker.events)

    @property
    def counts(self) -> FrameCounts:
        """Frames so far, and how many were not proven optimal or hit the frame budget: what
        ``refimpl track`` says on stderr; kept without history too."""
        t = self._tracker
        return FrameCounts(t.frames, t.not_optimal, t.budget_hits, t.over_budget)

    def result(self) -> TrackingResult:
        """Everything so far as ``refimpl.tracking.pipeline.run_sequence`` returns it (rows in MOT order
        frame, id, x, y, w, h, including the interpolated rows of bridged gaps); ``history=True`` only."""
        self._kept("result()")
        return self._tracker.result()

    def interpolated_rows(self) -> np.ndarray:
        """The (n, 6) MOT rows that ``update`` could not report online: bridged gaps and, with
        ``backfill`` / ``fill_hidden``, the earlier frames of a confirmation and filled occlusion episodes;
        ``history=True`` only."""
        self._kept("interpolated_rows()")
        rows = self._tracker.result_rows()
        keep = [(int(r[0]), int(r[1])) not in self._reported for r in rows]
        return rows[np.asarray(keep, dtype=bool)] if len(rows) else rows

    def sequence(self) -> DetectionSequence:
        """The detections given so far as a DetectionSequence (refimpl.io); ``history=True`` only."""
        self._kept("sequence()")
        return DetectionSequence(self.name, tuple(self._frames), self.first_frame, self.image_size, self.fps)

    def scene(self) -> Scene:
        """The scene so far (refimpl.scene.Scene): tracks, events and fluent timelines, for
        refimpl.scene.query / explain and refimpl.scene.plots; ``history=True`` only."""
        self._kept("scene()")
        return scene_from_result(self.sequence(), self.result())
