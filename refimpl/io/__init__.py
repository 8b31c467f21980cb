"""Files in and out: MOTChallenge and KITTI tracking detections, ground truth and results.

One concern per module (each imports only the ones listed before it):

* :mod:`.errors`       - InputFormatError, InputFormatWarning;
* :mod:`.lines`        - reading a file line by line, fields, numbers and the shared row checks;
* :mod:`.seqinfo`      - MOTChallenge seqinfo.ini and the columns det.txt and gt.txt share;
* :mod:`.ground_truth` - GroundTruth, what a ground-truth reader makes of a file;
* :mod:`.detections`   - DetectionFrame / DetectionSequence, what a detection reader makes of a file, and
  the confidence rule;
* :mod:`.stream`       - DetectionStream: detections read from a pipe frame by frame as they arrive;
* :mod:`.event_logs`   - event log lines and files;
* :mod:`.results`      - what the results readers and writers share (the table checks, the atomic write);
* :mod:`.formats`      - one module per file format (:mod:`.formats.mot` MOTChallenge, :mod:`.formats.kitti`
  KITTI tracking: readers and writers of detections, ground truth, results and the pipe, frame
  numbering, image size, frame rate, score rule, distractors, preset key, devkit, benchmark layout)
  and their registry (FORMATS, MOT, KITTI, get_format, registered), with ResultWriter;
* :mod:`.classes`      - a detector's class names and ids (COCO's 80) as the types they are tracked as;
* :mod:`.catalogue`    - the files of the public benchmarks (Benchmark, benchmark_files; the names are
  refimpl.io.datasets.CATALOGUE's), the KITTI splits, load_detections / load_ground_truth and the
  bundled demo.

Every public name is importable from ``refimpl.io`` itself.

Every reader turns a user mistake in a file into ``InputFormatError("<path>:<line>: <reason>")``
(never a numpy/pandas traceback, never a silently dropped row), because a benchmark number
computed from a half-read file is worse than no number.

Formats and the conventions implemented
---------------------------------------
MOTChallenge detections (``det/det.txt``): comma separated ``frame,id,x,y,w,h,score[,...]``,
7 to 10 fields, 1-based frames.  The sequence runs over frames ``1..seqLength`` of
``seqinfo.ini`` (or ``1..max frame`` without one); frames without detections are kept as
empty frames.  Confidence (the paper's integer 0..100): a file holds either probabilities or raw
detector scores, one rule for all its rows, chosen by ``scores=`` or, by default (``"auto"``),
by the share of its scores in [0, 1]:

* ``"probability"`` (e.g. SORT's Faster R-CNN ``det_sort_frcnn.txt``, 0.5..1.0): every score
  must be in [0, 1], else ``file:line`` is an error; ``conf = round(100 * score)``;
* ``"raw"`` (raw ACF scores of the official MOT15 ``det.txt``, about -0.8..139, of which at
  most 1.5 % fall in [0, 1]): ``conf = clip(round(score), 0, 100)``;
* ``"auto"``: probability if every score is in [0, 1], raw if at most half of them are; a file
  in between (more than half, but not all, in [0, 1]) is refused at the first score outside
  [0, 1].  So one stray value never switches the rule silently (a 1.01 among probabilities is
  an error naming its line; it used to turn every confidence of the file into 0 or 1).

``round`` is half up everywhere in this module (``floor(x + 0.5)``), as in ``geometry``.

KITTI PointRCNN detections (AB3DMOT's ``det_02_pointrcnn/<Class>/NNNN.txt``): comma separated
``frame,type,x1,y1,x2,y2,score,h,w,l,x,y,z,rot_y,alpha`` (15 fields, type 1 pedestrian, 2 car,
3 cyclist), 0-based frames.  Only rows of the requested class are kept (filtering by class,
not dropping).  The raw score is a logit (can be negative): ``conf = round(100*sigmoid(score))``.
The files contain a handful of zero-width boxes (``x1 == x2`` at the right image border: 1 in
Car/0000, 4 in Car/0019); by default these are dropped and *recorded* in
``DetectionSequence.dropped`` (with a warning), ``on_degenerate="error"`` raises instead.  A
negative width or height is always an error.  ``image_size`` is (1242, 375), the usual
image_02 size; individual KITTI sequences differ by a few pixels (e.g. 1224x370, 1238x374).
``fps`` is 10 (KITTI's recording rate).

MOTChallenge ground truth, following the MOTChallenge devkit:

* MOT15, 10 fields ``frame,id,x,y,w,h,flag,wx,wy,wz``: a row is a target iff ``flag != 0``;
  there are no distractors (as in the MOT15 evaluation).
* MOT16/17/20, 9 fields ``frame,id,x,y,w,h,flag,class,visibility``: a row is a target iff
  ``flag != 0`` and ``class == 1`` (pedestrian); classes 2 (person on vehicle), 7 (static
  person), 8 (distractor) and 12 (reflection) are distractors: a hypothesis matched to one
  (IoU >= 0.5, Hungarian per frame over all gt rows of the frame) is removed rather than
  counted.  The other classes (3..6, 9..11, 13) are kept as rows that are neither targets nor
  distractors (they take part in that matching, as in the devkit).  Class ids outside 1..13
  are an error.

KITTI tracking ground truth (``label_02/NNNN.txt``), space separated, 17 fields
``frame id type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry``, 0-based frames:

* ``car``: ``Car`` rows are targets, ``Van`` rows distractors;
* ``pedestrian``: ``Pedestrian`` rows are targets, ``Person`` rows (KITTI *tracking* labels
  spell person-sitting ``Person``; ``Person_sitting`` is accepted too) distractors;
* ``cyclist``: ``Cyclist`` rows are targets, no distractors;
* ``DontCare`` rows become ignore regions (``GroundTruth.dontcare``); all other types are
  not loaded.  Type names outside the KITTI vocabulary are an error.
* Not implemented (unlike the official KITTI devkit): no minimum box height (25 px), no
  truncation/occlusion-based ignoring.  Scores are therefore close to, not identical with,
  the official devkit.

MOTChallenge results: ``frame,id,x,y,w,h,1,-1,-1,-1`` sorted by (frame, id), boxes with two
decimals, written atomically (temporary file in the same folder, then ``os.replace``).  Frame
numbers are written as the tracker numbered them, so KITTI results stay 0-based: pass
``first_frame=0`` to ``write_mot_results`` / ``read_mot_results`` for them.

KITTI tracking results (``write_kitti_results`` / ``read_kitti_results``): the label_02 layout
plus a score, ``frame id type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry score``, space
separated, 0-based frames, what TrackEval's Kitti2DBox reads; unknown 3D fields are written as
KITTI's "unknown" values.  ``read_results`` reads either format for evaluation.

Frame numbers above ``MAX_FRAME`` (100 000) are rejected as typos everywhere, since a
sequence is materialised and tracked frame by frame (the longest MOTChallenge / KITTI
sequences have a few thousand frames; 100 000 empty frames already take about 10 s to track).
Box coordinates and sizes beyond ``MAX_COORD`` (1 000 000 pixels in magnitude) are rejected as
typos too: the solvers work on integer pixel boxes (32-bit integers in the fact format).  A
detection box narrower or lower than ``MIN_DET_SIZE`` (0.01 pixels, the precision of a results
file) is an error in MOTChallenge files and a degenerate box (dropped and recorded like a
zero-area box) in KITTI files: the trackers' boxes could not be written back.
"""

