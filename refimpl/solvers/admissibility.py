"""The admissibility of actions (docs/model-spec.md section 1): match_type and the integrity
constraints assignment_constraints, resume_constraints and start_constraints of Appendix A
(with refimpl's start_occupied, docs/model.md 3.21).

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
                       by_id: Mapping[str, TrackPrediction] | None = None) -> bool:
    """Appendix A resume_constraints(Trk, Det) plus refimpl's IoU condition (docs/model-spec.md);
    refimpl rule (docs/model.md 3.17): a track anticipated to unhide now (events.anticipated_unhide)
    resumes with any detection above conf_thresh_new_track.  ``state``/``by_id``: the frame's event
    state and tracks by id (computed from the problem when not given, only if needed)."""
    if _pair_constraints(problem, constants, iou, trk, det, "halted", "conf_thresh_resume", "iou_thresh_resume"):
        return True
    if not _pair_constraints(problem, constants, iou, trk, det, "halted", "conf_thresh_new_track",
                             "iou_thresh_resume"):
        return False
    if state is None:
        state = EventState.from_problem(problem)
    if by_id is None:
        by_id = {t.id: t for t in problem.tracks}
    return anticipated_unhide(state, constants, trk, by_id)


def occupying_pairs(problem: FrameProblem, constants: Mapping[str, int]) -> list[tuple[str, str]]:
    """refimpl rule (docs/model.md 3.21, association.lp [start_occupied]): the (trk, det) pairs of a
    matching type with IoU > iou_thresh_occupied; such a detection is that track seen again, or
    seen twice, and cannot start a new track."""
    limit = constants["iou_thresh_occupied"]
    types = {t.id: t.type for t in problem.tracks}
    det_types = {d.id: d.type for d in problem.detections}
    return [(t, d) for t, d, v in problem.iou
            if v > limit and t in types and d in det_types and match_type(problem, types[t], det_types[d])]


def occupied(problem: FrameProblem, constants: Mapping[str, int]) -> frozenset[str]:
    """The ids of the detections that lie where a track of their type is (:func:`occupying_pairs`)."""
    return frozenset(d for _, d in occupying_pairs(problem, constants))


def start_constraints(constants: Mapping[str, int], det: Detection, taken: frozenset[str]) -> bool:
    """Appendix A start_constraints(Det): confidence and size(bigger, Det, size_threshold) as area;
    and refimpl's [start_occupied]: not one of the frame's ``taken`` detections (:func:`occupied`)."""
    return (det.conf > constants["conf_thresh_new_track"] and area(det.box) > constants["size_threshold"]
            and det.id not in taken)
