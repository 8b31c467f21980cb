"""The answer of last resort when a solver's time runs out before it found any answer.

Every detection is ignored, every halted track is ignored (a missing one that a track now covers
from the front re-explained by its first possible re-explanation, events.lp [explain_ignore]) and
every active track is halted, explained by its first possible one-track halting event
(missing_detections).  For every problem the tracker builds this answer is admissible
(docs/model-spec.md section 4), so a frame whose solver ran out of time still gets an answer,
flagged not optimal; where it is not admissible, the caller reports the frame instead.
"""

from __future__ import annotations

from ..hypothesis import Hypothesis
from ..spec import FrameProblem


def obvious_hypothesis(problem: FrameProblem, backend: str, solve_ms: float = 0.0) -> Hypothesis | None:
    """The ignore-and-halt answer with its real cost vector, or None if it breaks a rule."""
    from ..check import check_answer  # the checker decides admissibility and the cost
    from ..constants import resolve_constants
    from ..events import EventState, explaining, poss, reexplained

    t = problem.time
    actions = [f"ignore_det({d.id})" for d in problem.detections]
    actions += [f"ignore_trk({x.id})" if x.state == "halted" else f"halt({x.id})" for x in problem.tracks]
    state = EventState.from_problem(problem)
    constants = resolve_constants(problem)
    solo = [e.name for e in explaining("halt") if e.arity == 1]
    events = []
    for x in problem.tracks:
        if x.state == "active" and solo:  # no possible one: the first, which the checker then rejects
            name = next((n for n in solo if poss(f"{n}({x.id})", problem, state, constants)), solo[0])
            events.append(f"occurs_at({name}({x.id}),{t})")
    for x in problem.tracks:
        if x.state == "halted" and reexplained(state, x.id):
            again = next((f"{e.name}({x.id},{o.id})" for e in explaining("ignore_trk") for o in problem.tracks
                          if o.id != x.id and poss(f"{e.name}({x.id},{o.id})", problem, state, constants)), None)
            if again is not None:
                events.append(f"occurs_at({again},{t})")
    draft = Hypothesis(t, tuple(actions), tuple(events), (), optimal=False, backend=backend, solve_ms=solve_ms)
    report = check_answer(problem, draft)
    if not report.ok:
        return None
    return Hypothesis(t, tuple(actions), tuple(events), report.cost, optimal=False, backend=backend,
                      solve_ms=solve_ms)
