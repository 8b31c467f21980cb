"""The checker's own proof of optimality on small components: every answer enumerated.

refimpl.solvers.check confirms that an answer breaks no rule and recomputes its cost; this module
confirms, where it can, that no admissible answer costs less on levels 10..0.  It needs neither
solver: it splits the frame into components by the checker's own pair rules (a track and a
detection are joined when assign or resume of the pair is admissible, refimpl.solvers.check.FrameRules),
and on every component of at most ``max_nodes`` tracks and detections it lists every admissible
sub-answer: each matching of the component's admissible pairs (each matched pair assign or
resume), every other track and detection with each of its admissible solo actions (end,
ignore_trk, halt; start, ignore_det), and each action needing an explanation with each event
whose precondition holds (the checker's explanation rules: exactly one event for halt, resume,
start and end, one for an ignore_trk that explain_ignore concerns, none otherwise).  Every
level of the cost vector is a sum over an answer's atoms (refimpl.solvers.check.recompute_cost), and no
rule joins the atoms of two components, so an answer is optimal exactly when its part on every
component is the least of that component's sub-answers (lexicographic order, levels 10..0).

Results per frame (:class:`FrameOptimum`): for each enumerated component its least cost, one
sub-answer reaching it and how many do (more than one: the tie-break is not canonical there);
the sizes of the components too large to enumerate.  ``verdict(hyp)`` compares an answer that
check_answer passed: ``better`` is an admissible answer (the hypothesis with one component's part
replaced, checked again by check_answer) that costs less, ``confirmed`` means every component was
enumerated and the answer is the unique optimum.  The enumeration shares the problem data, the
constants, the events' preconditions and the tie-break weights with the solvers, nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .check import FrameRules, check_answer, recompute_cost
from ..knowledge.events import poss
from ..knowledge.event_table import EVENT_TABLE
from ..core.hypothesis import PRIORITIES, Cost, Hypothesis
from .common import TiebreakWeights, event_term, tiebreak_weights
from ..core.spec import FrameProblem

MAX_NODES = 8
"""Components of at most this many tracks and detections are enumerated."""

_SOLO_TRACK = ("end", "ignore_trk", "halt")
_SOLO_DET = ("start", "ignore_det")


@dataclass(frozen=True)
class ComponentOptimum:
    tracks: tuple[str, ...]
    detections: tuple[str, ...]
    cost: tuple[int, ...]
    """The least cost vector of the component's sub-answers, in PRIORITIES order."""
    answer: tuple[str, ...]
    """One sub-answer of that cost (actions and occurs_at atoms, sorted)."""
    optima: int
    """How many sub-answers reach it (1 under a canonical tie-break)."""
    answers: int
    """How many admissible sub-answers were enumerated."""


@dataclass(frozen=True)
class Verdict:
    better: Hypothesis | None
    """An admissible answer cheaper than the hypothesis, or None."""
    detail: str
    confirmed: bool
    """Every component enumerated, the hypothesis's part on each is its unique least sub-answer."""


