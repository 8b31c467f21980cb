"""Online abduction tracker: the paper's Algorithm 1 (Online_Abduction), one frame at a time.

For each time point: observe detections (VO_t), Kalman-predict every track, active and halted
(P_t), compute the matching likelihood (ML_t, IoU x 100000), build the frame problem with the
event history, abduce the best hypothesis with a backend, and apply it: assign updates the
filter, start creates a track (ids handed out here, in detection order), halt keeps the track
alive but unobserved, resume re-attaches a detection to the same identity, end removes it,
ignores drop.  Events are logged as occurs_at(E, t) with track ids.

What the results file holds (refimpl decision; measurements in docs/tracking.md):
- a track's box is written for a frame in which a detection was assigned to it or resumed it,
  once the track is confirmed by SORT's online rule: hit_streak >= min_hits consecutive
  observations, or the first min_hits frames; WHICH box is the tracker option ``written_box``
  (WrittenBox): the updated Kalman state (FILTERED, SORT's), the detection (DETECTION, ByteTrack's), or
  per coordinate the one the sequence shows closer (AUTO, tracking.written_box; presets: docs/peers.md);
- a resumed track must be re-confirmed the same way, unless the gap was short (<= the tracker
  option ``bridge_gap`` frames) and the resuming detection confident (>= ``bridge_conf``): then it
  stays confirmed and its unobserved frames are filled by linear interpolation between the boxes
  around the gap (the paper's commonsense interpolation of a hidden object's position; the presets
  bridge a second, docs/tracking.md);
- a halted track writes nothing for its halted frames otherwise;
- with the tracker option ``fill_hidden`` (refimpl.tracking.options), an occlusion episode of a confirmed
  track (halted with hides_behind right after its last observed frame, resumed with
  unhides_from_behind) of at most fill_hidden frames is filled by the same interpolation once the
  resumed track is confirmed again (min_hits updates): the paper's interpolated position of a
  hidden object, written; a track hidden again before that chains the episodes, and the one
  re-confirmation fills every one whose rows are not final yet;
- with the tracker option ``backfill`` (refimpl.tracking.options), a track that becomes confirmed also
  writes the earlier frames of the streak that confirmed it (up to min_hits frames back: a new
  track's first frame and its first min_hits - 1 updates; SORT never writes them): a frame's rows
  are then final min_hits frames late instead of bridge_gap.
Why each rule is as it is, measured on MOT15 and KITTI: docs/tracking.md.
"""

from __future__ import annotations

import math
from itertools import chain
from dataclasses import dataclass, field
from time import perf_counter
from typing import Callable, Mapping

import numpy as np

from ..core.confidence import RANK_PRIOR, OnlineRank
from ..core.constants import default_constants, resolve_constants
from ..core.geometry import integer_box_array, integer_boxes
from ..knowledge.event_table import explaining
from ..core.hypothesis import Hypothesis, parse_action
from .motion import BoxKalman, column_medians  # noqa: F401  (column_medians: the scene's velocity; re-exported)
from .bounds import PredictionBounds
from .gate import MatchGate
from .likelihood import matching_likelihood, size_gate
from .options import TrackerOptions, WrittenBox
from .written_box import WrittenBoxLearner
from ..core.ranges import check_ranges, integer_boxes_fit
from ..solvers import Solver
from ..core.spec import Detection, FrameProblem, HistoryEvent, Term, TrackPrediction, is_symbol, track_number

DEFAULT_MIN_HITS = 3
_RESUMING = frozenset(e.name for e in explaining("resume"))
_STARTING = frozenset(e.name for e in explaining("start"))
_UNHIDING = frozenset(e.name for e in explaining("resume") if e.unhides)
_HIDING = frozenset(e.name for e in explaining("halt") if e.hides)

FrameObserver = Callable[[FrameProblem, Hypothesis], None]


def _all_symbols(types) -> bool:
    """Whether every detection type is a symbol (FrameProblem's test), each distinct one asked once."""
    try:
        kinds = set(types)
    except TypeError:  # unhashable: not a str; the constructor names it
        return False
    return all(map(is_symbol, kinds))


