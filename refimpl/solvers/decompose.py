"""Solving a frame part by part: its independent components (refimpl.solvers.common) grouped
into sub-problems, each solved on its own, the answers merged.

A sub-problem holds the tracks and detections of some components ("own" nodes), their iou/3
pairs, and the *context* tracks the own tracks' events may name: every track whose box overlaps
an own track's box (hides_behind(T, T2) needs overlapping_top) and every track named in an own
track's history events (unhides_from_behind(T, T2) needs hidden_by(T, T2)).  A context track
keeps its box, type and history but is made halted: then it has ignore_trk as an admissible
solo action whatever the rest of the frame is, and since no rule reads another track's state or
choice (common.py), the own nodes have exactly the candidates, preconditions and costs they have
in the whole frame.  The answer of a sub-problem restricted to its own nodes is therefore that of
the whole frame restricted to them, and the merged answer is the frame's answer.  The context
tracks' part of each sub-answer is discarded.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable, Iterable

import numpy as np

from ..core.spec import FrameProblem, parse_atom
from ..core.constants import resolve_constants
from .admissibility import occupying_pairs
from .common import Component, DisjointSets, components, event_term, intersection_matrix

DEFAULT_PART_NODES = 60
"""Components are grouped into sub-problems of about this many own tracks and detections (small
components together: fewer solver calls; a larger component is a sub-problem of its own)."""


@dataclass(frozen=True)
class Part:
    problem: FrameProblem
    own: frozenset[str]
    """The ids of the own tracks and detections."""


def split(problem: FrameProblem, part_nodes: int = DEFAULT_PART_NODES, context: bool = False,
          fits: Callable[[int, int], bool] | None = None) -> list[Part]:
    """The frame as sub-problems (module docstring), in component order.

    Components (their units, ``_kept_together``) are taken in order into the current sub-problem
    while it stays within ``part_nodes`` nodes: its own tracks and detections, and with
    ``context`` its context tracks too (what the clingo backend grounds: every ordered pair of the
    sub-problem's tracks has events and a fluent, so its grounding grows with the square of all
    its tracks).  ``fits(tracks, detections)``, if given, must also hold for the sub-problem's
    counts (own and context tracks, own detections) before a unit joins it (the clingo backend's
    32-bit sums, refimpl.core.ranges.clingo_sum_bounds); a unit alone is always a sub-problem.
    A frame that is one sub-problem is returned whole."""
    comps = components(problem)
    whole = [Part(problem, frozenset(t.id for t in problem.tracks) | {d.id for d in problem.detections})]
    if len(comps) <= 1:
        return whole
    units = _kept_together(problem, comps)
    tracks = problem.tracks
    t_index = {t.id: i for i, t in enumerate(tracks)}
    overlapping = intersection_matrix([t.box for t in tracks]) > 0
    named: dict[str, set[str]] = {}
    for h in problem.history:
        args = [str(a) for a in h.event.args]
        if args:
            named.setdefault(args[0], set()).update(args[1:])

    def kept(own_t: Iterable[str]) -> set[str]:
        """The own tracks and their context tracks (module docstring)."""
        keep = set(own_t)
        for x in list(keep):
            keep.update(tracks[j].id for j in np.flatnonzero(overlapping[t_index[x]]).tolist())
            keep.update(y for y in named.get(x, ()) if y in t_index)
        return keep

    groups: list[list[Component]] = []
    keep: set[str] = set()
    n_own = n_det = 0
    for unit in units:
        unit_t = [x for c in unit for x in c.tracks]
        unit_d = sum(len(c.detections) for c in unit)
        unit_keep = kept(unit_t) if context or fits is not None else set(unit_t)
        joined = keep | unit_keep
        size = (len(joined) if context else n_own + len(unit_t)) + n_det + unit_d
        if not groups or size > part_nodes or (fits is not None and not fits(len(joined), n_det + unit_d)):
            groups.append([])
            keep, n_own, n_det = set(), 0, 0
            joined = unit_keep
        groups[-1].extend(unit)
        keep = joined
        n_own += len(unit_t)
        n_det += unit_d
    if len(groups) == 1:
        return whole

    parts = []
    for group in groups:
        own_t = [x for c in group for x in c.tracks]
        own_d = {x for c in group for x in c.detections}
        own_set = set(own_t)
        keep = kept(own_t)
        sub_tracks = tuple(t if t.id in own_set else replace(t, state="halted") for t in tracks if t.id in keep)
        sub_dets = tuple(d for d in problem.detections if d.id in own_d)
        sub_iou = tuple(x for x in problem.iou if x[0] in own_set and x[1] in own_d)  # others: no pair action
        history = tuple(h for h in problem.history if h.event.args and str(h.event.args[0]) in keep)
        # FrameProblem's validation would only re-check what the whole problem passed
        sub = FrameProblem.__new__(FrameProblem)
        for name, value in (("time", problem.time), ("detections", sub_dets), ("tracks", sub_tracks),
                            ("iou", sub_iou), ("constants", problem.constants), ("history", history),
                            ("match_types", problem.match_types)):
            object.__setattr__(sub, name, value)
        parts.append(Part(sub, frozenset(own_set | own_d)))
    return parts


def _kept_together(problem: FrameProblem, comps: list[Component]) -> list[list[Component]]:
    """The components in order, those linked by a [start_occupied] pair (a detection's start reads
    its iou/3 fact with a track of another component) in one unit, placed at its first member: a
    sub-problem holds only the iou/3 facts among its own nodes, so it must hold both."""
    where = {x: k for k, c in enumerate(comps) for x in (*c.tracks, *c.detections)}
    sets = DisjointSets(len(comps))
    for t, d in occupying_pairs(problem, resolve_constants(problem)):
        sets.union(where[t], where[d])
    units: dict[int, list[Component]] = {}
    for k, c in enumerate(comps):
        units.setdefault(sets.find(k), []).append(c)
    return list(units.values())


def _first_argument(atom: str) -> str:
    return str(parse_atom(atom).args[0])


def own_atoms(part: Part, actions: Iterable[str], events: Iterable[str]) -> tuple[list[str], list[str]]:
    """The actions and events (occurs_at atoms) of the part's own nodes.  An action's subject is its
    first argument except for start/ignore_det (the detection, also first) and the pair actions
    (the track first, its detection own too by construction); an event's is its first argument."""
    acts = [a for a in actions if _first_argument(a) in part.own]
    evs = [e for e in events if _first_argument(event_term(e)) in part.own]
    return acts, evs
