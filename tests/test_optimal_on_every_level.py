"""An answer flagged optimal is optimal on every level (issue 26, item 1).

CP-SAT compares objective values with its bounds in doubles.  When levels 10..0 were packed into
one objective of up to 62 bits, it stopped a few units above the optimum on frames of the shape
of tests/adversarial.py and said OPTIMAL (27 of 1,500 such frames; seed 842 one unit too high at
level 1, the others at level 0).  Now every objective spans at most 2^OBJECTIVE_BITS values, and
a level larger on its own is certified in exact arithmetic.  The expected answers below are
clingo's: an independent encoding of the model (model/*.lp), whose optimisation is exact.
"""

from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ortools.sat.python import cp_model

from adversarial import adversarial_frame
from refimpl.solvers.check import check_answer
from refimpl.core.constants import resolve_constants
from refimpl.knowledge.events import EventState
from refimpl.solvers import get_solver
from refimpl.solvers.cpsat_model import OBJECTIVE_BITS, build_model
from refimpl.solvers.cpsat_lexicographic import (
    _chunk_pairs,
    _pack_levels,
    _range,
    _span,
    objective_plan,
    solve_lexicographic,
)

pytest.importorskip("clingo")

# seeds of adversarial_frame that got a wrong "optimal" answer from the 62-bit packing: 842 at
# level 1 (8 instead of 7), 955 and 1331 at level 0 by ~2^60, 63 and 325 at level 0 by 2^10
REGRESSION_SEEDS = (63, 325, 842, 955, 1331)


@pytest.fixture(scope="module")
def solvers():
    return {name: get_solver(name, **({"isolate": False} if name == "clingo" else {}))
            for name in ("cpsat-full", "clingo", "cpsat")}


def _model(problem):
    return build_model(problem, EventState.from_problem(problem), resolve_constants(problem))


def _packed_in_one_sequence(am, bits: int):
    """The levels packed as before issue 26 (and before the pair chunks got their own groups):
    levels 10..1, the pair chunks and the explanation part as one sequence."""
    return _pack_levels([level for part in objective_plan(am, bits) for group in part for level in group], bits)


def _agree_level_by_level(problem, solvers) -> None:
    ref = solvers["clingo"].solve(problem)
    assert ref.optimal
    for name in ("cpsat-full", "cpsat"):
        h = solvers[name].solve(problem)
        assert h.optimal
        for (p, got), (_, want) in zip(h.cost, ref.cost):
            assert got == want, f"{name} at level {p}: {got} vs clingo's {want}"
        assert h.answer == ref.answer
        report = check_answer(problem, h)
        assert not report.violations and report.cost == h.cost


@pytest.mark.parametrize("seed", REGRESSION_SEEDS)
def test_the_frames_cpsat_got_wrong_agree_with_clingo_on_every_level(seed, solvers):
    problem = adversarial_frame(random.Random(seed))
    # the shape: a halted track and two detections with the same box.  Packed up to 62 bits as
    # before issue 26, the objective then spanned more than 2^52 values; since docs/model.md 3.15
    # merged the resumes' level 5 into level 10 it spans less (7.4e12 on seed 63), so the frames
    # keep the shape and the agreement is what is asserted
    assert problem.tracks[0].state == "halted"
    boxes = [d.box for d in problem.detections]
    assert len(set(boxes)) < len(boxes)
    _agree_level_by_level(problem, solvers)


@pytest.mark.parametrize("seed", REGRESSION_SEEDS)
def test_every_objective_given_to_cpsat_spans_at_most_2_to_the_52(seed):
    # the objectives solve_lexicographic minimises one after another: objective_plan's three parts
    groups = [g for part in objective_plan(_model(adversarial_frame(random.Random(seed)))) for g in part]
    assert all(_span(g) <= 1 << OBJECTIVE_BITS for g in groups)


def test_tiebreak_chunks_fit_the_span_however_many_pairs():
    # 5000 terms of weights 2^0 .. 2^4999 (one component's pairs): bit length of 5000 is 13, so
    # width 52 - 13 = 39 and 5000 / 39 -> 129 chunks, each summing to < 5000 * 2^39 < 2^52
    model = cp_model.CpModel()
    xs = [model.new_bool_var(f"x{i}") for i in range(5000)]
    chunks = _chunk_pairs([(1 << q, x) for q, x in enumerate(xs)])
    assert len(chunks) == -(-5000 // 39)
    assert all(_range(c) <= 1 << OBJECTIVE_BITS for c in chunks)
    assert sum(len(c) for c in chunks) == 5000


@pytest.mark.parametrize("seed", (842, 955))
def test_levels_too_large_for_doubles_are_certified_and_give_the_same_answer(seed):
    # objective_bits=12: almost every level exceeds 2^12, so CP-SAT's OPTIMAL is re-proven by
    # asking for a strictly better solution until there is none; the answer must not change
    problem = adversarial_frame(random.Random(seed))
    exact = solve_lexicographic(_model(problem), problem)
    certified = solve_lexicographic(_model(problem), problem, objective_bits=12)
    assert "CERTIFIED" in certified.statuses
    assert certified.optimal and exact.optimal
    assert certified.cost == exact.cost and certified.values == exact.values


@st.composite
def adversarial_frames(draw):
    return adversarial_frame(draw(st.randoms(use_true_random=False)))


@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(problem=adversarial_frames())
def test_property_cpsat_full_equals_clingo_level_by_level(problem, solvers):
    _agree_level_by_level(problem, solvers)