class ResultSink:
    """Where a streaming tracker puts what it has decided (see AbductionTracker's ``sink``)."""

    def rows(self, rows: np.ndarray) -> None:
        """(n, 6) results rows of whole frames that can receive no more rows, sorted by (frame, id)."""

    def events(self, events: tuple[HistoryEvent, ...]) -> None:
        """The events of the frame just decided, in log order."""


@dataclass
class _Track:
    """A motion track's mutable state inside the tracker (not part of the public data flow)."""

    id: str
    type: str
    kalman: BoxKalman
    state: str = "active"
    observed: dict[int, np.ndarray] = field(default_factory=dict)  # frame -> box written for it
    gaps: list[tuple[int, int]] = field(default_factory=list)  # (last observed frame, resumed frame)
    history: list[HistoryEvent] = field(default_factory=list)
    halted: dict[int, np.ndarray] = field(default_factory=dict)  # frame -> predicted box while halted
    ended_at: int | None = None
    predicted: np.ndarray | None = None
    streak: int = 0  # consecutive observed frames, SORT's hit_streak (0 at birth)
    bridged: bool = False  # resumed after a short gap while confirmed: stays confirmed
    episodes: list[tuple[int, int]] = field(default_factory=list)  # occlusion episodes to fill once re-confirmed (fill_hidden)
    confirmed: set[int] = field(default_factory=set)  # observed frames that are written
    at_rest: np.ndarray | None = None  # started with the scene's motion: its first box, until observed again
    hits: int = 0  # detections taken (write_evidence)
    evidence: int = 0  # the sum of their confidences
    evident: bool = False  # its mean confidence has reached write_evidence: it may be written
    best: float = float("-inf")  # the highest score of a detection it has taken (write_peak)
    waited: bool = False  # it has been observed peak_wait frames in a row: write_peak holds it back no more


@dataclass(frozen=True)
class TrackRecord:
    """One motion track as abduced: where it was observed and where it was halted (unobserved)."""

    id: str
    type: str
    observed: tuple[tuple[int, tuple[float, float, float, float]], ...]
    """(frame, box) for every frame a detection was assigned to it or resumed it."""
    halted: tuple[tuple[int, tuple[float, float, float, float]], ...]
    """(frame, Kalman-predicted box) for every frame it was halted."""
    ended_at: int | None
    """The frame of its end action, or None if it was alive at the end of the sequence."""


@dataclass(frozen=True)
class TrackingResult:
    """Motion tracks and the event sequence explaining them: <H^events, MT>."""

    rows: np.ndarray
    """(n, 6) results rows frame, track number, x, y, w, h (MOTChallenge order)."""
    events: tuple[HistoryEvent, ...]
    tracks: tuple[TrackRecord, ...]
    frames: int
    not_optimal_frames: int
    solve_ms: float
    budget_hits: int = 0
    """Frames whose search the frame budget stopped (their best answer found so far, not proven
    optimal; counted in not_optimal_frames too)."""
    over_budget: int = 0
    """Frames whose step took longer than the frame budget, whatever their answer (wall-clock; the
    fast path and the tracker's own work are not interrupted)."""


def _det_id(i: int) -> str:
    return f"det_{i}"


def _trk_number(trk_id: str) -> int:
    return track_number(trk_id)


