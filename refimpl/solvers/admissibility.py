"""The admissibility of actions (docs/model-spec.md section 1): match_type and the integrity
constraints assignment_constraints, resume_constraints and start_constraints of Appendix A
(with refimpl's start_occupied, docs/model.md 3.21, resume_claimed, 3.29, and glimpse, 3.32).

Backend-neutral: the CP-SAT model, the fast path, the candidate pairs of the decomposition and
the tie-break (refimpl.solvers.common) all read these rules from here, one place.
"""

from __future__ import annotations

from typing import Mapping

from ..knowledge.events import EventState
from ..knowledge.event_table import anticipated_unhide
from ..knowledge.relations import area
from ..core.spec import Detection, FrameProblem, TrackPrediction


def match_type(problem: FrameProblem, trk_type: str, det_type: str) -> bool:
    """match_type(TrkType, DetType): equal types or a match_type/2 fact of the problem."""
    return trk_type == det_type or (trk_type, det_type) in problem.match_types


def _pair_constraints(problem: FrameProblem, constants: Mapping[str, int], iou: Mapping[tuple[str, str], int],
                      trk: TrackPrediction, det: Detection, state: str, conf: str, iou_key: str) -> bool:
    """A track in ``state``, a detection of a matching type above the ``conf`` threshold, and an
    iou/3 fact above the ``iou_key`` threshold: the shape both pair actions share."""
    v = iou.get((trk.id, det.id))
    return (
        trk.state == state
        and match_type(problem, trk.type, det.type)
        and det.conf > constants[conf]
        and v is not None and v > constants[iou_key]
    )


def assignment_constraints(problem: FrameProblem, constants: Mapping[str, int], iou: Mapping[tuple[str, str], int],
                           trk: TrackPrediction, det: Detection) -> bool:
    """Appendix A assignment_constraints(Trk, Det)."""
    return _pair_constraints(problem, constants, iou, trk, det, "active", "conf_thresh_assign", "iou_thresh")


def resume_constraints(problem: FrameProblem, constants: Mapping[str, int], iou: Mapping[tuple[str, str], int],
                       trk: TrackPrediction, det: Detection, state: EventState | None = None,
                       by_id: Mapping[str, TrackPrediction] | None = None, claims: "Claimed | None" = None) -> bool:
    """Appendix A resume_constraints(Trk, Det) plus refimpl's IoU condition (docs/model-spec.md);
    refimpl rule (docs/model.md 3.17): a track anticipated to unhide now (events.anticipated_unhide)
    resumes with any detection above conf_thresh_new_track; refimpl rule (3.29): not with a
    detection that continues a track followed without a break (:func:`resume_claimed`).
    ``state``/``by_id``/``claims``: the frame's event state, tracks by id and :class:`Claimed`
    (computed from the problem when not given, only if needed)."""
    if not _pair_constraints(problem, constants, iou, trk, det, "halted", "conf_thresh_resume", "iou_thresh_resume"):
        if not _pair_constraints(problem, constants, iou, trk, det, "halted", "conf_thresh_new_track",
                                 "iou_thresh_resume"):
            return False
        if state is None:
            state = EventState.from_problem(problem)
        if by_id is None:
            by_id = {t.id: t for t in problem.tracks}
        if not anticipated_unhide(state, constants, trk, by_id):
            return False
    if constants["glimpse_frames"] > 0:
        if state is None:
            state = EventState.from_problem(problem)
        if glimpse(state, constants, trk):
            return False
    return not resume_claimed(problem, constants, iou, trk, det, state, claims)


def glimpse(state: EventState, constants: Mapping[str, int], trk: TrackPrediction) -> bool:
    """refimpl rule (docs/model.md 3.32, association.lp [glimpse]): a halted track whose latest halt
    (halted_at) came at most glimpse_frames frames after its start (started_at) was seen too
    briefly to say an object is there: it is not resumed and occupies no detection."""
    g = constants["glimpse_frames"]
    if g <= 0 or trk.state != "halted":
        return False
    start, halt = state.started_at(trk.id), state.halted_at(trk.id)
    return start is not None and halt is not None and halt - start <= g