@dataclass(frozen=True)
class FrameOptimum:
    problem: FrameProblem
    components: tuple[ComponentOptimum, ...]
    skipped: tuple[int, ...]
    """The sizes (tracks + detections) of the components larger than max_nodes."""
    rules: FrameRules = field(repr=False, compare=False, default=None)
    weights: TiebreakWeights = field(repr=False, compare=False, default=None)

    @classmethod
    def of(cls, problem: FrameProblem, max_nodes: int = MAX_NODES) -> "FrameOptimum":
        rules = FrameRules.of(problem)
        comps = list(_components(rules))
        small = [c for c in comps if len(c[0]) + len(c[1]) <= max_nodes]
        skipped = [len(c[0]) + len(c[1]) for c in comps if len(c[0]) + len(c[1]) > max_nodes]
        weights = tiebreak_weights(problem) if small else None  # the shared table, only when needed
        done = [_enumerate(rules, weights, *c) for c in small]
        return cls(problem, tuple(done), tuple(skipped), rules, weights)

    @property
    def ties(self) -> tuple[ComponentOptimum, ...]:
        return tuple(c for c in self.components if c.optima > 1)

    def verdict(self, hyp: Hypothesis, levels: int = len(PRIORITIES)) -> Verdict:
        """Compare an answer that refimpl.solvers.check.check_answer passed with the enumerated optima, on
        the first ``levels`` levels of PRIORITIES (5: levels 10..1, an encoding without the
        tie-break; the least cost on a prefix of the levels is the prefix of the least cost)."""
        rules, weights = self.rules, self.weights
        atoms = hyp.actions + hyp.events
        unique = True
        for comp in self.components:
            nodes = set(comp.tracks) | set(comp.detections)
            mine = [a for a in atoms if _subject(a) in nodes]
            cost = _cost(rules, weights, mine)
            if comp.cost[:levels] < cost[:levels]:
                better = _replaced(self.problem, hyp, mine, comp.answer, rules, weights)
                level = next(p for p, a, b in zip(PRIORITIES, comp.cost, cost) if a != b)
                return Verdict(better, f"a cheaper answer exists at priority {level} on the component of "
                                       f"{', '.join(comp.tracks + comp.detections)}: "
                                       f"{' '.join(comp.answer) or '-'} instead of {' '.join(sorted(mine)) or '-'}",
                               False)
            if cost < comp.cost:
                raise RuntimeError(f"t={hyp.time}: the answer's part {sorted(mine)} is cheaper than every "
                                   "enumerated sub-answer: the enumeration missed an answer")
            unique = unique and comp.optima == 1
        n = len(self.components)
        if self.skipped:
            return Verdict(None, f"no cheaper answer on {n} enumerated components; {len(self.skipped)} "
                                 f"larger than the enumeration's limit not checked", False)
        if not unique:
            return Verdict(None, f"optimal, but {len(self.ties)} components have several optima", False)
        return Verdict(None, f"optimal on every level: all {n} components enumerated", True)


def _subject(atom: str) -> str:
    """The first argument of an action or of an occurs_at atom's event (its track or detection)."""
    inner = event_term(atom) if atom.startswith("occurs_at(") else atom
    return inner[inner.index("(") + 1:].split(",")[0].rstrip(")")


def _components(rules: FrameRules):
    """(tracks, detections, admissible pairs) per component, tracks and detections in problem order."""
    order = [t.id for t in rules.problem.tracks] + [d.id for d in rules.problem.detections]
    root = {x: x for x in order}

    def find(x):
        while root[x] != x:
            root[x] = root[root[x]]
            x = root[x]
        return x

    pairs, seen = [], set()
    for t, d, _ in rules.problem.iou:  # both pair actions need the pair's iou/3 fact
        if t in rules.tracks and d in rules.dets and (t, d) not in seen:
            seen.add((t, d))
            if any(rules.action_violation(a, (t, d)) is None for a in ("assign", "resume")):
                pairs.append((t, d))
                a, b = find(t), find(d)
                if a != b:
                    root[b] = a
    rank = {x: k for k, x in enumerate(order)}
    pairs.sort(key=lambda p: (rank[p[0]], rank[p[1]]))
    groups: dict[str, list[str]] = {}
    for x in order:
        groups.setdefault(find(x), []).append(x)
    by_root: dict[str, list[tuple[str, str]]] = {}
    for p in pairs:
        by_root.setdefault(find(p[0]), []).append(p)
    for r, members in groups.items():
        yield (tuple(x for x in members if x in rules.tracks), tuple(x for x in members if x in rules.dets),
               tuple(by_root.get(r, ())))


def _explanations(rules: FrameRules, action: str, subject: str) -> list[tuple[str, ...]]:
    """Every admissible set of explaining events of one action (each a tuple of event terms)."""
    if action in ("assign", "ignore_det"):
        return [()]
    if action == "ignore_trk" and not rules.ignore_needs_explanation(subject):
        return [()]
    out = []
    for name, spec in EVENT_TABLE.items():
        if spec.explains != action and action not in spec.also_explains:
            continue
        if spec.arity == 1:
            terms = [f"{name}({subject})"]
        else:
            terms = [f"{name}({subject},{o})" for o in rules.tracks if o != subject]
        out += [(e,) for e in terms if poss(e, rules.problem, rules.state, rules.c)]
    return out


