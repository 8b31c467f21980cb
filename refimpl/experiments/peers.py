"""Peer trackers on refimpl's detections: SORT, ByteTrack and OC-SORT from the ``trackers`` package,
and BoxMOT's motion-only trackers (ByteTrack, OC-SORT, BoT-SORT, HybridSORT, BoostTrack, Deep OC-SORT,
SFSORT, OccluBoost).

The peers are a second reference beside refimpl's own SORT baseline (which reproduces the
paper's baseline): what a user already runs.  Every peer is one ``Peer`` row of ``PEERS``
(refimpl.tracking.peer_table, re-exported here): the package it comes from, its class, and what
is set beyond the class's constructor defaults.

* ``trackers`` (roboflow; optional extra ``peers``, ``trackers==2.6.1``): the package's *default*
  parameters, except for the two things a caller must say: the frame rate and the confidences.
* BoxMOT (optional extra ``peers-boxmot``, ``boxmot==25.0.0``; it brings torch): the constructor
  defaults, the sequence's frame rate where the constructor takes one (ByteTrack, BoT-SORT), its
  image size where the tracker would read it off the image (SFSORT: :func:`image_extent`), and
  the switches that make a tracker motion-only: no appearance embeddings (ReID) and no
  camera-motion compensation (both need the images, which a detection file does not carry).

Inputs, exactly the detections refimpl's trackers read (``refimpl.io``), for every peer:

* boxes: the ``DetectionFrame.boxes`` (xywh) as xyxy, every frame in order, empty ones included
  (each package is called once per frame, without timestamps: fixed-rate mode);
* scores in 0..1, as a caller of these libraries gives them (refimpl.io.detections.probability_scale):
  a detector's probabilities as they are, logits (KITTI's PointRCNN) through a sigmoid, another
  scale (ACF) by its rank, quantised to 0.01 as refimpl's integer confidences are; one class (0)
  for BoxMOT.  (refimpl's own model reads the evidence rule's confidences: docs/model.md 3.19);
* ``frame_rate``: the sequence's (MOTChallenge ``seqinfo.ini`` frameRate, 10 for KITTI), or the
  packages' 30 when a sequence has none.  ``trackers`` scales its ``lost_track_buffer`` (given
  in frames at 30 fps) by ``frame_rate / 30``, BoxMOT's ByteTrack and BoT-SORT their
  ``track_buffer``; BoxMOT's OC-SORT, HybridSORT and BoostTrack count ``max_age`` in frames.

Output: one results row ``frame, id, x, y, w, h`` for every detection a peer returns with a track
id (id >= 0 in the packages, written as id + 1), the box being the *detection's* box: the
``trackers`` package returns detections; BoxMOT returns track rows with the index of the
detection each was updated with (``det_ind``), and that detection's box is written, so every
peer is scored on the same boxes and differs in which it keeps and how it links them (refimpl's
SORT writes the Kalman state).
"""

from __future__ import annotations

import inspect
import logging
import time
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from typing import Mapping

import numpy as np

from ..core.errors import UserFacingError
from ..core.loader import load
from ..evaluation.evaluate import evaluate_many
from ..io.datasets import TITLES, load_dataset
from ..io.detections import probability_scale
from ..solvers import BASELINE, DEFAULT_BACKEND
from ..tracking.options import TrackerOptions
from ..tracking.pipeline import Setup
from .latency import summarise
from ..tracking.peer_table import PACKAGES, PEERS, Package, Peer  # noqa: F401  (re-exported: the registry)
from .table6 import change, run_benchmark, run_tracker


DEFAULT_FRAME_RATE = 30.0
"""The packages' own default, used for a sequence without a frame rate."""
_UNSET_NAMES = ("self", "args", "kwargs", "reid_model", "reid_weights", "device", "half", "reid_preprocess")
"""Constructor arguments that are no tracker parameter (BoxMOT's ReID model loading)."""


class PeersUnavailable(UserFacingError):
    """An optional peer package is missing (install its extra)."""