class AbductionTracker:
    """Algorithm 1 with one solver backend; deterministic for a deterministic backend."""

    def __init__(self, solver: Solver, constants: Mapping[str, int] | None = None,
                 min_hits: int = DEFAULT_MIN_HITS, time_limit: float | None = None,
                 compact_history: bool = True, sink: ResultSink | None = None, keep_records: bool = True,
                 frame_budget: float | None = None, options: TrackerOptions = TrackerOptions(),
                 pixel_scale: float = 1.0):
        """``options``: the tracker options (refimpl.tracking.options.TrackerOptions, which parses
        and checks them; the module docstring says what the writing ones write; docs/tracking.md
        measures them).

        ``sink``: results rows and events are handed to it as soon as they are final (a frame's
        rows once no later frame can add any: bridged-gap interpolation reaches back at most
        the option ``bridge_gap`` frames, a backfilled confirmation min_hits; ``delay``), instead of being kept; with ``keep_records=False`` as well, the
        tracker forgets everything a later frame does not need (finished tracks, all but the last
        observed box of a live one), so its memory does not grow with the sequence; then
        :meth:`track_records` is empty.  :meth:`finish` hands over the rest.

        ``frame_budget``: milliseconds a frame may take (wall-clock, from building its problem to
        the solver's answer; None: no budget).  The solver gets what is left of it as its
        ``budget`` (refimpl.solvers: the search stops there with its best answer so far, flagged
        not proven optimal; the fast path's answer, exact and not interrupted, is kept however
        late), so a frame the fast path answers gets the same answer with any budget.  Counted:
        ``budget_hits`` (frames the budget stopped), ``over_budget`` (frames that took longer)."""
        self.solver = solver
        self.pixel_scale = float(pixel_scale)
        """From the image's pixels to the model's working pixels (refimpl.tracking.camera.working_scale):
        the facts' boxes and the image-size constants are in working pixels."""
        self.options = options
        """The tracker options (refimpl.tracking.options), read where they decide."""
        self.constants = tuple((constants or {}).items())
        self.constant_map = dict(self.constants)
        self.bounds = PredictionBounds.of(self.constant_map.get("img_width", 0),
                                          self.constant_map.get("img_height", 0), self.pixel_scale)
        """Where a prediction may lie (refimpl.tracking.bounds): the image, 1500 px a side where
        unknown, extended by one size on every side."""
        self.min_hits = min_hits
        self.time_limit = time_limit
        self.compact_history = compact_history
        self.tracks: dict[str, _Track] = {}
        self.finished: list[_Track] = []
        self.next_number = 1
        self.events: list[HistoryEvent] = []
        self.owners: dict[int, str] = {}
        """The last frame's detection index -> the track it was assigned to, resumed or started."""
        self.frames = 0
        self.not_optimal = 0
        self.solve_ms = 0.0
        self.frame_budget = check_frame_budget(frame_budget)
        self.budget_hits = 0
        self.over_budget = 0
        self.sink = sink
        self.keep_records = keep_records or sink is None
        self._pending: dict[int, list[list[float]]] = {}  # frame -> rows not yet handed to the sink
        self._integer_boxes: np.ndarray | None = None  # the last problem's integer boxes, detections first
        self._latest_event = -math.inf  # the time of the latest event logged
        self._learner = WrittenBoxLearner() if options.written_box is WrittenBox.AUTO else None
        self._gate = (MatchGate(options.learned_gate, self.constant_map.get("iou_thresh", default_constants()["iou_thresh"]))
                      if options.learned_gate else None)
        """The learned iou_thresh (option learned_gate, refimpl.tracking.gate); None: the constant."""
        self._likelihood: tuple[np.ndarray, dict[str, int]] | None = None  # the last problem's ML, track rows
        self._ranker = OnlineRank(prior=RANK_PRIOR)
        self.delay = max(self.options.bridge_gap, min_hits + self.options.backfill_gap if self.options.backfill else 0,
                         self.options.fill_hidden + min_hits if self.options.fill_hidden else 0)
        """How many frames late a frame's rows are final (bridged gaps, filled episodes, backfills)."""
        self._backfill_span = self.delay if self.options.write_evidence or self.options.backfill_gap else min_hits
        """How far back a confirmation writes its streak: min_hits (SORT's streak), or with
        write_evidence or backfill_gap as far as rows are not final yet (the frames before the
        evidence sufficed, the frames before a gap)."""

    # -- step 1: the problem specification ---------------------------------------------------
    def frame_problem(self, frame: int, boxes: np.ndarray, confidences: np.ndarray, types: tuple[str, ...]) -> FrameProblem:
        """Predict every track and build <VO_t, P_t, ML_t> with the event history of live tracks."""
        tracks = list(self.tracks.values())
        boxes_now, ok = BoxKalman.predict_box_array([t.kalman for t in tracks], self.options.hold_hidden)  # one batch
        for k in np.flatnonzero(~ok).tolist():
            boxes_now[k] = self._restarted(tracks[k])
        predicted = self.bounds.boxes(boxes_now)
        for k, t in enumerate(tracks):
            t.predicted = predicted[k]
        det_ids = [_det_id(i) for i in range(len(boxes))]
        conf = [int(c) for c in np.asarray(confidences).reshape(-1).tolist()]
        scale = self.pixel_scale
        working, working_predicted = (boxes, predicted) if scale == 1.0 else (boxes * scale, predicted * scale)
        rounded = self._integer_boxes = integer_box_array(working, working_predicted)  # both in one pass
        if rounded is None:  # a value integer_box must convert (or refuse) on its own
            det_boxes, track_boxes = integer_boxes(working), integer_boxes(working_predicted)
        else:
            every = list(map(tuple, rounded.tolist()))
            det_boxes, track_boxes = every[:len(boxes)], every[len(boxes):]
        detections = tuple(Detection(det_ids[i], types[i], conf[i], b) for i, b in enumerate(det_boxes))
        predictions = tuple(TrackPrediction(t.id, t.type, t.state, b) for t, b in zip(tracks, track_boxes))
        iou: tuple[tuple[str, str, int], ...] = ()
        if len(tracks) and len(boxes):
            # a track's last observed frame is the last key of its observed frames (inserted in increasing
            # order as the frames come; _forget keeps them sorted)
            gated, speeds = self.options.size_gate, self.options.uncertain_speed
            seen = [(k, frame - f, t.observed[f]) for k, t in enumerate(tracks) if t.observed and (gated or (
                    speeds and t.state == "halted")) for f in (next(reversed(t.observed)),)]
            last_seen = [(k, b) for k, _, b in seen if tracks[k].state == "halted"] if speeds else []
            at_rest = [(k, t.at_rest) for k, t in enumerate(tracks) if t.at_rest is not None]
            if scale != 1.0:  # the likelihood in working pixels too (its scene shift rounds to 0.1 px)
                last_seen = [(k, b * scale) for k, b in last_seen]
                at_rest = [(k, b * scale) for k, b in at_rest]
            once = [(k, t.observed[f] * scale, frame - f) for k, t in enumerate(tracks) if t.hits == 1
                    and t.state == "active" for f in t.observed] if self.options.new_speed else []  # started last frame
            ml = matching_likelihood(working_predicted, working, [t.state for t in tracks], at_rest, last_seen,
                                     self.options.scene_shift, once, self.options.new_speed, self.options.size_change or math.inf)
            if gated:  # in the image's pixels, as the boxes observed (a ratio of areas)
                size_gate(ml, boxes, seen, gated, self.options.size_change or 1.0)
            if self._gate is not None:  # the assignments' likelihoods are counted once the hypothesis is in
                self._likelihood = (ml, {t.id: k for k, t in enumerate(tracks)})
            ks, js = np.nonzero(ml > 0)  # row-major: by track, then by detection
            track_ids = [t.id for t in tracks]  # the facts' tuples made by zip (a crowd has thousands)
            iou = tuple(zip(map(track_ids.__getitem__, ks.tolist()), map(det_ids.__getitem__, js.tolist()),
                            ml[ks, js].tolist()))
        history = tuple(chain.from_iterable(t.history for t in tracks))
        # Built here, the problem holds what FrameProblem checks by construction (unique ids made here;
        # integer boxes with w, h >= 1; one IoU fact per pair, 0..100000; track types and states from
        # earlier frames) but what the caller gives: the constants (checked on the first frame), the
        # detections' types and confidences, and the frame number (after every event of the history).
        # Where one of those fails, the constructor raises its one-line error naming the first offender.
        checked = not (self.frames and _all_symbols(types) and (not conf or 0 <= min(conf) and max(conf) <= 100)
                       and (self._latest_event < frame or all(e.time < frame for e in history)))
        make = FrameProblem if checked else FrameProblem.unchecked
        return make(time=frame, detections=detections, tracks=predictions, iou=iou, constants=self._frame_constants(),
                    history=history)

    def _frame_constants(self) -> tuple[tuple[str, int], ...]:
        """The run's constants, with the learned gate as iou_thresh where it differs from the constant."""
        gate = self._gate.gate() if self._gate is not None else None
        if gate is None or gate == self._gate.preset:
            return self.constants
        return (*((k, v) for k, v in self.constants if k != "iou_thresh"), ("iou_thresh", gate))

    @staticmethod
    def _restarted(trk: _Track) -> np.ndarray:
        """The prediction of a track whose filter's state degenerated (BoxKalman.predict would raise
        InvalidPrediction): the filter restarts, motionless, at the last observed box."""
        trk.kalman = BoxKalman(trk.observed[max(trk.observed)], trk.kalman.velocity_noise,
                               area_noise=trk.kalman.area_noise, size_change=trk.kalman.size_change)
        return trk.kalman.predict()

    # -- steps 2-3 and the update ------------------------------------------------------------
    def step(self, frame: int, boxes: np.ndarray, confidences: np.ndarray, types: tuple[str, ...],
             observer: FrameObserver | None = None, scores: np.ndarray | None = None) -> Hypothesis:
        """Track one frame: its problem, the solver's hypothesis, the update.  ``scores``: the
        detector's own scores, whose ranks among the scores seen so far the option write_peak reads
        (the confidences' where not given)."""
        started = perf_counter()
        boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
        if self.options.write_peak:  # the scores seen so far, whose order write_peak reads
            self._scores = np.asarray(confidences if scores is None else scores, dtype=float).reshape(-1)
            self._ranker.counts(self._scores)  # seen: the ranks write_peak reads (_confirm)
        problem = self.frame_problem(frame, boxes, confidences, types)
        rounded = self._integer_boxes  # the frame's integer boxes: their range tests on the array
        checked = rounded is not None and integer_boxes_fit(rounded, len(boxes),
                                                            resolve_constants(problem).get("hide_overlap", 100))
        check_ranges(problem, f"frame {frame}", boxes_checked=checked)
        if self.frame_budget is None:
            hyp = self.solver.solve(problem, time_limit=self.time_limit)
        else:
            left = max(0.0, self.frame_budget / 1000.0 - (perf_counter() - started))
            hyp = self.solver.solve(problem, time_limit=self.time_limit, budget=left)  # type: ignore[call-arg]
            # the budget stopped the search where it came before the time limit
            self.budget_hits += not hyp.optimal and (self.time_limit is None or left < self.time_limit)
        if observer is not None:
            observer(problem, hyp)
        self.frames += 1
        self.not_optimal += not hyp.optimal
        self.solve_ms += hyp.solve_ms
        self._apply(frame, boxes, np.asarray(confidences), types, hyp)
        if self.frame_budget is not None:
            self.over_budget += (perf_counter() - started) * 1000.0 > self.frame_budget
        if self.sink is not None:
            self._flush(frame - self.delay)
            if not self.keep_records:
                self._forget()
        return hyp

    def _flush(self, upto: int | None) -> None:
        """Hand the rows of every pending frame <= upto (None: all) to the sink, by (frame, id)."""
        done = sorted(f for f in self._pending if upto is None or f <= upto)
        if done:
            rows = np.array([r for f in done for r in sorted(self._pending.pop(f), key=lambda r: r[1])],
                            dtype=float).reshape(-1, 6)
            self.sink.rows(rows)

    def _forget(self) -> None:
        """Drop what no later frame reads: finished tracks, old boxes, gaps, halted predictions."""
        self.finished.clear()
        self.events.clear()
        keep = self._backfill_span + 1 if self.options.backfill or self.options.fill_hidden else 1  # the streak's boxes
        for trk in self.tracks.values():
            recent = sorted(trk.observed)[-keep:]
            if trk.episodes:  # every box from the first pending occlusion episode on
                recent = sorted({*recent, *(f for f in trk.observed if f >= trk.episodes[0][0])})
            if len(trk.observed) > len(recent):
                trk.observed = {f: trk.observed[f] for f in recent}
            # which of the kept frames are already written: a later confirmation (backfill, an
            # occlusion episode) walks back over exactly these, and must not write one twice
            trk.confirmed &= set(recent)
            trk.gaps.clear()
            trk.halted.clear()

    def finish(self) -> None:
        """Hand every remaining row to the sink (streaming); call after the last frame."""
        if self.sink is not None:
            self._flush(None)

    def _apply(self, frame: int, boxes: np.ndarray, confidences: np.ndarray, types: tuple[str, ...],
               hyp: Hypothesis) -> None:
        index = {_det_id(j): j for j in range(len(boxes))}
        # the actions parsed once, by name, in sorted atom order (what Hypothesis.assignments,
        # .resumes, ... return one name at a time)
        acts: dict[str, list[tuple[str, ...]]] = {}
        for atom in hyp.actions:
            name, args = parse_action(atom)
            acts.setdefault(name, []).append(args)
        assignments, resumes = acts.get("assign", ()), acts.get("resume", ())
        event_terms = hyp.event_terms
        self.owners = {index[d]: t for t, d in (*assignments, *resumes)}
        # the scene's motion before this frame's updates change the velocities; only a start reads it
        scene = self._scene_velocity(frame) if self.options.scene_velocity and "start" in acts else None
        # every assigned track's filter corrected in one batch (the same bits as one by one), then
        # each track's streak and rows in sorted atom order: deterministic
        assigned = [self.tracks[trk_id] for trk_id, _ in assignments]
        detected = boxes[[index[det_id] for _, det_id in assignments]]  # their boxes, (n, 4)
        # wander_noise (docs/tracking.md 'A detector whose boxes wander'): where the gate this frame's
        # problem carried is lowered, a detection's centre is taken to scatter by a share of its box
        wander = self.options.wander_noise / 100 if self._gate is not None and self._gate.lowered() else 0.0
        states = BoxKalman.update_many([trk.kalman for trk in assigned], detected, wander)  # as floats, or None
        if self._gate is not None and assignments:
            ml, rows = self._likelihood
            self._gate.add(int(ml[rows[trk_id], index[det_id]]) for trk_id, det_id in assignments)
        for k, (trk, (_, det_id)) in enumerate(zip(assigned, assignments)):
            self._observed(trk, frame, detected[k], int(confidences[index[det_id]]), None if states is None else states[k],
                           index[det_id])
        unhidden = {args[0] for name, args in event_terms
                    if name in _UNHIDING} if self.options.fill_hidden and resumes else set()
        for trk_id, det_id in resumes:
            trk, j = self.tracks[trk_id], index[det_id]
            last = max(trk.observed)
            gap = frame - last - 1
            trk.bridged = (gap <= self.options.bridge_gap and int(confidences[j]) >= self.options.bridge_conf
                           and last in trk.confirmed)
            # an occlusion episode of a confirmed track, or one more of a track re-confirming after one
            hidden = (not trk.bridged and (last in trk.confirmed or bool(trk.episodes))
                      and gap <= self.options.fill_hidden and trk_id in unhidden and self._hid_after(trk, last))
            trk.episodes = [*(e for e in trk.episodes if e[0] >= frame - self.delay), (last, frame)] if hidden else []
            if trk.bridged:
                trk.gaps.append((last, frame))
            trk.state = "active"
            self._observe(trk, frame, boxes[j], int(confidences[j]), j, resumed=True, wander=wander)
            if trk.bridged and self.sink is not None:
                self._pend_gap(trk, last, frame)
        for (trk_id,) in acts.get("halt", ()):
            self.tracks[trk_id].state = "halted"
            self.tracks[trk_id].at_rest = None
        # start: new identities in detection order, so ids do not depend on atom sorting
        new_ids: dict[str, str] = {}
        for j in sorted(index[d] for (d,) in acts.get("start", ())):
            trk_id = f"trk_{self.next_number}"
            self.next_number += 1
            kalman = BoxKalman(boxes[j], self.options.velocity_noise, scene, self.options.area_noise,
                               self.options.size_change)
            trk = _Track(trk_id, types[j], kalman, at_rest=None if scene is None else boxes[j].copy())
            trk.observed[frame] = self._written(trk_id, frame, kalman, boxes[j])
            trk.hits, trk.evidence = 1, int(confidences[j])
            if self.options.write_peak:
                trk.best = float(self._scores[j])
            self._confirm(trk, frame)
            self.tracks[trk_id] = trk
            new_ids[_det_id(j)] = trk_id
            self.owners[j] = trk_id
        frame_events: list[HistoryEvent] = []
        for name, args in event_terms:
            event = Term(name, tuple(Term(new_ids.get(a, a)) for a in args))
            logged = HistoryEvent(event, frame)
            self.events.append(logged)
            self._latest_event = max(self._latest_event, frame)  # no history event is later
            frame_events.append(logged)
            owner = self.tracks.get(event.args[0].name)
            if owner is None:
                continue
            if self.compact_history and name in _RESUMING:
                # a resume leaves every fluent of the track at its initial value (visible,
                # unclipped, hidden by none, in view): only its start event still matters
                owner.history = [e for e in owner.history if e.event.name in _STARTING]
            else:
                owner.history.append(logged)
        if self.sink is not None and frame_events:
            self.sink.events(tuple(frame_events))
        for (trk_id,) in acts.get("end", ()):
            trk = self.tracks.pop(trk_id)
            trk.ended_at = frame
            self.finished.append(trk)
        for trk in self.tracks.values():
            if trk.state == "halted" and trk.predicted is not None:
                trk.halted[frame] = trk.predicted
        if self._learner is not None:  # runs that no later check can extend
            self._learner.forget(frame)

    @staticmethod
    def _hid_after(trk: _Track, last: int) -> bool:
        """Whether the track's halt after its last observed frame was explained by an event that
        hides it (hides_behind)."""
        return any(e.event.name in _HIDING and e.time == last + 1 for e in trk.history)

    def _scene_velocity(self, frame: int) -> np.ndarray | None:
        """The tracker option scene_velocity: the component-wise median (du, dv) of the active tracks
        observed in the previous frame and at least once before it (a velocity measured, not a
        newborn's), the image motion they share when the camera turns; None (a new track starts at
        rest, as in SORT) with fewer than two such tracks."""
        moving = [t.kalman.velocity for t in self.tracks.values()
                  if t.state == "active" and frame - 1 in t.observed and t.streak >= 1]
        return column_medians(np.array(moving)) if len(moving) >= 2 else None

    def _observe(self, trk: _Track, frame: int, box: np.ndarray, conf: int, j: int, resumed: bool = False,
                 wander: float = 0.0) -> None:
        """A detection assigned to, or resuming, the track: update the filter (``wander``: wander_noise's share, or 0)
        and SORT's hit streak."""
        if resumed and self.options.reupdate_on_resume:
            trk.kalman.reupdate(box, wander)  # observation-centric re-update along the gap
        else:
            trk.kalman.update(box, wander)
        self._observed(trk, frame, box, conf, None, j)

    def _observed(self, trk: _Track, frame: int, box: np.ndarray, conf: int, state: list[float] | None, j: int) -> None:
        """After the track's filter took the detection: SORT's hit streak, the written box, the rows
        (``state``: the filter's state as floats, where the caller has them)."""
        trk.streak = trk.streak + 1 if frame - 1 in trk.observed else 1
        trk.at_rest = None
        trk.hits += 1
        trk.evidence += conf
        if self.options.write_peak:
            trk.best = max(trk.best, float(self._scores[j]))
        trk.observed[frame] = self._written(trk.id, frame, trk.kalman, box, state)
        self._confirm(trk, frame)

    def _written(self, trk_id: str, frame: int, kalman: BoxKalman, box: np.ndarray,
                 state: list[float] | None = None) -> np.ndarray:
        """The box an observed frame writes (WrittenBox; ``state``: the updated filter state as floats, if known)."""
        if self.options.written_box is WrittenBox.DETECTION:
            return np.array(box, dtype=float).reshape(4)  # a copy: the frame's array is the caller's
        filtered = kalman.box if state is None else BoxKalman.box_of_state(state)  # a new (4,) float array
        return filtered if self._learner is None else self._learner.written(trk_id, frame, box, filtered)

    def _confirm(self, trk: _Track, frame: int) -> None:
        """SORT's online output rule: written once hit_streak >= min_hits (or in the first min_hits
        frames); a confirmed track resumed after a gap of at most bridge_gap frames stays confirmed.
        With backfill, the frame that confirms a streak also writes the streak's earlier frames; a
        track re-confirmed after an occlusion episode (fill_hidden) writes the episode, interpolated,
        and the frames that re-confirmed it."""
        if not (trk.streak >= self.min_hits or self.frames <= self.min_hits or trk.bridged):
            return
        trk.evident = trk.evident or trk.evidence >= self.options.write_evidence * trk.hits  # once, for good
        if not trk.evident:
            return
        if self.options.write_peak:  # its best score ranks high among those so far, judged anew, or it was
            trk.waited = trk.waited or 0 < self.options.peak_wait <= trk.streak  # seen peak_wait frames in a row
            if not trk.waited and self._ranker.rank_of(trk.best) < self.options.write_peak:
                return
        first = frame
        if self.options.backfill and frame - 1 not in trk.confirmed:  # the streak's frames, a new track's first included
            first = self._backfilled(trk, frame)
        if trk.episodes and trk.streak >= self.min_hits:
            # every pending episode not final yet (rows <= frame - 1 - delay are handed over) nor
            # bridged by the backfill above (first <= last), and what was observed from its start on
            walked = first
            for last, resumed in trk.episodes:
                if frame - self.delay <= last < walked:
                    trk.gaps.append((last, resumed))
                    if self.sink is not None:
                        self._pend_gap(trk, last, resumed)
                    first = min(first, last)
            trk.episodes = []
        for f in range(first, frame + 1):
            if f in trk.observed and f not in trk.confirmed:
                trk.confirmed.add(f)
                if self.sink is not None:
                    self._pending.setdefault(f, []).append([f, _trk_number(trk.id), *trk.observed[f]])

    def _backfilled(self, trk: _Track, frame: int) -> int:
        """The first frame a confirmation at ``frame`` writes with backfill: back over the track's
        observed frames not yet written, at most _backfill_span frames back, across gaps of at most
        backfill_gap unobserved frames (each such gap bridged: written interpolated, as bridge_gap
        does for a confirmed track; 0: the streak's consecutive frames only)."""
        first = frame
        for f in range(frame - 1, frame - self._backfill_span - 1, -1):
            if f in trk.confirmed or first - f - 1 > self.options.backfill_gap:
                break
            if f in trk.observed:
                if first - f > 1:
                    trk.gaps.append((f, first))
                    if self.sink is not None:
                        self._pend_gap(trk, f, first)
                first = f
        return first

    def _pend_gap(self, trk: _Track, last: int, resumed: int) -> None:
        """The interpolated rows of a bridged gap, exactly as result_rows computes them."""
        number = _trk_number(trk.id)
        a, b = trk.observed[last], trk.observed[resumed]
        for f in range(last + 1, resumed):
            w = (f - last) / (resumed - last)
            self._pending.setdefault(f, []).append([f, number, *((1 - w) * a + w * b)])

    # -- results -----------------------------------------------------------------------------
    def result_rows(self) -> np.ndarray:
        rows: list[list[float]] = []
        for trk in sorted(self.finished + list(self.tracks.values()), key=lambda t: _trk_number(t.id)):
            if not trk.confirmed:
                continue
            number = _trk_number(trk.id)
            for f in sorted(trk.confirmed):
                rows.append([f, number, *trk.observed[f]])
            for last, resumed in trk.gaps:  # bridged gaps only
                a, b = trk.observed[last], trk.observed[resumed]
                for f in range(last + 1, resumed):
                    w = (f - last) / (resumed - last)
                    rows.append([f, number, *((1 - w) * a + w * b)])
        out = np.array(rows, dtype=float).reshape(-1, 6)
        return out[np.lexsort((out[:, 1], out[:, 0]))] if len(out) else out

    def track_records(self) -> tuple[TrackRecord, ...]:
        def boxes(d: dict[int, np.ndarray]):
            return tuple((f, tuple(float(v) for v in b)) for f, b in sorted(d.items()))
        everyone = sorted(self.finished + list(self.tracks.values()), key=lambda t: _trk_number(t.id))
        return tuple(TrackRecord(t.id, t.type, boxes(t.observed), boxes(t.halted), t.ended_at) for t in everyone)

    def result(self) -> TrackingResult:
        return TrackingResult(self.result_rows(), tuple(self.events), self.track_records(), self.frames,
                              self.not_optimal, self.solve_ms, self.budget_hits, self.over_budget)


def check_frame_budget(ms: object) -> float | None:
    """None, or a frame budget in milliseconds: a finite number >= 0 (ValueError, one sentence)."""
    if ms is None:
        return None
    ok = not isinstance(ms, bool) and isinstance(ms, (int, float, np.integer, np.floating))
    if not ok or not math.isfinite(ms) or ms < 0:
        raise ValueError(f"a frame budget must be a finite number of milliseconds >= 0 (or None: no budget), "
                         f"got {ms!r}")
    return float(ms)
