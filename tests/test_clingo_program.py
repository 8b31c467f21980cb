"""The clingo backend parses the model files once per solver and adds the parsed program to each
solve's Control (issue 38: re-reading the files cost ~2 ms of every call); the answers are those
of the files loaded as text."""

from __future__ import annotations

import pickle

import pytest

from refimpl.experiments.synthetic import synthetic_frame

clingo = pytest.importorskip("clingo")
from refimpl.solvers.clingo_backend import (  # noqa: E402
    ClingoSolver, clingo_arguments, default_model_files, problem_facts)


def _loaded_from_text(problem) -> tuple[list[str], list[int]]:
    """The optimum of the model files loaded as text (Control.load, as before issue 38)."""
    ctl = clingo.Control(clingo_arguments(problem))
    for path in default_model_files():
        ctl.load(str(path))
    ctl.add("base", [], problem_facts(problem))
    ctl.ground([("base", [])])
    best: list = []
    ctl.solve(on_model=lambda m: best.append((sorted(map(str, m.symbols(shown=True))), list(m.cost))))
    return best[-1]


def test_the_model_is_parsed_once_and_answers_as_the_files_loaded():
    solver = ClingoSolver(isolate=False, certify=False, decompose=False)
    frames = [synthetic_frame(6, 0.5, seed=s) for s in range(3)]
    program = None
    for p in frames:
        ctl = solver.control(p)  # the parsed program and the facts, not grounded
        ctl.ground([("base", [])])
        best: list = []
        ctl.solve(on_model=lambda m: best.append((sorted(map(str, m.symbols(shown=True))), list(m.cost))))
        assert best[-1] == _loaded_from_text(p)
        if program is None:
            program = solver._statements
        assert solver._statements is program  # the same parsed statements, not parsed again


def test_a_pickled_solver_parses_again_and_answers_the_same():
    solver = ClingoSolver(isolate=False)
    p = synthetic_frame(8, 0.5, seed=4)
    h = solver.solve(p)
    assert solver._statements is not None
    copy = pickle.loads(pickle.dumps(solver))  # clingo's AST cannot be pickled: dropped, parsed again
    assert copy._statements is None
    h2 = copy.solve(p)
    assert (h2.actions, h2.events, h2.cost, h2.optimal) == (h.actions, h.events, h.cost, h.optimal)


def test_a_model_clingo_cannot_parse_is_one_line_at_every_solve(tmp_path):
    bad = tmp_path / "bad.lp"
    bad.write_text("a :- b\n")  # no final period
    solver = ClingoSolver(isolate=False, model_files=[bad])
    p = synthetic_frame(2, 0.0, seed=1)
    for _ in range(2):
        with pytest.raises(RuntimeError, match="clingo could not parse the model: .*bad.lp"):
            solver.solve(p)
    assert solver._statements is None


def test_comments_are_not_handed_to_clingo():
    # model/*.lp is mostly comments (each rule's tag and why); the parsed program keeps only the
    # statements, here as many as there are rules, #const, #defined, #minimize, #show and
    # #program lines
    solver = ClingoSolver(isolate=False)
    statements = solver._program(lambda code, message: None)
    parsed: list = []
    clingo.ast.parse_files([str(p) for p in default_model_files()], parsed.append)
    kept = [s for s in parsed if s.ast_type != clingo.ast.ASTType.Comment]
    assert len(kept) < len(parsed) and [str(s) for s in statements] == [str(s) for s in kept]
