"""An answer checker independent of both backends.

Given a frame problem and a hypothesis, it verifies every rule of the model
(docs/model-spec.md) — each track and each detection in exactly one action, every integrity
constraint, every event's precondition, every halt/resume/start/end explained (and the ignore
of a missing track that a track now covers from the front) and no event without its action —
recomputes the cost vector from the answer, and reports each violation by the rule's label.  It shares only the problem data, the constants, the event-calculus
state and the preconditions (refimpl.knowledge.events, event_table) with the backends: the numbers are the same,
the reasoning over them is written again here.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from functools import cached_property

from ..core.constants import resolve_constants
from ..knowledge.events import EventState, poss
from ..knowledge.event_table import EVENT_TABLE
from ..core.hypothesis import ACTION_TABLE, EVENT_LEVEL, PRIORITIES, TIEBREAK_LEVEL, Cost, Hypothesis
from .common import tiebreak_level
from ..core.spec import FrameProblem
from ..core.facts import parse_term

_ACTION_ARITY = {a.name: len(a.args) for a in ACTION_TABLE.values()}
_EXPLAINED_BY = {e.name: e.explains for e in EVENT_TABLE.values()}  # event -> the action it explains
_EVENT_ARITY = {e.name: e.arity for e in EVENT_TABLE.values()}
_EXPLAINED_ACTIONS = frozenset(_EXPLAINED_BY.values())
_ALSO = {e.name: e.also_explains for e in EVENT_TABLE.values()}  # event -> actions it re-explains


def _inter(a, b) -> int:
    """The overlap area of two integer boxes (x, y, w, h), written again here."""
    w = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    h = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return max(w, 0) * max(h, 0)


@dataclass(frozen=True)
class CheckReport:
    """What the checker found: every broken rule (none: the answer is admissible) and the true cost."""

    violations: tuple[Violation, ...]
    cost: Cost
    """The cost vector recomputed from the answer (clingo's convention)."""

    @property
    def ok(self) -> bool:
        return not self.violations

    @property
    def messages(self) -> tuple[str, ...]:
        """One line per violation, ``[rule] detail``, as the command line prints them."""
        return tuple(f"[{v.rule}] {v.detail}" for v in self.violations)


@dataclass(frozen=True)
class Violation:
    rule: str
    """The rule of the model the answer breaks (the names docs/model.md uses)."""
    detail: str
    """What breaks it: the atoms (in the fact syntax) and why."""


@dataclass(frozen=True)
class FrameRules:
    """What the rules of one frame read: its constants, the event-calculus state, tracks and
    detections by id, the IoU map.  ``action_violation`` and ``ignore_needs_explanation`` are the
    per-action rules check_answer applies; refimpl.solvers.check_optimum enumerates answers with them."""

    problem: FrameProblem
    c: dict
    state: EventState
    tracks: dict
    dets: dict
    iou: dict

    @classmethod
    def of(cls, problem: FrameProblem) -> "FrameRules":
        return cls(problem, resolve_constants(problem), EventState.from_problem(problem),
                   {t.id: t for t in problem.tracks}, {d.id: d for d in problem.detections}, problem.iou_map)

    def match_type(self, a: str, b: str) -> bool:
        return a == b or (a, b) in self.problem.match_types

    def assignable(self, t, d) -> bool:
        """association.lp assignment_constraints(T, D)."""
        c, iou = self.c, self.iou
        return (t.state == "active" and self.match_type(t.type, d.type) and d.conf > c["conf_thresh_assign"]
                and (t.id, d.id) in iou and iou[(t.id, d.id)] > c["iou_thresh"])

    @cached_property
    def claimed(self) -> dict:
        """association.lp [claimed] (docs/model.md 3.29): each detection claimed, with the active track
        that claims it: one an active track may be assigned with no other it may be assigned at a
        greater IoU, and at an IoU above iou_thresh_claim."""
        out = {}
        for t in self.tracks.values():
            options = [(self.iou[(t.id, d.id)], d.id) for d in self.dets.values() if self.assignable(t, d)]
            if options:
                top = max(v for v, _ in options)
                out.update({d: t.id for v, d in options if v == top and v > self.c["iou_thresh_claim"]})
        return out

    def action_violation(self, name: str, args: tuple[str, ...]) -> Violation | None:
        """The integrity constraint the action (of known ids) breaks, or None."""
        c, tracks, dets, iou, state = self.c, self.tracks, self.dets, self.iou, self.state
        atom = f"{name}({','.join(args)})"
        if name == "assign":
            if not self.assignable(tracks[args[0]], dets[args[1]]):
                return Violation("assignment_constraints", f"{atom} is not admissible")
        elif name == "resume":
            t, d = tracks[args[0]], dets[args[1]]
            # the confidence a resume needs: conf_thresh_new_track where the track is anticipated to
            # unhide now (hidden, and at least half of its predicted box out of a current track it is
            # hidden_by), else conf_thresh_resume (association.lp resume_constraints)
            unhiding = state.holds_at(("visibility", t.id), "not_visible") and any(
                o != t.id and state.holds_at(("hidden_by", t.id, o), "true")
                and 2 * _inter(t.box, tracks[o].box) <= t.box[2] * t.box[3] for o in tracks)
            need = min(c["conf_thresh_resume"], c["conf_thresh_new_track"]) if unhiding else c["conf_thresh_resume"]
            if not (t.state == "halted" and self.match_type(t.type, d.type) and d.conf > need
                    and (t.id, d.id) in iou and iou[(t.id, d.id)] > c["iou_thresh_resume"]):
                return Violation("resume_constraints", f"{atom} is not admissible")
            # association.lp [resume_claimed]: halted at least claim_after frames ago, and the
            # detection continues an active track
            halted = state.halted_at(t.id)
            if halted is not None and self.problem.time - halted >= c["claim_after"] and d.id in self.claimed:
                return Violation("resume_claimed", f"{atom}: {d.id} continues {self.claimed[d.id]}, and {t.id} "
                                 f"was halted at {halted}")
            if self.glimpse(t.id):
                return Violation("glimpse", f"{atom}: {t.id} was halted at {halted}, within "
                                 f"glimpse_frames {c['glimpse_frames']} of its start")
        elif name == "start":
            d = dets[args[0]]
            if not (d.conf > c["conf_thresh_new_track"] and d.box[2] * d.box[3] > c["size_threshold"]):
                return Violation("start_constraints", f"{atom} is not admissible")
            # association.lp [start_occupied]: no track of a matching type overlaps it by more
            # than iou_thresh_occupied
            for t in tracks.values():
                v = iou.get((t.id, d.id))
                if (v is not None and v > c["iou_thresh_occupied"] and self.match_type(t.type, d.type)
                        and not self.glimpse(t.id)):
                    return Violation("start_occupied", f"{atom}: {t.id} is where {d.id} is (IoU {v})")
        elif name in ("end", "ignore_trk") and tracks[args[0]].state != "halted":
            return Violation(f"{name}_constraints", f"{atom} needs a halted track")
        elif name == "halt" and tracks[args[0]].state != "active":
            return Violation("halt_constraints", f"{atom} needs an active track")
        return None

    def glimpse(self, trk: str) -> bool:
        """association.lp [glimpse] (docs/model.md 3.32): a halted track whose latest halt came at
        most glimpse_frames frames after its latest start; it neither resumes nor occupies."""
        g = self.c["glimpse_frames"]
        if g <= 0 or self.tracks[trk].state != "halted":
            return False
        start, halt = self.state.started_at(trk), self.state.halted_at(trk)
        return start is not None and halt is not None and halt - start <= g

    def ignore_needs_explanation(self, trk: str) -> bool:
        """explain_ignore: an ignored track that is clipped needs one explanation iff one is possible."""
        return self.state.holds_at(("clipped", trk), "true") and any(
            poss(f"{e}({trk},{o})", self.problem, self.state, self.c) for e, spec in EVENT_TABLE.items()
            if "ignore_trk" in spec.also_explains for o in self.tracks if o != trk)


def check_answer(problem: FrameProblem, hyp: Hypothesis) -> CheckReport:
    """Every rule the answer breaks, and the cost vector it really has."""
    rules = FrameRules.of(problem)
    bad: list[Violation] = []
    actions = _check_actions(rules, hyp.actions, bad)
    explanations, event_names = _check_events(rules, problem, hyp.events, bad)
    _check_explanations(rules, actions, explanations, bad)
    valid_events = [a for a in hyp.events if _well_formed_event(a)]
    return CheckReport(tuple(bad), recompute_cost(problem, hyp.actions, event_names, valid_events, rules.c,
                                                    state=rules.state))


def _check_actions(rules: FrameRules, atoms, bad: list[Violation]) -> list[tuple[str, tuple[str, ...]]]:
    """The well-formed actions as (name, args); a violation in ``bad`` for every malformed one, for
    every track or detection without exactly one action, and for every rule an action breaks."""
    tracks, dets = rules.tracks, rules.dets
    per_track: dict[str, list[str]] = defaultdict(list)
    per_det: dict[str, list[str]] = defaultdict(list)
    actions: list[tuple[str, tuple[str, ...]]] = []
    for atom in atoms:
        term = parse_term(atom)
        name, args = term.name, tuple(a.name for a in term.args)
        if _ACTION_ARITY.get(name) != len(args):
            bad.append(Violation("action_syntax", f"{atom} is not an action of the model"))
            continue
        if name in ("assign", "resume"):
            if args[0] not in tracks or args[1] not in dets:
                bad.append(Violation("action_syntax", f"{atom} names an unknown id"))
                continue
            per_track[args[0]].append(atom)
            per_det[args[1]].append(atom)
        elif name in ("start", "ignore_det"):
            if args[0] not in dets:
                bad.append(Violation("action_syntax", f"{atom} names an unknown detection"))
                continue
            per_det[args[0]].append(atom)
        else:
            if args[0] not in tracks:
                bad.append(Violation("action_syntax", f"{atom} names an unknown track"))
                continue
            per_track[args[0]].append(atom)
        actions.append((name, args))

    for t in tracks:
        if len(per_track[t]) != 1:
            bad.append(Violation("actions_per_track", f"{t} has {len(per_track[t])} actions: {per_track[t]}"))
    for d in dets:
        if len(per_det[d]) != 1:
            bad.append(Violation("actions_per_detection", f"{d} has {len(per_det[d])} actions: {per_det[d]}"))

    for name, args in actions:
        v = rules.action_violation(name, args)
        if v is not None:
            bad.append(v)
    return actions


def _check_events(rules: FrameRules, problem: FrameProblem, atoms,
                  bad: list[Violation]) -> tuple[dict[tuple[str, str], list[str]], list[str]]:
    """(action, subject) -> the events explaining it, and the names of the well-formed events; a
    violation in ``bad`` for every malformed event, one at another time and one not possible."""
    tracks = rules.tracks
    explanations: dict[tuple[str, str], list[str]] = defaultdict(list)
    event_names: list[str] = []
    for atom in atoms:
        term = parse_term(atom)
        if term.name != "occurs_at" or len(term.args) != 2 or not term.args[1].is_int:
            bad.append(Violation("event_syntax", f"{atom} is not occurs_at(Event, Time)"))
            continue
        event, when = term.args[0], term.args[1].as_int()
        if when != problem.time:
            bad.append(Violation("event_time", f"{atom} is not at curr_time={problem.time}"))
        if event.name not in _EXPLAINED_BY:
            bad.append(Violation("event_syntax", f"{atom}: unknown event {event.name}"))
            continue
        if len(event.args) != _EVENT_ARITY[event.name] or any(a.args for a in event.args):
            bad.append(Violation("event_syntax", f"{atom}: {event.name} takes {_EVENT_ARITY[event.name]} ids"))
            continue
        event_names.append(event.name)
        if not poss(event, problem, rules.state, rules.c):
            bad.append(Violation(f"poss_{event.name}", f"{atom}: its precondition does not hold"))
        subject = event.args[0].name
        explains = _EXPLAINED_BY[event.name]
        if subject in tracks and tracks[subject].state == "halted" and "ignore_trk" in _ALSO[event.name]:
            explains = "ignore_trk"  # a halted track cannot halt: it is the re-explanation of its ignore
        explanations[(explains, subject)].append(str(event))
    return explanations, event_names


def _check_explanations(rules: FrameRules, actions: list[tuple[str, tuple[str, ...]]],
                        explanations: dict[tuple[str, str], list[str]], bad: list[Violation]) -> None:
    """explain_<action>: every explained action has exactly one explaining event, and no event
    explains an action not taken."""
    subjects = {(n, a[0]) for n, a in actions if n in _EXPLAINED_ACTIONS}
    # explain_ignore: an ignored track that is clipped needs one explanation iff one is possible
    for n, a in actions:
        if n == "ignore_trk" and rules.ignore_needs_explanation(a[0]):
            subjects.add((n, a[0]))
    for action, subject in sorted(subjects | set(explanations)):
        found = explanations.get((action, subject), [])
        label = "explain_ignore" if action == "ignore_trk" else f"explain_{action}"  # events.lp labels
        if (action, subject) not in subjects:
            bad.append(Violation(label, f"{found} occur without {action} of {subject}"))
        elif len(found) != 1:
            bad.append(Violation(label,
                                 f"{action} of {subject} needs exactly one explanation, has {found}"))


def _well_formed_event(atom: str) -> bool:
    term = parse_term(atom)
    if term.name != "occurs_at" or len(term.args) != 2:
        return False
    event = term.args[0]
    return _EVENT_ARITY.get(event.name) == len(event.args)


def recompute_cost(problem: FrameProblem, actions, event_names, event_atoms, c, weights=None,
                   state: EventState | None = None) -> Cost:
    """The cost vector of an answer, every level of PRIORITIES (docs/model-spec.md section 5); every
    level is a sum over the answer's atoms, so it is also the cost of part of an answer.  ``weights``:
    the frame's tie-break weights (refimpl.solvers.common.tiebreak_weights), ``state``: its event
    state (EventState.from_problem), when the caller has them."""
    # [matching_likelihood]: the IoU weighed by the detection's confidence, computed here from the
    # rule's text (model/optimisation.lp), not from the solvers' refimpl.core.spec.pair_likelihood
    conf, k = {d.id: d.conf for d in problem.detections}, c["likelihood_conf"]
    ml = {(t, d): v * (10000 - k * (100 - conf[d])) // 10000 for t, d, v in problem.iou}
    halving = c["likelihood_halving"]
    if halving:  # [stale_likelihood]: a halted track's, times H / (H + curr_time - T), T its halted_at
        state = EventState.from_problem(problem) if state is None else state
        since = {t.id: c["curr_time"] - h for t in problem.tracks
                 if t.state == "halted" and (h := state.halted_at(t.id)) is not None}
        ml = {(t, d): v * halving // (halving + since[t]) if t in since else v for (t, d), v in ml.items()}
    level = dict.fromkeys(PRIORITIES, 0)
    for atom in actions:
        term = parse_term(atom)
        args = tuple(a.name for a in term.args)
        spec = ACTION_TABLE.get(term.name)
        if spec is None:
            continue
        if spec.level is not None:
            level[spec.level] += spec.weight
        if spec.likelihood_level is not None:
            level[spec.likelihood_level] -= ml.get(args, 0)
    level[TIEBREAK_LEVEL] += tiebreak_level(problem, actions, event_atoms, weights)  # the canonical tie-break
    level[EVENT_LEVEL] += sum(c[EVENT_TABLE[name].cost_constant] for name in event_names if name in EVENT_TABLE)
    return tuple((p, level[p]) for p in PRIORITIES)
