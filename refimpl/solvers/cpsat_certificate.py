"""The level-10/5 certificate (refimpl.solvers.certificate) as pruning constraints of the CP-SAT model.

clingo checks the certificate in ASP (model/certificate.lp, docs/model.md 2.10); here the same
checks run in Python on the built model (``AbductionModel``), and only a certificate that passes
them all adds its constraints:

* level 10: potentials U(T), V(D) >= 0 with U + V >= w = IoU + 1 on every assign variable's pair,
  and a witness matching of assign variables, each tight (U + V = w), covering every node of
  positive potential, whose every other track has a solo action in the model (an active track a
  ``halt`` variable, which exists only when some explanation is possible; a halted track always
  has ``ignore_trk``; a detection always ``ignore_det``).  Then every lexicographic optimum
  assigns only tight pairs and every node of positive potential: assign variables of the other
  pairs are fixed to 0, and each positive node gets "one of its tight assigns".
* level 5 (only after level 10's passed): the same over the resume variables whose detection has
  level-10 potential 0, with weight IoU, a witness apart from level 10's tracks and detections,
  each of its pairs a resume variable of the model (which exists only when the resume can be
  explained).

The argument needs the model's levels 10 and 5 to hold only assign and resume terms, as
``build_model`` makes them (``action_cost``), which ``prune`` checks too.  The pruned model keeps
every lexicographic optimum, so the answer is the same (unique under the canonical tie-break);
CP-SAT only proves level 10 and 5 without searching for them.  The witness also goes into the
answer that stands in when a time limit leaves the first level no time (cpsat_lexicographic's
_trivial_solution): the obvious answer with the witness's pairs assigned, optimal at level 10.
"""

from __future__ import annotations

from typing import Mapping

from ..core.hypothesis import PRIORITIES, TIEBREAK_LEVEL
from ..core.spec import FrameProblem
from .certificate import Certificate, assign_weights, certificate, resume_weights
from .cpsat_model import PAIR_ORDER


def prune(am, problem: FrameProblem) -> tuple[bool, bool]:
    """Add the certificate's pruning to ``am`` (a refimpl.solvers.cpsat_model.AbductionModel of
    ``problem``) where its checks pass, and the pair part of the tie-break without the pairs it
    fixes to 0 (``_reorder``); (level 10 pruned, level 5 pruned)."""
    zero: set[int] = set()
    done = _prune(am, problem, zero)
    if zero:
        _reorder(am, zero)
    return done


def _reorder(am, zero: set[int]) -> None:
    """objectives[PAIR_ORDER]: the tie-break's pair terms (coefficients 2^q, distinct within a
    component) without the variables every optimum sets to 0, each 2^q weighed 2^(rank of q among
    those left).  Within a component the order of every two sets of pairs is that of the largest
    q in which they differ, which the ranks keep; components add up independently (the model's
    levels 10..1 are sums of their optima).  So the minimum is the same set of pairs, and with far
    fewer bits CP-SAT needs far fewer chunks (cpsat_lexicographic._chunk_pairs): a 400-track pile kept
    ~600 of its ~15,000 pairs, 12 chunks instead of ~390."""
    kept = [(c, v) for c, v in am.objectives[TIEBREAK_LEVEL] if v.index not in zero]
    rank = {c: 1 << k for k, c in enumerate(sorted({c for c, _ in kept}))}
    am.objectives[PAIR_ORDER] = [(rank[c], v) for c, v in kept]