def _cost(rules: FrameRules, weights, atoms) -> tuple[int, ...]:
    acts = [a for a in atoms if not a.startswith("occurs_at(")]
    evs = [a for a in atoms if a.startswith("occurs_at(")]
    names = [event_term(e).split("(", 1)[0] for e in evs]
    return tuple(v for _, v in recompute_cost(rules.problem, acts, names, evs, rules.c, weights, rules.state))


def _options(rules: FrameRules, weights, action: str, args: tuple[str, ...]):
    """(cost vector, atoms) of every admissible way to take one action."""
    if rules.action_violation(action, args) is not None:
        return []
    atom = f"{action}({','.join(args)})"
    out = []
    for events in _explanations(rules, action, args[0]):
        atoms = (atom,) + tuple(f"occurs_at({e},{rules.problem.time})" for e in events)
        out.append((_cost(rules, weights, atoms), atoms))
    return out


def _enumerate(rules: FrameRules, weights, tracks, dets, pairs) -> ComponentOptimum:
    solo = {t: [o for a in _SOLO_TRACK for o in _options(rules, weights, a, (t,))] for t in tracks}
    solo.update({d: [o for a in _SOLO_DET for o in _options(rules, weights, a, (d,))] for d in dets})
    paired = {t: [(d, o) for (t2, d) in pairs if t2 == t for a in ("assign", "resume")
                  for o in _options(rules, weights, a, (t, d))] for t in tracks}
    zero = (0,) * len(PRIORITIES)
    best: list = [None, (), 0, 0]  # cost, atoms, how many reach it, how many answers

    def offer(cost, atoms):
        best[3] += 1
        if best[0] is None or cost < best[0]:
            best[0], best[1], best[2] = cost, atoms, 1
        elif cost == best[0]:
            best[2] += 1

    def add(a, b):
        return tuple(x + y for x, y in zip(a, b))

    def rest(k, used, cost, atoms):  # the detections no track took
        if k == len(dets):
            offer(cost, atoms)
            return
        d = dets[k]
        if d in used:
            rest(k + 1, used, cost, atoms)
            return
        for c, a in solo[d]:
            rest(k + 1, used, add(cost, c), atoms + a)

    def walk(i, used, cost, atoms):  # each track: a solo action or a pair with a free detection
        if i == len(tracks):
            rest(0, used, cost, atoms)
            return
        t = tracks[i]
        for c, a in solo[t]:
            walk(i + 1, used, add(cost, c), atoms + a)
        for d, (c, a) in paired[t]:
            if d not in used:
                walk(i + 1, used | {d}, add(cost, c), atoms + a)

    walk(0, frozenset(), zero, ())
    if best[0] is None:  # no admissible sub-answer: the frame has no answer at all
        return ComponentOptimum(tracks, dets, (float("inf"),) * len(PRIORITIES), (), 0, 0)
    return ComponentOptimum(tracks, dets, best[0], tuple(sorted(best[1])), best[2], best[3])


def _replaced(problem: FrameProblem, hyp: Hypothesis, mine, answer, rules: FrameRules, weights) -> Hypothesis:
    """hyp with one component's atoms replaced; checked again (an enumeration bug is no finding)."""
    keep = [a for a in hyp.actions + hyp.events if a not in set(mine)] + list(answer)
    acts = tuple(a for a in keep if not a.startswith("occurs_at("))
    evs = tuple(a for a in keep if a.startswith("occurs_at("))
    names = [event_term(e).split("(", 1)[0] for e in evs]
    cost: Cost = recompute_cost(problem, acts, names, evs, rules.c, weights, rules.state)
    better = Hypothesis(hyp.time, acts, evs, cost, optimal=False, backend="check_optimum")
    report = check_answer(problem, better)
    if not report.ok:
        raise RuntimeError(f"the enumerated answer breaks {report.messages[0]}: an enumeration error")
    return better