@dataclass(frozen=True)
class PeerRun:
    """A peer's results on one sequence and the time its tracking loop took."""

    rows: np.ndarray
    seconds: float
    """CPU seconds of its update calls (refimpl.experiments.latency's boundary)."""
    parameters: Mapping[str, object]
    frame_times: tuple[float, ...] = ()
    """CPU seconds of each frame's update call."""


def peer(name: str) -> Peer:
    if name not in PEERS:
        raise ValueError(f"unknown peer {name!r} (choose from {', '.join(PEERS)})")
    return PEERS[name]


def parse_peers(text: str) -> tuple[str, ...]:
    """``--peers``: a comma-separated list of peer names, or ``all`` (every registered peer);
    ValueError naming the choices otherwise."""
    names = tuple(p.strip() for p in text.split(",") if p.strip())
    if names == ("all",):
        return tuple(PEERS)
    unknown = [p for p in names if p not in PEERS]
    if unknown or not names:
        raise ValueError(f"--peers takes 'all' or a comma-separated list out of {','.join(PEERS)}, got {text!r}")
    return names


def _package(name: str):
    pkg = PACKAGES[name]
    try:
        module = load(pkg.module)  # a registry entry naming its package (refimpl.core.loader)
    except ImportError as exc:
        raise PeersUnavailable(f"the {name} peers need the '{pkg.module}' package ({pkg.requirement}): "
                               f"pip install 'refimpl[{pkg.extra}]'{pkg.note} ({exc})") from None
    return module


def peer_class(name: str):
    entry = peer(name)
    return getattr(_package(entry.package), entry.class_name)


def _constructor_defaults(cls) -> dict:
    """Every constructor parameter with a default, the class's own first, then its bases' (BoxMOT's
    trackers pass ``**kwargs`` on to their base tracker; a ``trackers`` class has no such base)."""
    out: dict = {}
    for klass in cls.__mro__:
        init = klass.__dict__.get("__init__")
        if init is None:
            continue
        for k, p in inspect.signature(init).parameters.items():
            if k not in _UNSET_NAMES and p.default is not inspect.Parameter.empty and k not in out:
                out[k] = p.default
    return out


def peer_parameters(name: str, frame_rate: float | None = None, image_size: tuple[int, int] | None = None,
                    **overrides) -> dict:
    """The parameters a peer runs with: its constructor defaults (read from the signatures), its
    settings, the sequence's frame rate and image size where it takes them, then explicit
    overrides (e.g. for tests)."""
    entry = peer(name)
    cls = peer_class(name)
    params = _constructor_defaults(cls)
    params.update(entry.settings)
    if entry.frame_rate:
        params["frame_rate"] = float(frame_rate) if frame_rate else DEFAULT_FRAME_RATE
    if entry.image_size:
        if image_size is None:
            raise ValueError(f"{entry.class_name} needs the image size (frame_width, frame_height)")
        params["frame_width"], params["frame_height"] = (int(v) for v in image_size)
    for k, v in overrides.items():
        if k not in params:
            raise ValueError(f"{entry.class_name} has no parameter {k!r} (has: {', '.join(params)})")
        params[k] = v
    return params


def _shown_value(v) -> str:
    if isinstance(v, type):
        return v.__name__
    return f"{v:g}" if isinstance(v, float) else str(v)


def describe_parameters(name: str, params: Mapping[str, object]) -> str:
    """'SORTTracker(lost_track_buffer=30, ...)': the parameters that shape the result."""
    entry = peer(name)
    shown = [f"{k}={_shown_value(params[k])}" for k in entry.shown if k in params]
    return f"{entry.class_name}({', '.join(shown)})"


def _xyxy(fr) -> np.ndarray:
    b = np.asarray(fr.boxes, dtype=float).reshape(-1, 4)
    return np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3]])


def _rows(frame: int, ids: np.ndarray, xyxy: np.ndarray) -> np.ndarray:
    """Results rows ``frame, id + 1, x, y, w, h`` of these ids (>= 0) and xyxy boxes."""
    return np.column_stack([np.full(len(ids), float(frame)), ids + 1.0, xyxy[:, 0], xyxy[:, 1],
                            xyxy[:, 2] - xyxy[:, 0], xyxy[:, 3] - xyxy[:, 1]])


