"""A hypothesis <H^assign_t, H^events_t>: assignment actions, abduced events, cost vector.

Actions and events are kept as their atom strings (e.g. ``assign(trk_12,det_1)``,
``occurs_at(hides_behind(trk_13,trk_12),235)``), sorted, so answers of different
backends compare as plain tuples.  The cost vector has clingo's shape: (priority, value)
pairs, highest priority first, maximise statements counted negatively.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from . import bigint
from .spec import _FLAT_ARG, event_of, parse_atom

PRIORITIES = (10, 5, 3, 2, 1, 0)
"""The cost levels, highest priority first (model/optimisation.lp, docs/model.md "Optimisation"):
@10 matching likelihood and number of the pairs that continue a track, assigned or resumed
(maximised; the resumes there are a refimpl decision, docs/model.md 3.15), @5 empty since that
decision (still reported, so a cost vector keeps its six places), @3 ignored detections and
tracks, @2 ended and started tracks, @1 the cost of the abduced events, @0 the tie-break."""

EVENT_LEVEL = 1
"""The level at which each abduced event costs its cost_<event> constant."""
TIEBREAK_LEVEL = 0


@dataclass(frozen=True)
class ActionType:
    """One assignment action of the paper (Appendix A): its arguments and what it costs.

    ``level``/``weight``: the action costs ``weight`` at priority ``level`` (None: no cost).
    ``likelihood_level``: the action's matching likelihood ML = IoU x 100000 of its (track,
    detection) pair is maximised there, i.e. it costs -ML at that level: assign and resume both at
    @10 (model/optimisation.lp level10_likelihood, with level10_count: -(ML + 1) in all).
    """

    name: str
    args: tuple[str, ...]
    """'trk' / 'det' for each argument."""
    level: int | None
    weight: int
    likelihood_level: int | None = None


ACTION_TABLE: dict[str, ActionType] = {a.name: a for a in (
    ActionType("assign", ("trk", "det"), 10, -1, 10),
    ActionType("start", ("det",), 2, 5),
    ActionType("end", ("trk",), 2, 5),
    ActionType("halt", ("trk",), None, 0),
    ActionType("resume", ("trk", "det"), 10, -1, 10),
    ActionType("ignore_det", ("det",), 3, 10),
    ActionType("ignore_trk", ("trk",), 3, 10),
)}
"""action name -> ActionType; the one copy of model/optimisation.lp's per-action weights."""

Cost = tuple[tuple[int, int], ...]


def cost_text(cost: Cost) -> str:
    """A cost vector as ``solve`` prints it, ``value@priority`` highest first (values of any size,
    refimpl.core.bigint: level 0 of a dense crowd has thousands of digits)."""
    return " ".join(f"{bigint.int_text(v)}@{p}" for p, v in cost)


def cost_list_text(cost: Cost) -> str:
    """A cost vector as the list of (priority, value) pairs it is, ``[(10, -5), ...]``, any size."""
    return "[" + ", ".join(f"({p}, {bigint.int_text(v)})" for p, v in cost) + "]"


def action_cost(name: str, likelihood: int = 0) -> tuple[int, ...]:
    """The cost an action adds to each level, in PRIORITIES order (likelihood: the ML of its pair)."""
    spec = ACTION_TABLE[name]
    out = [0] * len(PRIORITIES)
    if spec.level is not None:
        out[PRIORITIES.index(spec.level)] += spec.weight
    if spec.likelihood_level is not None:
        out[PRIORITIES.index(spec.likelihood_level)] -= likelihood
    return tuple(out)