class Claimed:
    """The frame's claimed detections (association.lp [claimed], docs/model.md 3.29): for every
    active track, the detections it may be assigned (assignment_constraints) with its greatest IoU,
    where that IoU is above iou_thresh_claim: the detection that continues a track followed without
    a break.  Computed on the first question, once per frame."""

    def __init__(self, problem: FrameProblem, constants: Mapping[str, int], iou: Mapping[tuple[str, str], int]):
        self.problem, self.constants, self.iou = problem, constants, iou
        self._ids: frozenset[str] | None = None

    def __contains__(self, det_id: str) -> bool:
        if self._ids is None:
            self._ids = self._claimed()
        return det_id in self._ids

    def _claimed(self) -> frozenset[str]:
        problem, constants, iou = self.problem, self.constants, self.iou
        active = {t.id: t for t in problem.tracks if t.state == "active"}
        dets = {d.id: d for d in problem.detections}
        best: dict[str, tuple[int, list[str]]] = {}  # track -> (greatest IoU, its detections)
        # a detection at or below iou_thresh_claim is never claimed, nor the best of a track whose
        # best is claimed; one at or below iou_thresh is not assignable: neither is looked at
        floor = max(constants["iou_thresh_claim"], constants["iou_thresh"])
        for (tid, did), v in iou.items():
            if v <= floor:
                continue
            t, d = active.get(tid), dets.get(did)
            if t is None or d is None or not assignment_constraints(problem, constants, iou, t, d):
                continue
            top = best.get(tid)
            if top is None or v > top[0]:
                best[tid] = (v, [did])
            elif v == top[0]:
                top[1].append(did)
        return frozenset(d for _, ds in best.values() for d in ds)


def resume_claimed(problem: FrameProblem, constants: Mapping[str, int], iou: Mapping[tuple[str, str], int],
                   trk: TrackPrediction, det: Detection, state: EventState | None = None,
                   claims: Claimed | None = None) -> bool:
    """refimpl rule (docs/model.md 3.29, association.lp [resume_claimed]): a track halted at least
    claim_after frames ago (halted_at) does not resume with a claimed detection (:class:`Claimed`)."""
    if state is None:
        state = EventState.from_problem(problem)
    halted = state.halted_at(trk.id)
    if halted is None or problem.time - halted < constants["claim_after"]:
        return False
    return det.id in (Claimed(problem, constants, iou) if claims is None else claims)


def occupying_pairs(problem: FrameProblem, constants: Mapping[str, int],
                    state: EventState | None = None) -> list[tuple[str, str]]:
    """refimpl rule (docs/model.md 3.21, association.lp [start_occupied]): the (trk, det) pairs of a
    matching type with IoU > iou_thresh_occupied; such a detection is that track seen again, or
    seen twice, and cannot start a new track.  A :func:`glimpse` occupies nothing (3.32); ``state``:
    the frame's event state (built from the problem where a glimpse may be)."""
    limit = constants["iou_thresh_occupied"]
    glimpses: frozenset[str] = frozenset()
    if constants["glimpse_frames"] > 0 and any(t.state == "halted" for t in problem.tracks):
        if state is None:
            state = EventState.from_problem(problem)
        glimpses = frozenset(t.id for t in problem.tracks if glimpse(state, constants, t))
    types = {t.id: t.type for t in problem.tracks if t.id not in glimpses}
    det_types = {d.id: d.type for d in problem.detections}
    return [(t, d) for t, d, v in problem.iou
            if v > limit and t in types and d in det_types and match_type(problem, types[t], det_types[d])]


def occupied(problem: FrameProblem, constants: Mapping[str, int], state: EventState | None = None) -> frozenset[str]:
    """The ids of the detections that lie where a track of their type is (:func:`occupying_pairs`)."""
    return frozenset(d for _, d in occupying_pairs(problem, constants, state))


def start_constraints(constants: Mapping[str, int], det: Detection, taken: frozenset[str]) -> bool:
    """Appendix A start_constraints(Det): confidence and size(bigger, Det, size_threshold) as area;
    and refimpl's [start_occupied]: not one of the frame's ``taken`` detections (:func:`occupied`)."""
    return (det.conf > constants["conf_thresh_new_track"] and area(det.box) > constants["size_threshold"]
            and det.id not in taken)
