"""The level-10 certificate (refimpl.solvers.certificate) as pruning constraints of the CP-SAT model.

clingo checks the certificate in ASP (model/certificate.lp, docs/model.md 2.10); here the same
checks run in Python on the built model (``AbductionModel``), and only a certificate that passes
them all adds its constraints:

* potentials U(T), V(D) >= 0 with U + V >= w = IoU + 1 on the pair of every assign and resume
  variable, and a witness matching of such variables, each tight (U + V = w), covering every node
  of positive potential, whose every other track has a solo action in the model (an active track
  a ``halt`` variable, which exists only when some explanation is possible; a halted track always
  has ``ignore_trk``; a detection always ``ignore_det``; a resume variable exists only when the
  resume can be explained).  Then every lexicographic optimum takes only tight pairs and every
  node of positive potential: pair variables of the other pairs are fixed to 0, and each positive
  node gets "one of its tight pairs".

The argument needs the model's level 10 to hold only assign and resume terms and level 5 none, as
``build_model`` makes them (``action_cost``), which ``prune`` checks too.  The pruned model keeps
every lexicographic optimum, so the answer is the same (unique under the canonical tie-break);
CP-SAT only proves level 10 without searching for it.  The witness's assigns also go into the
answer that stands in when a time limit leaves the first level no time
(cpsat_lexicographic._trivial_solution): the obvious answer with those pairs assigned (a level-10
optimum where the witness has no resume).
"""

from __future__ import annotations

from typing import Mapping

from ..core.hypothesis import PRIORITIES, TIEBREAK_LEVEL
from ..core.spec import FrameProblem
from .certificate import Certificate, certificate, pair_weights
from .cpsat_model import PAIR_ORDER


def prune(am, problem: FrameProblem) -> bool:
    """Add the certificate's pruning to ``am`` (a refimpl.solvers.cpsat_model.AbductionModel of
    ``problem``) where its checks pass, and the pair part of the tie-break without the pairs it
    fixes to 0 (``_reorder``); whether level 10 was pruned."""
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


def _prune(am, problem: FrameProblem, zero: set[int]) -> bool:
    if not _only_pairs_at_level_10(am):
        return False
    weights = pair_weights(problem)  # once: it folds the event state to ask which resumes are explainable
    cert = certificate(problem, weights)
    if cert is None:
        return False
    variables = {}
    for pair in weights:
        var = am.actions.get(f"assign({pair[0]},{pair[1]})")
        if var is None:
            var = am.actions.get(f"resume({pair[0]},{pair[1]})")
        if var is not None:
            variables[pair] = var
    tight = _checked(cert, {p: w for p, w in weights.items() if p in variables}, am, problem)
    if tight is None:
        return False
    _add(am, cert, variables, tight, zero)
    # the stand-in answer's assigns (a level-10 optimum where the witness has no resume)
    am.witness = tuple(p for p in cert.matching if f"assign({p[0]},{p[1]})" in am.actions)
    return True


def _only_pairs_at_level_10(am) -> bool:
    """Whether no level lies above 10, level 10 holds only assign and resume terms and level 5 none
    (model/certificate.lp relies on the same of optimisation.lp; certificate.CERTIFIED_STATEMENTS)."""
    names = {id(v): a for a, v in am.actions.items()}
    if max(am.objectives, default=0) > 10 or any(p > 10 for p in PRIORITIES):
        return False
    ok10 = all(names.get(id(v), "").startswith(("assign(", "resume(")) for _, v in am.objectives.get(10, []))
    return ok10 and not am.objectives.get(5)


def _checked(cert: Certificate, w: Mapping[tuple[str, str], int], am,
             problem: FrameProblem) -> set[tuple[str, str]] | None:
    """The tight pairs of ``w`` if the certificate passes every check (module docstring), else None."""
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