from __future__ import annotations

from .errors import InputFormatError, InputFormatWarning
from .lines import (MAX_COORD, MAX_DET_AREA, MAX_DETECTIONS_PER_FRAME, MAX_FRAME, MIN_DET_SIZE, OBJECT_TYPES,
                    data_line_numbers, data_lines)
from .seqinfo import read_seqinfo
from .ground_truth import GroundTruth
from .detections import (DEFAULT_SCORE_RULE, SCORE_RULES, DetectionFrame, DetectionSequence, calibrated_together,
                         resolve_rule)
from .stream import STDIN_NAME, DetectionStream
from .event_logs import event_json_line, event_line, write_event_log, write_event_log_json
from .results import write_text_atomic
from .formats import (FORMAT_NAMES, FORMATS, KITTI, MOT, RESULT_FORMATS, DataFormat, ResultWriter, get_format,
                      read_results, registered, results_formatter, write_results)
from .formats.mot import (format_mot_results, read_mot_detections, read_mot_ground_truth, read_mot_results,
                          stream_mot_detections, write_mot_results)
from .formats.kitti import (KITTI_FPS, KITTI_IMAGE_SIZE, format_kitti_results, read_kitti_detections,
                            read_kitti_ground_truth, read_kitti_results, stream_kitti_detections, write_kitti_results)
from .classes import COCO_CLASS_TYPES, COCO_NAMES, class_id_type, class_type
from .catalogue import (KITTI_TRAIN, KITTI_VAL_SEQMAP, MOT15_ACF, MOT15_SORT6, MOT15_TRAIN, Benchmark,
                        BenchmarkSequence, benchmark_files, bundled_data_dirs, demo_sequence_paths, kitti_val_sequences,
                        load_detections, load_ground_truth, shipped_examples)

__all__ = [
    "InputFormatError", "InputFormatWarning",
    "MAX_COORD", "MAX_DET_AREA", "MAX_DETECTIONS_PER_FRAME", "MAX_FRAME", "MIN_DET_SIZE", "OBJECT_TYPES",
    "data_line_numbers", "data_lines",
    "read_seqinfo",
    "COCO_CLASS_TYPES", "COCO_NAMES", "class_id_type", "class_type",
    "GroundTruth", "read_kitti_ground_truth", "read_mot_ground_truth",
    "DEFAULT_SCORE_RULE", "KITTI_FPS", "KITTI_IMAGE_SIZE", "SCORE_RULES", "DetectionFrame", "DetectionSequence", "read_kitti_detections",
    "calibrated_together", "resolve_rule",
    "read_mot_detections",
    "STDIN_NAME", "DetectionStream", "stream_kitti_detections", "stream_mot_detections",
    "event_json_line", "event_line", "write_event_log", "write_event_log_json",
    "RESULT_FORMATS", "ResultWriter", "format_kitti_results", "format_mot_results", "read_kitti_results",
    "read_mot_results", "read_results", "results_formatter", "write_kitti_results", "write_mot_results",
    "write_results", "write_text_atomic",
    "FORMAT_NAMES", "FORMATS", "KITTI", "MOT", "DataFormat", "get_format", "registered",
    "KITTI_TRAIN", "KITTI_VAL_SEQMAP", "MOT15_ACF", "MOT15_SORT6", "MOT15_TRAIN", "Benchmark", "BenchmarkSequence",
    "benchmark_files", "bundled_data_dirs", "demo_sequence_paths", "kitti_val_sequences", "load_detections",
    "load_ground_truth", "shipped_examples",
]
