"""The answer of last resort when a solver's time runs out before it found any answer.

Every detection is ignored, every halted track is ignored (a missing one that a track now covers
from the front re-explained by its first possible re-explanation, events.lp [explain_ignore]) and
every active track is halted, explained by its first possible one-track halting event in
event-table order (missing_detections), else by its first other possible explanation.  For every
problem the tracker builds this answer is admissible (docs/model-spec.md section 4), so a frame
whose solver ran out of time still gets an answer, flagged not optimal; where it is not admissible,
the caller reports the frame instead.  One function (:func:`obvious_answer`) builds it for every
backend: the CP-SAT model starts from it inside a level (cpsat_lexicographic._trivial_solution), the
backends return it as a Hypothesis (:func:`obvious_hypothesis`).
"""

from __future__ import annotations

from typing import Mapping

from .check import check_answer  # the checker decides admissibility and the cost
from ..core.constants import resolve_constants
from ..knowledge.events import EventState, poss
from ..knowledge.event_table import explaining, reexplained
from ..core.hypothesis import Hypothesis
from ..core.spec import FrameProblem


def _first_possible(action: str, trk: str, problem: FrameProblem, state: EventState,
                    constants: Mapping[str, int]) -> str | None:
    """The first possible event explaining ``action`` of trk, in event-table order, pair events by
    the order of the problem's tracks (the CP-SAT model's variable order)."""
    for e in explaining(action):
        if e.arity == 1:
            candidates = [f"{e.name}({trk})"]
        else:
            candidates = [f"{e.name}({trk},{o.id})" for o in problem.tracks if o.id != trk]
        found = next((atom for atom in candidates if poss(atom, problem, state, constants)), None)
        if found is not None:
            return found
    return None


def obvious_answer(problem: FrameProblem, state: EventState | None = None,
                   constants: Mapping[str, int] | None = None) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(actions, event atoms) of the ignore-and-halt answer, not yet checked: an active track is
    halted with its first possible one-track halting event (the event table's order:
    missing_detections) when one is possible, else with its first possible explanation (the first
    one-track halting event when none is: the checker then refuses the answer)."""
    state = EventState.from_problem(problem) if state is None else state
    constants = resolve_constants(problem) if constants is None else constants
    actions = [f"ignore_det({d.id})" for d in problem.detections]
    solo = [e.name for e in explaining("halt") if e.arity == 1]
    events = []
    for x in problem.tracks:
        if x.state == "halted":
            actions.append(f"ignore_trk({x.id})")
            if reexplained(state, x.id):
                again = _first_possible("ignore_trk", x.id, problem, state, constants)
                if again is not None:
                    events.append(again)
        else:
            actions.append(f"halt({x.id})")
            first = next((f"{n}({x.id})" for n in solo if poss(f"{n}({x.id})", problem, state, constants)), None)
            events.append(first or _first_possible("halt", x.id, problem, state, constants) or f"{solo[0]}({x.id})")
    return tuple(actions), tuple(events)


def obvious_hypothesis(problem: FrameProblem, backend: str, solve_ms: float = 0.0) -> Hypothesis | None:
    """The ignore-and-halt answer with its real cost vector, or None if it breaks a rule."""
    t = problem.time
    actions, atoms = obvious_answer(problem)
    events = tuple(f"occurs_at({e},{t})" for e in atoms)
    draft = Hypothesis(t, actions, events, (), optimal=False, backend=backend, solve_ms=solve_ms)
    report = check_answer(problem, draft)
    if not report.ok:
        return None
    return Hypothesis(t, actions, events, report.cost, optimal=False, backend=backend, solve_ms=solve_ms)
