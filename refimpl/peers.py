"""Peer trackers: SORT, ByteTrack and OC-SORT from the ``trackers`` package, on refimpl's detections.

The peers are a second reference beside refimpl's own SORT baseline (which reproduces the
paper's baseline): what a user already runs.  They come from roboflow's ``trackers`` package
(optional extra ``peers``, ``trackers==2.6.1``) and run with the package's *default* parameters,
except for the two things a caller must say: the frame rate and the confidences.

Inputs, exactly the detections refimpl's trackers read (``refimpl.io``):

* boxes: the ``DetectionFrame.boxes`` (xywh) as xyxy, every frame in order, empty ones included
  (the package is called once per frame, without timestamps: fixed-rate mode);
* scores in 0..1: ``confidence / 100``, the integer confidence refimpl's model sees (so a
  threshold means the same for a peer and for the model; it quantises scores to 0.01);
* ``frame_rate``: the sequence's (MOTChallenge ``seqinfo.ini`` frameRate, 10 for KITTI), or the
  package's 30 when a sequence has none.  The package scales its ``lost_track_buffer`` (given
  in frames at 30 fps) by ``frame_rate / 30``.

Output: one results row ``frame, id, x, y, w, h`` for every detection the peer returns with a
track id (id >= 0 in the package, written as id + 1), the box being the *detection's* box (the
package returns detections, not filtered track states; refimpl's SORT writes the Kalman state).
"""

from __future__ import annotations

import inspect
import time
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from .solvers import BASELINE, DEFAULT_BACKEND

PEERS = {"sort": "SORTTracker", "bytetrack": "ByteTrackTracker", "ocsort": "OCSORTTracker"}
"""Peer name (as on the command line) -> class of the ``trackers`` package."""

PEERS_REQUIREMENT = "trackers==2.6.1"
DEFAULT_FRAME_RATE = 30.0
"""The package's own default, used for a sequence without a frame rate."""

_SHOWN_PARAMETERS = ("lost_track_buffer", "frame_rate", "track_activation_threshold", "minimum_consecutive_frames",
                     "minimum_iou_threshold", "high_conf_det_threshold", "direction_consistency_weight", "delta_t",
                     "state_estimator_class")


class PeersUnavailable(Exception):
    """The optional ``trackers`` package is missing (install the ``peers`` extra)."""


@dataclass(frozen=True)
class PeerRun:
    """A peer's results on one sequence and the time its tracking loop took."""

    rows: np.ndarray
    seconds: float
    parameters: Mapping[str, object]


def _package():
    try:
        import trackers
    except ImportError as exc:
        raise PeersUnavailable(f"the peer trackers need the 'trackers' package ({PEERS_REQUIREMENT}): "
                               f"pip install 'refimpl[peers]' ({exc})") from None
    return trackers


def peer_class(name: str):
    if name not in PEERS:
        raise ValueError(f"unknown peer {name!r} (choose from {', '.join(PEERS)})")
    return getattr(_package(), PEERS[name])


def peer_parameters(name: str, frame_rate: float | None = None, **overrides) -> dict:
    """The parameters a peer runs with: the package's defaults (read from its signature), the
    sequence's frame rate, then explicit overrides (e.g. for tests)."""
    sig = inspect.signature(peer_class(name).__init__)
    params = {k: p.default for k, p in sig.parameters.items()
              if k != "self" and p.default is not inspect.Parameter.empty}
    params["frame_rate"] = float(frame_rate) if frame_rate else DEFAULT_FRAME_RATE
    for k, v in overrides.items():
        if k not in params:
            raise ValueError(f"{PEERS[name]} has no parameter {k!r} (has: {', '.join(params)})")
        params[k] = v
    return params


def describe_parameters(name: str, params: Mapping[str, object]) -> str:
    """'SORTTracker(lost_track_buffer=30, ...)': the parameters that shape the result."""
    shown = []
    for k in _SHOWN_PARAMETERS:
        if k in params:
            v = params[k]
            shown.append(f"{k}={v.__name__ if isinstance(v, type) else (f'{v:g}' if isinstance(v, float) else v)}")
    return f"{PEERS[name]}({', '.join(shown)})"


def run_peer(seq, name: str, **overrides) -> PeerRun:
    """Track a DetectionSequence with a peer; see the module docstring for inputs and outputs."""
    import supervision as sv

    overrides = dict(overrides)
    params = peer_parameters(name, overrides.pop("frame_rate", getattr(seq, "fps", None)), **overrides)
    tracker = peer_class(name)(**params)
    prepared = []
    for fr in seq.frames:
        b = np.asarray(fr.boxes, dtype=float).reshape(-1, 4)
        xyxy = np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3]])
        # float64: 70 / 100 is then the same double as the package's threshold 0.7 (in float32 it is
        # below it, and a detection of confidence 70 would not reach ByteTrack's ">= 0.7")
        conf = np.asarray(fr.confidences, dtype=np.float64).reshape(-1) / 100.0
        prepared.append((fr.frame, sv.Detections(xyxy=xyxy, confidence=conf)))
    out = []
    t0 = time.perf_counter()
    for frame, dets in prepared:
        res = tracker.update(dets)
        ids = np.asarray(res.tracker_id, dtype=np.int64).reshape(-1)
        keep = ids >= 0
        if keep.any():
            box = np.asarray(res.xyxy, dtype=float)[keep]
            out.append(np.column_stack([np.full(int(keep.sum()), float(frame)), ids[keep] + 1.0,
                                        box[:, 0], box[:, 1], box[:, 2] - box[:, 0], box[:, 3] - box[:, 1]]))
    seconds = time.perf_counter() - t0
    rows = np.vstack(out) if out else np.zeros((0, 6))
    rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
    return PeerRun(rows, seconds, params)