def _track_trackers(seq, tracker) -> tuple[list[np.ndarray], list[float]]:
    import supervision as sv
    prepared = []
    for fr in seq.frames:
        # float64: 70 / 100 is then the same double as the package's threshold 0.7 (in float32 it is
        # below it, and a detection of confidence 70 would not reach ByteTrack's ">= 0.7")
        conf = np.asarray(fr.confidences, dtype=np.float64).reshape(-1) / 100.0
        prepared.append((fr.frame, sv.Detections(xyxy=_xyxy(fr), confidence=conf)))
    out, times = [], []
    for frame, dets in prepared:
        t0 = time.process_time()
        res = tracker.update(dets)
        times.append(time.process_time() - t0)
        ids = np.asarray(res.tracker_id, dtype=np.int64).reshape(-1)
        keep = ids >= 0
        if keep.any():
            out.append(_rows(frame, ids[keep], np.asarray(res.xyxy, dtype=float)[keep]))
    return out, times


@contextmanager
def _boxmot_quiet():
    """BoxMOT logs every tracker's construction at INFO on stderr; hold its logger at WARNING while
    a peer runs (restored afterwards: nothing else in the process changes)."""
    log = logging.getLogger("boxmot")
    level = log.level
    log.setLevel(logging.WARNING)
    try:
        yield
    finally:
        log.setLevel(level)


def _track_boxmot(seq, tracker) -> tuple[list[np.ndarray], list[float]]:
    prepared = []
    for fr in seq.frames:
        conf = np.asarray(fr.confidences, dtype=np.float64).reshape(-1, 1) / 100.0
        xyxy = _xyxy(fr)
        prepared.append((fr.frame, np.hstack([xyxy, conf, np.zeros((len(xyxy), 1))])))
    out, times = [], []
    for frame, dets in prepared:
        t0 = time.process_time()
        res = np.asarray(tracker.update(dets)).reshape(-1, 8)  # x1, y1, x2, y2, id, conf, class, det_ind
        times.append(time.process_time() - t0)
        ids, det_ind = res[:, 4].astype(np.int64), res[:, 7].astype(np.int64)
        keep = (ids >= 0) & (det_ind >= 0)
        if keep.any():
            out.append(_rows(frame, ids[keep], dets[det_ind[keep], :4]))
    return out, times


def image_extent(seq) -> tuple[int, int]:
    """The sequence's image size (width, height), or, where it has none, the extent of its boxes
    (the largest x + w and y + h, rounded up; at least 1 x 1)."""
    if getattr(seq, "image_size", None):
        return tuple(int(v) for v in seq.image_size)
    boxes = [np.asarray(f.boxes, dtype=float).reshape(-1, 4) for f in seq.frames]
    every = np.concatenate(boxes) if boxes else np.zeros((0, 4))
    if not len(every):
        return (1, 1)
    far = np.ceil((every[:, :2] + every[:, 2:]).max(axis=0))
    return (max(1, int(far[0])), max(1, int(far[1])))


def run_peer(seq, name: str, **overrides) -> PeerRun:
    """Track a DetectionSequence with a peer; see the module docstring for inputs and outputs."""
    seq = probability_scale(seq)  # the scores as a caller of these libraries gives them (0..1)
    entry = peer(name)
    overrides = dict(overrides)
    frame_rate = overrides.pop("frame_rate", getattr(seq, "fps", None))
    image_size = overrides.pop("image_size", None) or (image_extent(seq) if entry.image_size else None)
    params = peer_parameters(name, frame_rate, image_size, **overrides)
    cls = peer_class(name)
    if entry.package == "trackers":
        out, times = _track_trackers(seq, cls(**params))
    else:
        # only what differs from the constructor's defaults is passed (BoxMOT's ByteTrack refuses
        # its base tracker's det_thresh, which it replaces by track_thresh)
        defaults = _constructor_defaults(cls)
        told = ("frame_rate", "frame_width", "frame_height")  # what the sequence says, default or not
        given = {k: v for k, v in params.items() if k in entry.settings or k in told
                 or k in overrides or defaults.get(k, v) != v}
        with _boxmot_quiet():
            out, times = _track_boxmot(seq, cls(**given))
    rows = np.vstack(out) if out else np.zeros((0, 6))
    rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
    return PeerRun(rows, float(sum(times)), params, tuple(times))


