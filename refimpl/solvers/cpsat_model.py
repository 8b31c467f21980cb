"""The abduction model as a CP-SAT model (refimpl.solvers.cpsat).

``build_model`` (one Boolean per candidate action and event, the actions' admissibility read from
refimpl.solvers.admissibility, the explanation rules as linear equalities, one objective per level of PRIORITIES);
refimpl.solvers.cpsat_lexicographic solves it priority by priority (``solve_lexicographic``).
The contract is in refimpl/solvers/cpsat.py.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np

# OR-Tools is imported where a model is built or solved (build_model, cpsat_lexicographic), not
# here: importing cp_model costs ~0.65 s (it imports pandas), and the fast path (fast_path.py),
# which imports this module's admissibility rules, answers most frames without CP-SAT.
if TYPE_CHECKING:
    from ortools.sat.python import cp_model

from ..knowledge.events import EventState
from ..knowledge.event_table import EVENT_TABLE, EventType, explaining, reexplained
from ..core.hypothesis import ACTION_TABLE, EVENT_LEVEL, PRIORITIES, TIEBREAK_LEVEL, action_cost
from ..core.spec import Detection, FrameProblem, TrackPrediction
from . import NoAdmissibleHypothesis
from .admissibility import Claimed, assignment_constraints, occupied, resume_constraints, start_constraints
from .common import intersection_matrix, tiebreak_weights

_EVENT_AT = PRIORITIES.index(EVENT_LEVEL)
_TIE_AT = PRIORITIES.index(TIEBREAK_LEVEL)


_BASE_COST = {name: action_cost(name) for name in ACTION_TABLE}
_LIKELIHOOD_AT = {name: PRIORITIES.index(a.likelihood_level) for name, a in ACTION_TABLE.items()
                  if a.likelihood_level is not None}


def _cost(action: str, likelihood: int = 0, event: int = 0, tiebreak: int = 0) -> tuple[int, ...]:
    """An action's cost vector in PRIORITIES order, with its explaining event's cost and tie-break
    (action_cost's vector, from a table: this runs for every option of every frame)."""
    out = list(_BASE_COST[action])
    at = _LIKELIHOOD_AT.get(action)
    if at is not None:
        out[at] -= likelihood
    out[_EVENT_AT] += event
    out[_TIE_AT] += tiebreak
    return tuple(out)


def _pair_candidates(spec: EventType, i: int, tracks: Sequence[TrackPrediction], top: np.ndarray,
                     state: EventState) -> Sequence[TrackPrediction]:
    """The second tracks worth testing poss for a pair event of tracks[i]: every other track, narrowed
    (as a speed-up only, same answers) by the condition its precondition implies (EventType.prefilter):
    'overlapping_top' (hides_behind: the top matrix), 'hidden_by' (unhides_from_behind: the track
    not_visible, and only the tracks it is hidden_by, in the frame's order: in a crowd a hidden
    track has one or two of those among hundreds of tracks).  ``top``: the matrix, or its rows as
    lists of column indices (fast_path._rows, computed once per frame)."""
    if spec.prefilter == "overlapping_top":
        row = top[i]
        return [tracks[j] for j in (row if isinstance(row, list) else np.flatnonzero(row).tolist())]
    trk = tracks[i].id
    if spec.prefilter == "hidden_by":
        if not _hidden(state, trk):
            return ()
        partners = state.hidden_by_holding(trk, "true")
        if partners is not None:  # else every other track may be (a default of true)
            return [t2 for t2 in tracks if t2.id in partners] if partners else ()
    return [t2 for t2 in tracks if t2.id != trk]


def _explanations(action: str, i: int, tracks: Sequence[TrackPrediction], top: np.ndarray,
                  state: EventState, constants: Mapping[str, int],
                  by_id: Mapping[str, TrackPrediction]) -> list[tuple[EventType, tuple[str, ...]]]:
    """The possible events explaining ``action`` of tracks[i]: (event type, argument ids), in
    event-table order, pair events by their candidate order."""
    t = tracks[i]
    out: list[tuple[EventType, tuple[str, ...]]] = []
    for spec in explaining(action):
        if spec.arity == 1:
            if spec.poss(state, constants, t, tracks=by_id):
                out.append((spec, (t.id,)))
        else:
            out.extend((spec, (t.id, t2.id)) for t2 in _pair_candidates(spec, i, tracks, top, state)
                       if spec.poss(state, constants, t, t2, tracks=by_id))
    return out


def _has_explanation(action: str, i: int, tracks: Sequence[TrackPrediction], top: np.ndarray,
                     state: EventState, constants: Mapping[str, int],
                     by_id: Mapping[str, TrackPrediction]) -> bool:
    """bool(_explanations(...)), stopping at the first possible event (the one-track events first:
    a precondition or two, where a pair event tests every candidate partner)."""
    t = tracks[i]
    specs = explaining(action)
    if any(spec.arity == 1 and spec.poss(state, constants, t, tracks=by_id) for spec in specs):
        return True
    return any(spec.arity != 1 and any(spec.poss(state, constants, t, t2, tracks=by_id)
                                       for t2 in _pair_candidates(spec, i, tracks, top, state))
               for spec in specs)


EXPLANATION = -1
"""AbductionModel.objectives key of the tie-break's explanation part (solved after the pair part)."""
PAIR_ORDER = -2
"""AbductionModel.objectives key, where present, of the pair part as it is minimised: the terms that
can be nonzero in an optimum, each weighed 2^(its rank), the same order (cpsat_certificate)."""

OBJECTIVE_BITS = 52
"""Every objective CP-SAT is asked to minimise takes fewer than 2^52 values in absolute value:
CP-SAT compares objective values with its bounds in doubles (53-bit mantissa), so beyond that it
can stop a few units above the optimum and report OPTIMAL (issue 26: with 57-61-bit objectives,
27 of 1,500 small adversarial frames got a worse answer flagged optimal, at level 0 and once at
level 1).  Below 2^52 every value and every difference of two values is an exact double.  Levels
are packed into one objective only within this span (``_pack_levels``), the tie-break's pair part
is cut into chunks that fit it (``_chunk_pairs``), and a single level that is larger on its own
has its optimum certified in exact integer arithmetic (``_certify``)."""


class CpSatFailure(RuntimeError):
    """CP-SAT ended without any solution for a reason other than infeasibility (e.g. UNKNOWN at a
    time limit with no fallback answer, or MODEL_INVALID)."""


# ---------------------------------------------------------------------------------------
# Model building
# ---------------------------------------------------------------------------------------

@dataclass
class AbductionModel:
    """A built CP-SAT model with its variables by atom string and its objectives (one per level)."""

    model: cp_model.CpModel
    time: int
    actions: dict[str, cp_model.IntVar] = field(default_factory=dict)
    """action atom ('assign(trk_1,det_0)') -> Boolean."""
    events: dict[str, cp_model.IntVar] = field(default_factory=dict)
    """event ('hides_behind(trk_13,trk_12)', 'enters_fov(det_3)') -> Boolean."""
    objectives: dict[int, list[tuple[int, cp_model.IntVar]]] = field(default_factory=dict)
    """priority -> [(coefficient, Boolean)], minimised.  TIEBREAK_LEVEL holds the tie-break's pair
    part (coefficients 2^q, Python integers of any size); EXPLANATION its explanation part."""
    tiebreak_shift: int = 0
    """E of the tie-break (common.py): level 0 = pair part * 2^E + explanation part."""
    witness: tuple[tuple[str, str], ...] = ()
    """Assign pairs of a level-10 optimum known before any solve (the accepted certificate's witness,
    cpsat_certificate): the stand-in answer of a level without time takes them (_trivial_solution)."""
    track_actions: list[list[cp_model.IntVar]] = field(default_factory=list)
    """Each track's actions, in problem order: exactly one is taken."""
    det_actions: list[list[cp_model.IntVar]] = field(default_factory=list)
    """Each detection's actions, in problem order: exactly one is taken."""
    explained: list[tuple[list[cp_model.IntVar], list[cp_model.IntVar]]] = field(default_factory=list)
    """(actions, events) of each explanation rule, sum(events) == sum(actions): with the two lists
    above, every constraint build_model adds (cpsat_matching reads the model's structure here)."""
    built_constraints: int = 0
    """How many constraints build_model added (cpsat_matching checks the lists above hold them all)."""

    def all_vars(self) -> list[cp_model.IntVar]:
        return list(self.actions.values()) + list(self.events.values())


def _overlapping_top_matrix(tracks: Sequence[TrackPrediction], inter: np.ndarray, hide_overlap: int) -> np.ndarray:
    """top[i, j] = relations.overlapping_top(tracks[i].box, tracks[j].box, hide_overlap) and i != j,
    for all pairs at once (exact integer arithmetic on the intersection matrix)."""
    b = np.asarray([t.box for t in tracks], dtype=np.int64).reshape(-1, 4)
    bottom = b[:, 1] + b[:, 3]
    top = (100 * inter > hide_overlap * (b[:, 2] * b[:, 3])[:, None]) & (bottom[None, :] >= bottom[:, None])
    np.fill_diagonal(top, False)
    return top


def _hidden(state: EventState, trk: str) -> bool:
    return state.holds_at(("visibility", trk), "not_visible")


def _partners(problem: FrameProblem) -> dict[str, list[Detection]]:
    """Track -> the detections of its iou/3 facts, in problem order.

    Only pairs with an iou/3 fact can be assigned or resumed, and hides_behind(T, T2) needs
    overlapping_top(T, T2): build_model skips everything else before calling the rules (same
    candidates, same variable order as testing every pair, without n^2 Python calls)."""
    det_at = {d.id: j for j, d in enumerate(problem.detections)}
    partners: dict[str, list[int]] = {}
    for t_id, d_id, _ in problem.iou:
        if d_id in det_at:
            partners.setdefault(t_id, []).append(det_at[d_id])
    return {t_id: [problem.detections[j] for j in sorted(set(js))] for t_id, js in partners.items()}


class _Builder:
    """build_model's model under construction: its variables (one per action and event, each with
    its objective terms), and each track's and detection's actions, of which exactly one is taken."""

    def __init__(self, problem: FrameProblem, state: EventState, constants: Mapping[str, int],
                 model: cp_model.CpModel, am: AbductionModel):
        self.problem, self.state, self.constants, self.model, self.am = problem, state, constants, model, am
        self.iou = problem.iou_map
        self.ml = problem.likelihood_map(constants["likelihood_conf"], constants["likelihood_halving"],
                                         state.halted_at)  # [matching_likelihood], [stale_likelihood]
        inter = intersection_matrix([t.box for t in problem.tracks])
        self.tb = tiebreak_weights(problem, inter, state)
        self.w = self.tb.pair  # 2^q per pair; events: tb.event (common.py)
        am.tiebreak_shift = self.tb.shift
        self.partners = _partners(problem)
        self.by_id = {t.id: t for t in problem.tracks}
        self.claims = Claimed(problem, constants, self.iou)  # [resume_claimed]
        self.top = _overlapping_top_matrix(problem.tracks, inter, constants["hide_overlap"])
        self.cost = {name: constants[e.cost_constant] for name, e in EVENT_TABLE.items()}
        self.per_trk: dict[str, list[cp_model.IntVar]] = {t.id: [] for t in problem.tracks}
        self.per_det: dict[str, list[cp_model.IntVar]] = {d.id: [] for d in problem.detections}

    def action(self, atom: str, name: str, likelihood: int = 0) -> cp_model.IntVar:
        v = self.model.new_bool_var(atom)
        self.am.actions[atom] = v
        for p, c in zip(PRIORITIES, action_cost(name, likelihood)):
            if c:
                self.am.objectives[p].append((c, v))
        return v

    def event(self, spec: EventType, args: tuple[str, ...]) -> cp_model.IntVar:
        atom = f"{spec.name}({','.join(args)})"
        v = self.model.new_bool_var(atom)
        self.am.events[atom] = v
        if self.cost[spec.name]:
            self.am.objectives[EVENT_LEVEL].append((self.cost[spec.name], v))
        tie = self.tb.event.get(atom, 0)
        if tie:
            self.am.objectives[EXPLANATION].append((tie, v))
        return v

    def explain(self, actions: list[cp_model.IntVar], events: list[cp_model.IntVar]) -> None:
        """The explanation rule: exactly one of the events iff (one of) the actions."""
        self.model.add(sum(events) == sum(actions))
        self.am.explained.append((actions, events))

    def explanations(self, action: str, i: int) -> list[tuple[EventType, tuple[str, ...]]]:
        return _explanations(action, i, self.problem.tracks, self.top, self.state, self.constants, self.by_id)

    def pair(self, name: str, t: TrackPrediction, d: Detection) -> cp_model.IntVar:
        """assign(T, D) or resume(T, D): an action of the track and of the detection, with its tie-break."""
        a = self.action(f"{name}({t.id},{d.id})", name, self.ml[(t.id, d.id)])
        self.per_trk[t.id].append(a)
        self.per_det[d.id].append(a)
        self.am.objectives[TIEBREAK_LEVEL].append((self.w[(t.id, d.id)], a))
        return a

    def active_track(self, i: int, t: TrackPrediction) -> None:
        # assign(T, D): assignment_constraints
        for d in self.partners.get(t.id, ()):
            if assignment_constraints(self.problem, self.constants, self.iou, t, d):
                self.pair("assign", t, d)
        # halt(T) <=> exactly one of its possible explanations   (explain_halt)
        halts = self.explanations("halt", i)
        if halts:
            h = self.action(f"halt({t.id})", "halt")
            self.per_trk[t.id].append(h)
            self.explain([h], [self.event(spec, args) for spec, args in halts])

    def halted_track(self, i: int, t: TrackPrediction) -> None:
        # end(T) <=> exactly one of its possible explanations   (explain_end)
        ends = self.explanations("end", i)
        if ends:
            en = self.action(f"end({t.id})", "end")
            self.per_trk[t.id].append(en)
            self.explain([en], [self.event(spec, args) for spec, args in ends])
        ig = self.action(f"ignore_trk({t.id})", "ignore_trk")
        self.per_trk[t.id].append(ig)
        # ignore_trk(T) of a missing track <=> exactly one possible re-explanation, if any   (explain_ignore)
        again = self.explanations("ignore_trk", i) if reexplained(self.state, t.id) else []
        if again:
            self.explain([ig], [self.event(spec, args) for spec, args in again])
        # resume(T, D) <=> exactly one of its possible explanations   (explain_resume)
        resumable = [d for d in self.partners.get(t.id, ())
                     if resume_constraints(self.problem, self.constants, self.iou, t, d, self.state, self.by_id,
                                           self.claims)]
        expl = self.explanations("resume", i) if resumable else []
        if resumable and expl:
            res = [self.pair("resume", t, d) for d in resumable]
            self.explain(res, [self.event(spec, args) for spec, args in expl])

    def detections(self) -> None:
        taken = occupied(self.problem, self.constants, self.state)  # [start_occupied]
        for d in self.problem.detections:
            # start(D) <=> exactly one of its possible explanations (enters_fov)   (explain_start)
            starts = [spec for spec in explaining("start") if spec.poss(self.state, self.constants, d.id, tracks=None)]
            if start_constraints(self.constants, d, taken) and starts:
                s = self.action(f"start({d.id})", "start")
                self.per_det[d.id].append(s)
                self.explain([s], [self.event(spec, (d.id,)) for spec in starts])
            self.per_det[d.id].append(self.action(f"ignore_det({d.id})", "ignore_det"))

    def exactly_one(self) -> None:
        """Every track and every detection takes exactly one of its actions."""
        for t in self.problem.tracks:
            if not self.per_trk[t.id]:
                raise NoAdmissibleHypothesis(
                    f"track {t.id} ({t.state}) has no admissible action at time {self.problem.time}")
            self.model.add_exactly_one(self.per_trk[t.id])
            self.am.track_actions.append(self.per_trk[t.id])
        for d in self.problem.detections:
            self.model.add_exactly_one(self.per_det[d.id])
            self.am.det_actions.append(self.per_det[d.id])


def build_model(problem: FrameProblem, state: EventState, constants: Mapping[str, int]) -> AbductionModel:
    """The CP-SAT model of one frame problem (see the module docstring).

    Raises NoAdmissibleHypothesis when some track has no candidate action at all.
    """
    from ortools.sat.python import cp_model  # heavy: only when the full model is needed (see the imports)
    model = cp_model.CpModel()
    am = AbductionModel(model, problem.time, objectives={p: [] for p in PRIORITIES + (EXPLANATION,)})
    build = _Builder(problem, state, constants, model, am)
    for i, t in enumerate(problem.tracks):
        if t.state == "active":
            build.active_track(i, t)
        else:  # halted
            build.halted_track(i, t)
    build.detections()
    build.exactly_one()
    am.built_constraints = len(model.proto.constraints)
    return am