def _prune(am, problem: FrameProblem, zero: set[int]) -> tuple[bool, bool]:
    if not _only_pairs_at_levels_10_and_5(am):
        return False, False
    cert = certificate(problem)
    if cert is None:
        return False, False
    weights = assign_weights(problem)
    assigns = {pair: am.actions[f"assign({pair[0]},{pair[1]})"] for pair in weights
               if f"assign({pair[0]},{pair[1]})" in am.actions}
    tight = _checked(cert, {p: w for p, w in weights.items() if p in assigns}, am, problem, None)
    if tight is None:
        return False, False
    _add(am, cert, assigns, tight, zero)
    am.witness = tuple(cert.matching)  # a level-10 optimum: the stand-in answer's assigns
    if cert.resume is None:
        return True, False
    v10 = dict(cert.det)
    pairs5 = {p: w for p, w in resume_weights(problem).items() if v10.get(p[1], 0) == 0}
    resumes = {p: am.actions[f"resume({p[0]},{p[1]})"] for p in pairs5 if f"resume({p[0]},{p[1]})" in am.actions}
    tight5 = _checked(cert.resume, {p: w for p, w in pairs5.items() if p in resumes}, am, problem, cert)
    if tight5 is None:
        return True, False
    _add(am, cert.resume, resumes, tight5, zero)
    return True, True


def _only_pairs_at_levels_10_and_5(am) -> bool:
    """Whether no level lies above 10 and levels 10 and 5 hold only assign and resume terms
    (model/certificate.lp relies on the same of optimisation.lp; certificate.CERTIFIED_STATEMENTS)."""
    names = {id(v): a for a, v in am.actions.items()}
    if max(am.objectives, default=0) > 10 or any(p > 10 for p in PRIORITIES):
        return False
    ok10 = all(names.get(id(v), "").startswith("assign(") for _, v in am.objectives.get(10, []))
    ok5 = all(names.get(id(v), "").startswith("resume(") for _, v in am.objectives.get(5, []))
    return ok10 and ok5


def _checked(cert: Certificate, w: Mapping[tuple[str, str], int], am, problem: FrameProblem,
             level10: Certificate | None) -> set[tuple[str, str]] | None:
    """The tight pairs of ``w`` if the certificate passes every check (module docstring), else None.
    ``level10``: for level 5, the accepted level-10 certificate (its witness must be avoided)."""
    u, v = dict(cert.trk), dict(cert.det)
    if any(x < 0 for x in u.values()) or any(x < 0 for x in v.values()):
        return None
    if any(u.get(t, 0) + v.get(d, 0) < weight for (t, d), weight in w.items()):
        return None  # not dual feasible: the bound would be wrong
    tight = {p for p, weight in w.items() if u.get(p[0], 0) + v.get(p[1], 0) == weight}
    witness = list(cert.matching)
    trks, dets = [t for t, _ in witness], [d for _, d in witness]
    if len(set(trks)) != len(trks) or len(set(dets)) != len(dets) or not all(p in tight for p in witness):
        return None
    if any(x > 0 and t not in trks for t, x in u.items()) or any(x > 0 and d not in dets for d, x in v.items()):
        return None
    if level10 is not None:  # level 5's witness apart from level 10's
        if set(trks) & {t for t, _ in level10.matching} or set(dets) & {d for _, d in level10.matching}:
            return None
        covered = set(trks) | {t for t, _ in level10.matching}
    else:
        covered = set(trks)
    for t in problem.tracks:  # every track outside the witness can take a solo action
        if t.id not in covered:
            solo = "halt" if t.state == "active" else "ignore_trk"
            if f"{solo}({t.id})" not in am.actions:
                return None
    return tight


def _add(am, cert: Certificate, variables: Mapping[tuple[str, str], object], tight: set[tuple[str, str]],
         zero: set[int]) -> None:
    """Only tight pairs (the others' variables into ``zero``), and every node of positive potential
    in one of them."""
    model = am.model
    at: tuple[dict[str, list], dict[str, list]] = ({}, {})  # each node's tight pairs' variables, per side
    for pair, var in variables.items():
        if pair not in tight:
            model.add(var == 0)
            zero.add(var.index)
        else:
            at[0].setdefault(pair[0], []).append(var)
            at[1].setdefault(pair[1], []).append(var)
    for side, potentials in ((0, cert.trk), (1, cert.det)):
        for node, x in potentials:
            if x > 0:
                model.add(sum(at[side].get(node, [])) == 1)