# ---------------------------------------------------------------------------------------
# Side by side: refimpl's baseline, refimpl's abduction tracker and the peers, in one run
# ---------------------------------------------------------------------------------------

COMPARISON_COLUMNS = ("HOTA", "DetA", "AssA", "MOTA", "IDF1", "IDs", "Frag", "FP", "FN", "fps", "p50 ms", "p99 ms")
"""fps, p50 and p99: CPU frames per second and per-frame CPU milliseconds of the tracking work
alone, every tracker timed at the same boundary (refimpl.experiments.latency)."""
PEERS_BEGIN, PEERS_END = "<!-- peers:begin -->", "<!-- peers:end -->"


@dataclass(frozen=True)
class TrackerScore:
    """One tracker on one dataset: the overall scores and the frames/s of its tracking loop."""

    label: str
    overall: Mapping[str, object]
    per_sequence: Mapping[str, Mapping[str, object]]
    frames: int
    seconds: float
    parameters: str = ""
    latency: object = None
    """refimpl.experiments.latency.Latency of its frames (CPU per frame), or None."""


@dataclass(frozen=True)
class Comparison:
    dataset: str
    title: str
    scores: tuple[TrackerScore, ...]
    constants: Mapping[str, int]
    """The constants the abduction tracker ran with beyond model/constants.lp (preset + --const)."""
    options: Mapping[str, str] = field(default_factory=dict)
    """The tracker options it ran with that differ from the defaults (the preset's, then any tracker option flag)."""
    repeat: int = 1
    """How many timed runs per tracker and sequence the speed columns are the fastest of."""