@dataclass(frozen=True)
class Hypothesis:
    """The abduced answer for one frame problem."""

    time: int
    actions: tuple[str, ...]
    events: tuple[str, ...]
    cost: Cost
    optimal: bool
    backend: str = ""
    solve_ms: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "actions", tuple(sorted(self.actions)))
        object.__setattr__(self, "events", tuple(sorted(self.events)))
        object.__setattr__(self, "cost", tuple((int(p), int(v)) for p, v in self.cost))

    @property
    def answer(self) -> tuple[str, ...]:
        """Actions and events together, sorted: what two backends must agree on."""
        return tuple(sorted(self.actions + self.events))

    def _actions(self, name: str) -> tuple[tuple[str, ...], ...]:
        return tuple(args for n, args in map(parse_action, self.actions) if n == name)

    @property
    def assignments(self) -> tuple[tuple[str, str], ...]:
        """(track id, detection id) of every assign, in sorted atom order."""
        return self._actions("assign")  # type: ignore[return-value]

    @property
    def resumes(self) -> tuple[tuple[str, str], ...]:
        """(track id, detection id) of every resume."""
        return self._actions("resume")  # type: ignore[return-value]

    @property
    def starts(self) -> tuple[str, ...]:
        """Detection ids that start a new track."""
        return tuple(a[0] for a in self._actions("start"))

    @property
    def halts(self) -> tuple[str, ...]:
        return tuple(a[0] for a in self._actions("halt"))

    @property
    def ends(self) -> tuple[str, ...]:
        return tuple(a[0] for a in self._actions("end"))

    @property
    def event_terms(self) -> tuple[tuple[str, tuple[str, ...]], ...]:
        """(event name, argument ids) of every abduced event, in sorted atom order."""
        return tuple(map(_event_name_args, self.events))

    def to_json_dict(self) -> dict:
        return {
            "time": self.time,
            "backend": self.backend,
            "optimal": self.optimal,
            "actions": list(self.actions),
            "events": list(self.events),
            "cost": [list(c) for c in self.cost],
            "solve_ms": round(self.solve_ms, 3),
        }

    def to_json(self) -> str:
        """``json.dumps(self.to_json_dict())``, with a level 0 of any size (refimpl.core.bigint)."""
        return bigint.dumps(self.to_json_dict())


def _event_name_args(atom: str) -> tuple[str, tuple[str, ...]]:
    """(event_of(atom).name, event_of(atom).arg_names).  An 'occurs_at(name(a,b,...),t)' atom
    whose name, arguments and time are flat (what every backend's events are) is split as
    parse_atom's tokens would split it, without making its Terms; any other goes to event_of."""
    if atom.startswith("occurs_at(") and atom.endswith(")"):
        inner, comma, time = atom[10:-1].rpartition(",")
        if comma and _FLAT_ARG.fullmatch(time):
            head, paren, rest = inner.partition("(")
            if _FLAT_ARG.fullmatch(head):
                if not paren:
                    return head, ()
                if "(" not in rest and rest.endswith(")"):
                    args = rest[:-1].split(",")
                    if all(_FLAT_ARG.fullmatch(a) for a in args):
                        return head, tuple(args)
    e = event_of(atom)
    return e.name, e.arg_names


@lru_cache(maxsize=1 << 12)
def parse_action(atom: str) -> tuple[str, tuple[str, ...]]:
    """'assign(trk_1,det_2)' -> ('assign', ('trk_1', 'det_2')) (refimpl.core.spec.parse_atom).

    Memoised as strings: a tuple of strings is no object the garbage collector walks (CPython
    stops tracking it), where parse_atom's memo keeps Terms, which it walks on every full
    collection (docs/benchmarks.md, "The slowest frames").  A flat atom ('name(a,b)', what every
    backend's actions are) is split as parse_atom's flat case splits it, without making Terms."""
    head, paren, rest = atom.partition("(")
    if paren and "(" not in rest and rest.endswith(")") and _FLAT_ARG.fullmatch(head):
        args = rest[:-1].split(",")
        if all(_FLAT_ARG.fullmatch(a) for a in args):
            return head, tuple(args)
    term = parse_atom(atom, memo=False)
    return term.name, term.arg_names
