"""The canonical tie-break (refimpl/solvers/common.py docstring) written out the slow way, for
tests: components by repeated flooding over the admissible pairs, indices by a plain sort."""

from __future__ import annotations

from refimpl.core.constants import resolve_constants
from refimpl.core.geometry import intersection_area
from refimpl.core.spec import FrameProblem, natural_key


def plain_tiebreak(problem: FrameProblem):
    """The canonical tie-break (refimpl/solvers/common.py docstring) written out the slow way:
    components by repeated flooding over the admissible pairs, indices by a plain sort."""
    from refimpl.knowledge.event_table import EFFECTS, EVENT_NAMES
    from refimpl.solvers.cpsat import assignment_constraints, resume_constraints

    consts = resolve_constants(problem)
    iou = problem.iou_map
    tracks = {t.id: t for t in problem.tracks}
    dets = {d.id: d for d in problem.detections}
    pairs = [(t, d) for t, d, _ in problem.iou
             if (assignment_constraints if tracks[t].state == "active" else resume_constraints)(
                 problem, consts, iou, tracks[t], dets[d])]
    nat = natural_key
    pair = {}
    todo = [t.id for t in problem.tracks] + [d.id for d in problem.detections]
    done = set()
    for start in todo:
        if start in done:
            continue
        comp, frontier = {start}, [start]
        while frontier:
            x = frontier.pop()
            for t, d in pairs:
                for a, b in ((t, d), (d, t)):
                    if a == x and b not in comp:
                        comp.add(b)
                        frontier.append(b)
        done |= comp
        mine = sorted((p for p in pairs if p[0] in comp), key=lambda p: (nat(p[0]), nat(p[1])))
        pair.update({p: 2 ** q for q, p in enumerate(mine)})
    event = {}
    named = {}
    for h in problem.history:
        args = [str(a) for a in h.event.args]
        if len(args) == 2 and args[0] in tracks and args[1] in tracks and args[1] != args[0]:
            named.setdefault(args[0], set()).add(args[1])
    for t1 in problem.tracks:
        over = sorted((t2 for t2 in problem.tracks if t2.id != t1.id and intersection_area(t1.box, t2.box) > 0),
                      key=lambda t2: (-intersection_area(t1.box, t2.box), nat(t2.id)))
        others = [t2.id for t2 in over] + sorted(named.get(t1.id, set()) - {t2.id for t2 in over}, key=nat)
        evs = [f"{n}({t1.id})" for n in EVENT_NAMES if EFFECTS[n][0] == 1]
        evs += [f"{n}({t1.id},{o})" for n in EVENT_NAMES if EFFECTS[n][0] == 2 for o in others]
        event.update({e: i for i, e in enumerate(evs)})
    for d in problem.detections:
        event.update({e: i for i, e in enumerate(f"{n}({d.id})" for n in EVENT_NAMES if EFFECTS[n][0] == 1)})
    return pair, event


def plain_level0(problem: FrameProblem, actions, events) -> int:
    """Level 0 of an answer by the definition: (sum of the chosen pairs' 2^q) * 2^E + the chosen
    events' indices, E the bit length of the sum over nodes of each node's largest index."""
    pair, event = plain_tiebreak(problem)
    largest: dict[str, int] = {}
    for e, i in event.items():
        node = e[e.index("(") + 1:].split(",")[0].rstrip(")")
        largest[node] = max(largest.get(node, 0), i)
    shift = sum(largest.values()).bit_length()
    pairs = sum(pair.get(tuple(a[a.index("(") + 1:-1].split(",")), 0) for a in actions
                if a.startswith(("assign(", "resume(")))
    return (pairs << shift) + sum(event.get(e[len("occurs_at("):e.rindex(",")], 0) for e in events)




# --- the explanation part's numbers for hand-derived expectations ----------------------------
# A test that derives a level-0 value by hand names the events and counts the nodes; these read
# the rest from the event table (refimpl.knowledge.event_table.EVENT_TABLE), so that a new event does not reopen
# the derivation: a node's indices are its arity-1 events in table order (0, 1, ...), then, for
# each arity-2 event in table order, one per other track of its candidate list; E is the bit
# length of the sum over the nodes of each node's largest index (refimpl/solvers/common.py).

def _names(arity: int) -> list[str]:
    from refimpl.knowledge.event_table import EVENT_TABLE
    return [name for name, e in EVENT_TABLE.items() if e.arity == arity]


def event_index(name: str) -> int:
    """An arity-1 event's index at every node: its place among the table's arity-1 events
    (missing_detections 0, recover 1, enters_fov 2, ... with today's table)."""
    return _names(1).index(name)


def pair_index(name: str, rank: int, others: int) -> int:
    """The index of the arity-2 event ``name`` naming the track's candidate of rank ``rank`` (0:
    the most overlapping) out of ``others``: after the arity-1 events and the earlier pair events."""
    return len(_names(1)) + _names(2).index(name) * others + rank


def largest_index(others: int = 0) -> int:
    """A node's largest index: its arity-1 events and each arity-2 event per candidate, minus one."""
    return len(_names(1)) + len(_names(2)) * others - 1


def shift(*largest: int) -> int:
    """E for nodes with these largest indices (largest_index of each node)."""
    return sum(largest).bit_length()
