"""The level-10/5 certificate in the CP-SAT model (refimpl/solvers/cpsat_certificate.py, issue 41):
the checks of model/certificate.lp run in Python on the built model, a certificate that passes
them prunes, one that fails them prunes nothing, and the pruned model gives the unpruned one's
answer, on hand-made, random, history-laden and dense frames."""

from __future__ import annotations

import random
import sys
from pathlib import Path

import pytest

pytest.importorskip("ortools")

from refimpl.core.constants import resolve_constants  # noqa: E402
from refimpl.core.facts import parse_facts  # noqa: E402
from refimpl.experiments.synthetic import dense_frame  # noqa: E402
from refimpl.knowledge.events import EventState  # noqa: E402
from refimpl.solvers import NoAdmissibleHypothesis  # noqa: E402
from refimpl.solvers.certificate import certificate  # noqa: E402
from refimpl.solvers.cpsat_certificate import prune  # noqa: E402
from refimpl.solvers.cpsat_model import PAIR_ORDER, TIEBREAK_LEVEL, build_model  # noqa: E402
from refimpl.solvers.cpsat_lexicographic import solve_lexicographic  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from framegen import random_frame  # noqa: E402
from densegen import dense_frame as pile  # noqa: E402
from certificate_frames import OUTSIDE_THE_WITNESS, TWO_BY_TWO  # noqa: E402


def _solve(problem, pruned: bool):
    am = build_model(problem, EventState.from_problem(problem), resolve_constants(problem))
    done = prune(am, problem) if pruned else False
    res = solve_lexicographic(am, problem)
    return done, am, res


def test_the_two_by_two_frame_is_pruned_to_its_witness():
    # tests/test_certificate.py derives its certificate by hand: u = (35000, 20000),
    # v = (45001, 20001), witness {(1,1), (2,2)}; (1,2) and (2,1) are not tight (55001 > 50001,
    # 65001 > 60001), every node has positive potential.  So both of those assign variables are
    # fixed to 0 and the pair part of the tie-break keeps two terms, re-weighed 2^0 and 2^1.
    problem = parse_facts(TWO_BY_TWO)
    done, am, res = _solve(problem, True)
    assert done is True
    kept = sorted((c, str(v)) for c, v in am.objectives[PAIR_ORDER])
    assert kept == [(1, "assign(trk_1,det_1)"), (2, "assign(trk_2,det_2)")]
    assert res.optimal and dict(res.cost)[10] == -120002
    assert {a for a, v in res.values.items() if v and a.startswith("assign")} == {
        "assign(trk_1,det_1)", "assign(trk_2,det_2)"}


def test_a_track_without_a_solo_action_outside_the_witness_prunes_nothing():
    # tests/test_certificate.py's frame: trk_2 went missing at 95 (clipped, no halt possible),
    # its only pair is (trk_2, det_1); the relaxation's witness {(trk_1, det_1)} leaves it out.
    # Trusted, the pruning would forbid (trk_2, det_1) (not tight) and leave trk_2 no action;
    # the check sees there is no halt(trk_2) in the model and prunes nothing.  The answer:
    # assign(trk_2,det_1), trk_1 halted, level 10 = -(40000 + 1).
    problem = parse_facts(OUTSIDE_THE_WITNESS)
    done, am, res = _solve(problem, True)
    assert done is False and PAIR_ORDER not in am.objectives
    assert res.optimal and dict(res.cost)[10] == -40001
    assert res.values["assign(trk_2,det_1)"] == 1 and res.values["halt(trk_1)"] == 1


def _same_with_and_without(problem) -> tuple[bool, bool]:
    """(pruned, pruned with a resume in the witness), the answers equal with and without it."""
    try:
        plain = _solve(problem, False)[2]
    except NoAdmissibleHypothesis:  # a random history may leave a frame without any answer
        with pytest.raises(NoAdmissibleHypothesis):
            _solve(problem, True)
        return False, False
    done, _, pruned = _solve(problem, True)
    assert pruned.optimal and plain.optimal
    assert (pruned.cost, pruned.values) == (plain.cost, plain.values), problem.to_facts()
    halted = {t.id for t in problem.tracks if t.state == "halted"}
    return done, done and any(t in halted for t, _ in certificate(problem).matching)


def test_random_frames_with_and_without_history_get_the_same_answer():
    rng = random.Random(41)
    used = [_same_with_and_without(random_frame(rng, with_history=k % 2 == 1)) for k in range(300)]
    # the certificate is used on most of them, with a resume in its witness on some (the counts keep
    # this test honest)
    assert sum(d[0] for d in used) > 150 and sum(d[1] for d in used) > 10


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dense_crowds_and_piles_get_the_same_answer(seed):
    assert _same_with_and_without(dense_frame(60, seed))[0]
    # a pile (tests/densegen.py): 60 identical-size boxes in a 120 px square, IoUs that tie
    assert _same_with_and_without(pile(60, 55, seed, side=120))[0]


def test_the_pair_order_keeps_the_order_of_the_pairs_left():
    # on a pile the re-weighed pair part must rank the kept pairs as their 2^q did
    problem = pile(40, 36, 0, side=100)
    am = build_model(problem, EventState.from_problem(problem), resolve_constants(problem))
    prune(am, problem)
    original = {v.index: c for c, v in am.objectives[TIEBREAK_LEVEL]}
    kept = sorted(am.objectives[PAIR_ORDER], key=lambda t: original[t[1].index])
    assert [c for c, _ in kept] == sorted(c for c, _ in kept)
    assert len(kept) < len(original)


def test_out_of_time_the_stand_in_answer_has_the_witnesss_assigns():
    # issue 41: a dense crowd out of time got the obvious answer, no assign at all.  With the
    # certificate accepted, the stand-in is the obvious answer with the witness's assigns: still an
    # answer (every other track takes the obvious answer's solo action; the checker confirms it).
    # The witness reaches the level-10 optimum (2.10); the stand-in leaves out its resumes (their
    # halted tracks ignored), so its level 10 is the optimum's plus w = IoU + 1 of each of them.
    from refimpl.core.hypothesis import Hypothesis
    from refimpl.solvers.check import check_answer
    from refimpl.solvers.cpsat_lexicographic import _trivial_solution
    problem = dense_frame(60, 1)
    am = build_model(problem, EventState.from_problem(problem), resolve_constants(problem))
    assert prune(am, problem) and len(am.witness) > 40
    stand_in = _trivial_solution(am, problem)
    chosen = [a for a, v in list(am.actions.items()) + list(am.events.items()) if stand_in[v.index]]
    actions = tuple(sorted(a for a in chosen if a in am.actions))
    events = tuple(sorted(f"occurs_at({e},{problem.time})" for e in chosen if e in am.events))
    assert sum(a.startswith("assign(") for a in actions) == len(am.witness)
    report = check_answer(problem, Hypothesis(problem.time, actions, events, (), optimal=False))
    assert report.ok
    optimum = _solve(problem, False)[2]
    resumed = [p for p in certificate(problem).matching if p not in am.witness]
    assert dict(report.cost)[10] == dict(optimum.cost)[10] + sum(problem.iou_map[p] + 1 for p in resumed)