# ---------------------------------------------------------------------------------------
# Side by side: refimpl's baseline, refimpl's abduction tracker and the peers, in one run
# ---------------------------------------------------------------------------------------

COMPARISON_COLUMNS = ("HOTA", "DetA", "AssA", "MOTA", "IDF1", "IDs", "Frag", "FP", "FN", "fps")
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


@dataclass(frozen=True)
class Comparison:
    dataset: str
    title: str
    scores: tuple[TrackerScore, ...]
    constants: Mapping[str, int]
    """The constants the abduction tracker ran with beyond model/constants.lp (preset + --const)."""
    options: Mapping[str, str] = field(default_factory=dict)
    """The tracker options it ran with that differ from the defaults (the preset's, then any tracker option flag)."""


def compare(name: str, data_root: str, peers=tuple(PEERS), backend: str = DEFAULT_BACKEND,
            constants: Mapping[str, int] | None = None, dataset=None, step=None, options=None) -> Comparison:
    """Every tracker on the same detections of a dataset, scored by the same evaluator."""
    from .evaluate import evaluate_many
    from .datasets import TITLES, load_dataset
    from .table6 import run_benchmark

    for p in peers:
        peer_class(p)  # unknown name or missing package: fail before tracking anything
    dataset = dataset if dataset is not None else load_dataset(name, data_root)
    frames = sum(len(d.frames) for _, d, _ in dataset)
    scores = []
    from .options import TrackerOptions
    options = options or TrackerOptions()
    runs = [(BASELINE, "refimpl baseline (SORT)", None, None),
            (backend, f"refimpl abduction ({backend})", dict(constants or {}), options)]
    if constants or options.changed():  # what the preset changes: model/constants.lp and default options
        runs.append((backend, f"refimpl abduction ({backend}), no preset", {}, TrackerOptions()))
    for tracker, label, consts, opts in runs:
        run = run_benchmark(name, data_root, tracker, step, dataset=dataset, constants=consts, options=opts)
        scores.append(TrackerScore(label, run.overall, run.per_sequence, frames, run.seconds))
    for p in peers:
        triples, seconds, params = [], 0.0, {}
        for seq_name, dets, gt in dataset:
            r = run_peer(dets, p)
            triples.append((seq_name, gt, r.rows))
            seconds += r.seconds
            params = r.parameters
            if step:
                step(f"{p} {seq_name}")
        per_seq, overall = evaluate_many(triples)
        rates = sorted({float(d.fps or DEFAULT_FRAME_RATE) for _, d, _ in dataset})
        params = dict(params, frame_rate="/".join(f"{r:g}" for r in rates))
        scores.append(TrackerScore(f"{p} (trackers {_version()})", overall, per_seq, frames, seconds,
                                   describe_parameters(p, params)))
    return Comparison(name, TITLES.get(name, name), tuple(scores), dict(constants or {}), options.changed())


def _version() -> str:
    try:
        from importlib.metadata import version
        return version("trackers")
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
            f"{s.frames / s.seconds:.0f}" if s.seconds > 0 else "-"]


def comparison_table(c: Comparison) -> str:
    """Markdown: one row per tracker, the peers' parameters and the abduction constants below."""
    head = "| tracker | " + " | ".join(COMPARISON_COLUMNS) + " |"
    lines = [head, "|---|" + "---:|" * len(COMPARISON_COLUMNS)]
    lines += ["| " + " | ".join([s.label, *score_cells(s)]) + " |" for s in c.scores]
    notes = [f"- {s.label}: `{s.parameters}`" for s in c.scores if s.parameters]
    consts = ", ".join(f"{k}={v}" for k, v in sorted(c.constants.items())) or "none"
    opts = "".join(f"; tracker option {k}={v}" for k, v in sorted(c.options.items()))
    notes.insert(0, f"- refimpl abduction: model/constants.lp with {consts}{opts} (the preset of this format "
                    f"and class, refimpl.presets, and any --const or tracker option flag); \"no preset\": "
                    f"model/constants.lp and the tracker's default options (--no-preset)")
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


def comparison_report(comparisons, command: str, machine: str, per_sequence: bool = False) -> str:
    """The generated section of docs/peers.md: the command, then a table per dataset."""
    out = [f"Command: `{command}`  \nMachine: {machine}.\n"]
    for c in comparisons:
        o = c.scores[0].overall
        out.append(f"### {c.title}\n\n{c.scores[0].frames} frames, {o['num_unique_objects']} targets, "
                   f"{o['num_gt']} target boxes.\n")
        out.append(comparison_table(c))
        if per_sequence:
            out.append(f"Per sequence (HOTA / IDF1 / IDs):\n\n{per_sequence_table(c)}")
    out.append("HOTA, DetA, AssA: TrackEval's HOTA ('-' where refimpl.evaluate does not provide it yet); "
               "MOTA, IDF1, IDs (ID switches), Frag, FP, FN: CLEAR MOT / IDF1 via motmetrics, all on the "
               "same rows (refimpl.evaluate: distractor and DontCare handling). fps: frames / seconds of the "
               "tracking loop alone (reading files and scoring excluded).\n")
    return "\n".join(out)