def compare(name: str, data_root: str, peers=tuple(PEERS), backend: str = DEFAULT_BACKEND,
            constants: Mapping[str, int] | None = None, dataset=None, step=None, options=None,
            repeat: int = 1, without_preset: bool = True, setup: Setup | None = None) -> Comparison:
    """Every tracker on the same detections of a dataset, scored by the same evaluator.

    ``repeat`` > 1: every tracker tracks every sequence that many times in all, the repetitions
    interleaved (sequence by sequence, every tracker in turn), and each (tracker, sequence) keeps
    the frame times of its fastest run (least CPU in all): on a shared machine a burst of other
    work then slows one run of one tracker, not one tracker's whole column.  The results and so
    the scores are those of the first run (every run gives the same rows).  ``without_preset``: a row
    of the abduction tracker without its preset too, where the preset changes anything.  ``setup``:
    what the abduction tracker runs with (refimpl.tracking.pipeline.setup_for: a preset's constants,
    options and frame rate), else ``constants`` and ``options`` without a preset."""
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat}")

    for p in peers:
        peer_class(p)  # unknown name or missing package: fail before tracking anything
    dataset = dataset if dataset is not None else load_dataset(name, data_root)
    frames = sum(len(d.frames) for _, d, _ in dataset)
    scores = []
    options = options or TrackerOptions()
    abduction = setup or Setup(backend, tuple((constants or {}).items()), options)
    runs = [(BASELINE, "refimpl baseline (SORT)", Setup(BASELINE)),
            (backend, f"refimpl abduction ({backend})", abduction)]
    if without_preset and (constants or options.changed()):  # what the preset changes: model/constants.lp and default options
        runs.append((backend, f"refimpl abduction ({backend}), no preset", Setup(backend)))
    # per tracker: a function timing one sequence (its CPU seconds per frame), and the frame
    # times kept per sequence (the fastest run's)
    timers: list = []
    kept: list[dict[str, list[float]]] = []
    for tracker, label, run_setup in runs:
        run = run_benchmark(name, data_root, tracker, step, dataset=dataset, setup=run_setup)
        scores.append(TrackerScore(label, run.overall, run.per_sequence, frames, run.seconds))
        by_seq: dict[str, list[float]] = {}
        for t, seq_name, *_ in run.latency:
            by_seq.setdefault(seq_name, []).append(t)
        kept.append(by_seq)
        timers.append(lambda seq, run_setup=run_setup: _refimpl_frame_times(seq, run_setup))
    for p in peers:
        triples, params, by_seq = [], {}, {}
        for seq_name, dets, gt in dataset:
            r = run_peer(dets, p)
            triples.append((seq_name, gt, r.rows))
            by_seq[seq_name] = list(r.frame_times)
            params = r.parameters
            if step:
                step(f"{p} {seq_name}")
        per_seq, overall = evaluate_many(triples)
        if PEERS[p].frame_rate:
            rates = sorted({float(d.fps or DEFAULT_FRAME_RATE) for _, d, _ in dataset})
            params = dict(params, frame_rate="/".join(f"{r:g}" for r in rates))
        package = PEERS[p].package
        scores.append(TrackerScore(f"{p} ({package} {_version(package)})", overall, per_seq, frames, 0.0,
                                   describe_parameters(p, params)))
        kept.append(by_seq)
        timers.append(lambda seq, p=p: list(run_peer(seq, p).frame_times))
    for _ in range(repeat - 1):
        for seq_name, dets, _gt in dataset:
            for timer, by_seq in zip(timers, kept):
                times = timer(dets)
                if sum(times) < sum(by_seq[seq_name]):
                    by_seq[seq_name] = times
    timed_scores = []
    for score, by_seq in zip(scores, kept):
        timed = [(t, seq_name, fr.frame, len(fr)) for seq_name, dets, _ in dataset
                 for t, fr in zip(by_seq[seq_name], dets.frames)]
        timed_scores.append(replace(score, seconds=sum(t for t, *_ in timed), latency=summarise(timed)))
    return Comparison(name, TITLES.get(name, name), tuple(timed_scores), dict(constants or {}), options.changed(),
                      repeat)


def _refimpl_frame_times(seq, setup: Setup) -> list[float]:
    """CPU seconds per frame of one refimpl run (the boundary of run_benchmark's latency)."""
    times: list[float] = []
    run_tracker(seq, setup.backend, frame_times=times, setup=setup)
    return times


def _version(package: str) -> str:
    try:
        from importlib.metadata import version
        return version(PACKAGES[package].module)
    except Exception:  # not installed as a distribution: say so rather than guess
        return "?"


def _pct(v) -> str:
    if v is None:
        return "-"
    v = float(v)
    return "-" if v != v else f"{100 * v:.1f}"


def score_cells(s: TrackerScore) -> list[str]:
    o = s.overall
    return [_pct(o.get("hota")), _pct(o.get("deta")), _pct(o.get("assa")), _pct(o["mota"]), _pct(o["idf1"]),
            str(o["idsw"]), str(o["frag"]), str(o["fp"]), str(o["fn"]),
            f"{s.frames / s.seconds:.0f}" if s.seconds > 0 else "-",
            f"{s.latency.median_ms:.2f}" if s.latency else "-", f"{s.latency.p99_ms:.2f}" if s.latency else "-"]


