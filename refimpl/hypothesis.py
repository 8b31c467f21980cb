"""A hypothesis <H^assign_t, H^events_t>: assignment actions, abduced events, cost vector.

Actions and events are kept as their atom strings (e.g. ``assign(trk_12,det_1)``,
``occurs_at(hides_behind(trk_13,trk_12),235)``), sorted, so answers of different
backends compare as plain tuples.  The cost vector has clingo's shape: (priority, value)
pairs, highest priority first, maximise statements counted negatively.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

ACTIONS = ("assign", "start", "end", "halt", "resume", "ignore_det", "ignore_trk")
EVENTS = (
    "hides_behind", "unhides_from_behind", "missing_detections", "recover",
    "enters_fov", "leaves_fov", "lost", "noise",
)

Cost = tuple[tuple[int, int], ...]


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
        return json.dumps(self.to_json_dict())


def parse_action(atom: str) -> tuple[str, tuple[str, ...]]:
    """'assign(trk_1,det_2)' -> ('assign', ('trk_1', 'det_2'))."""
    name, _, rest = atom.partition("(")
    args = tuple(a.strip() for a in rest.rstrip(")").split(",")) if rest else ()
    return name, args