def comparison_table(c: Comparison) -> str:
    """Markdown: one row per tracker, the peers' parameters and the abduction constants below, and
    every tracker's ID switches against the baseline's."""
    head = "| tracker | " + " | ".join(COMPARISON_COLUMNS) + " |"
    lines = [head, "|---|" + "---:|" * len(COMPARISON_COLUMNS)]
    lines += ["| " + " | ".join([s.label, *score_cells(s)]) + " |" for s in c.scores]
    notes = [f"- {s.label}: `{s.parameters}`" for s in c.scores if s.parameters]
    consts = ", ".join(f"{k}={v}" for k, v in sorted(c.constants.items())) or "none"
    opts = "".join(f"; tracker option {k}={v}" for k, v in sorted(c.options.items()))
    notes.insert(0, f"- refimpl abduction: model/constants.lp with {consts}{opts} (the preset of this format "
                    f"and class, refimpl.tracking.presets, and any --const or tracker option flag); \"no preset\": "
                    f"model/constants.lp and the tracker's default options (--no-preset)")
    base = c.scores[0].overall["idsw"]  # the first row is refimpl's baseline (SORT), the paper's baseline
    notes.insert(1, f"- ID switches against {c.scores[0].label} (the paper's headline metric): "
                    + "; ".join(f"{s.label} {change(base, s.overall['idsw'])}" for s in c.scores[1:]))
    slowest = [f"{s.label} {s.latency.worst_ms:.1f} ms at {s.latency.worst}" for s in c.scores if s.latency]
    if slowest:
        runs = (f", each sequence's fastest of {c.repeat} runs per tracker, the runs interleaved (--repeat)"
                if c.repeat > 1 else "")
        notes.insert(2, "- fps, p50, p99: CPU frames/s and per-frame CPU ms of each tracker's updates alone, measured "
                        f"in this run on this machine (refimpl.experiments.latency){runs}; the slowest frame: "
                        + "; ".join(slowest))
    return "\n".join(lines) + "\n\n" + "\n".join(notes) + "\n"


def per_sequence_table(c: Comparison) -> str:
    """Markdown: one row per sequence, one column per tracker, each cell HOTA / IDF1 / IDs; the last
    column names the tracker with the best IDF1 on that sequence ('-' for a sequence without targets,
    ties named together), and the last row counts, per tracker, the sequences it is best on."""
    head = "| sequence | " + " | ".join(s.label for s in c.scores) + " | best IDF1 |"
    lines = [head, "|---|" + "---:|" * len(c.scores) + "---|"]
    wins = [0] * len(c.scores)
    for seq in c.scores[0].per_sequence:
        rows = [s.per_sequence[seq] for s in c.scores]
        cells = [f"{_pct(r.get('hota'))} / {_pct(r['idf1'])} / {r['idsw']}" for r in rows]
        if rows[0]["num_gt"]:
            top = max(round(float(r["idf1"]), 6) for r in rows)
            best = [k for k, r in enumerate(rows) if round(float(r["idf1"]), 6) == top]
            for k in best:
                wins[k] += 1
            name = ", ".join(c.scores[k].label for k in best)
        else:
            name = "- (no targets)"
        lines.append(f"| {seq} | " + " | ".join(cells) + f" | {name} |")
    lines.append("| best IDF1 on | " + " | ".join(str(w) for w in wins) + " | |")
    return "\n".join(lines) + "\n"


def comparison_report(comparisons, command: str, machine: str, per_sequence: bool = False, note: str = "") -> str:
    """The generated section of docs/peers.md: the command, any note (the peers not run), then a table
    per dataset."""
    out = [f"Command: `{command}`  \nMachine: {machine}." + (f"  \nPeers {note}." if note else "") + "\n"]
    for c in comparisons:
        o = c.scores[0].overall
        out.append(f"### {c.title}\n\n{c.scores[0].frames} frames, {o['num_unique_objects']} targets, "
                   f"{o['num_gt']} target boxes.\n")
        out.append(comparison_table(c))
        if per_sequence:
            out.append(f"Per sequence (HOTA / IDF1 / IDs):\n\n{per_sequence_table(c)}")
    out.append("HOTA, DetA, AssA: TrackEval's HOTA ('-' where refimpl.evaluation.evaluate does not provide it yet); "
               "MOTA, IDF1, IDs (ID switches), Frag, FP, FN: CLEAR MOT / IDF1 via motmetrics, all on the "
               "same rows (refimpl.evaluation.evaluate: distractor and DontCare handling). fps: frames / seconds of the "
               "tracking loop alone (reading files and scoring excluded).\n")
    return "\n".join(out)
