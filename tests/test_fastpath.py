"""The CP-SAT backend's fast exact path gives the identical Hypothesis as the full CP-SAT model.

``CpSatSolver()`` (fast path on) and ``CpSatSolver(fast_path=False)`` (every frame through the
full lexicographic CP-SAT model) must agree on actions, events, cost vector and optimality, or
raise the same NoAdmissibleHypothesis, on:

* thousands of seeded random frames (tests/framegen.py), with and without history, and with
  constants that make explanations cost the same (the tie-break's explanation part decides);
* synthetic frames of refimpl.experiments.synthetic (5 .. 100 tracks, overlap 0.2 .. 0.8);
* every frame of real sequences (MOT15 TUD-Campus and KITTI-17, KITTI Car 0000) tracked by the
  fast path, each frame re-solved by the full model (skipped without ../shared/data).

The pieces are checked on their own too: the vectorised tie-break weights and overlapping_top
against their plain definitions, the per-track fold against EventState, the matching and its
uniqueness test against brute force, and the uniqueness of the optimum against CP-SAT's
enumeration of all optimal answers.  No test here times anything: performance lives in `refimpl bench-scale`.
"""

from __future__ import annotations

import itertools
import random
import warnings
from collections import Counter

import pytest
from ortools.sat.python import cp_model

from framegen import random_frame
from plain_tiebreak import plain_tiebreak as _plain_tiebreak
from refimpl.io.datasets import benchmark_sequences
from refimpl.core.constants import resolve_constants
from refimpl.knowledge.events import EventState
from refimpl.core.geometry import intersection_area
from refimpl.knowledge.relations import overlapping_top
from refimpl.solvers import NoAdmissibleHypothesis
from refimpl.solvers.common import intersection_matrix, tiebreak_weights
from refimpl.solvers.cpsat import (
    PRIORITIES,
    CpSatSolver,
    FastPathDeclined,
    TrackwiseState,
    _max_weight_matching,
    _overlapping_top_matrix,
    build_model,
    solve_fast,
    solve_lexicographic,
)
from refimpl.core.facts import parse_facts
from refimpl.solvers.fast_path import _matching
from refimpl.core.spec import FrameProblem, natural_key, with_constants
from refimpl.experiments.synthetic import synthetic_frame

EQUAL_COSTS = {name: 1 for name in ("cost_hides_behind", "cost_missing_detections", "cost_unhides_from_behind",
                                    "cost_recover", "cost_leaves_fov", "cost_lost", "cost_noise")}
"""Every explanation costs the same: halt by missing_detections and by hiding behind the
track covering most of it tie, and so do the explanations of an end or a resume."""


def _answer(solver, problem, state=None):
    try:
        h = solver.solve(problem, state=state)
    except NoAdmissibleHypothesis as exc:
        return ("NoAdmissibleHypothesis", str(exc))
    return (h.actions, h.events, h.cost, h.optimal, h.time)  # backend names differ: cpsat, cpsat-full


def _compare(frames, min_fast_share):
    fast, full = CpSatSolver(), CpSatSolver(fast_path=False)
    for p in frames:
        a, b = _answer(fast, p), _answer(full, p)
        assert a == b, f"fast path differs from the full model on\n{p.to_facts()}\nfast: {a}\nfull: {b}"
    assert fast.stats["fast"] >= min_fast_share * len(frames), fast.stats
    return fast.stats


# -- the pieces --------------------------------------------------------------------------------

def _mixed_frames(seed: int, n: int):
    rng = random.Random(seed)
    frames = [random_frame(rng, with_history=i % 2 == 1, n_trk=(1, 9), n_det=(0, 9)) for i in range(n)]
    frames += [synthetic_frame(n_trk, ov, s) for n_trk in (5, 20, 60) for ov in (0.2, 0.8) for s in range(3)]
    return frames


def test_vectorised_tiebreak_weights_are_the_plain_definition():
    for p in _mixed_frames(1, 400):
        got = tiebreak_weights(p)
        assert (got.pair, got.event) == _plain_tiebreak(p)


def test_vectorised_overlapping_top_is_the_relation():
    for p in _mixed_frames(2, 300):
        tracks = p.tracks
        inter = intersection_matrix([t.box for t in tracks])
        for hide_overlap in (10, 0, 55, -3):
            top = _overlapping_top_matrix(tracks, inter, hide_overlap)
            for i, t1 in enumerate(tracks):
                for j, t2 in enumerate(tracks):
                    assert inter[i, j] == intersection_area(t1.box, t2.box)
                    assert bool(top[i, j]) == (i != j and overlapping_top(t1.box, t2.box, hide_overlap))


def test_trackwise_state_answers_like_event_state():
    rng = random.Random(3)
    n = 0
    for _ in range(500):
        p = random_frame(rng, with_history=True, n_trk=(1, 8))
        ids = [t.id for t in p.tracks] + ["trk_99", "det_0"]
        full = EventState(p.history, ids)
        cache: dict = {}
        for _repeat in range(2):  # the second time every per-track state comes from the cache
            tw = TrackwiseState(p.history, ids, cache)
            for a in ids:
                assert tw.started_at(a) == full.started_at(a) and tw.halted_at(a) == full.halted_at(a)
                for name in ("visibility", "clipped", "in_fov"):
                    assert tw.values((name, a)) == full.values((name, a))
                    for v in ("true", "false", "not_visible", "fully_visible", "partially_visible"):
                        assert tw.holds_at((name, a), v) == full.holds_at((name, a), v)
                for b in ids:
                    if a != b:
                        assert tw.values(("hidden_by", a, b)) == full.values(("hidden_by", a, b))
                        assert tw.holds_at(("hidden_by", a, b), "true") == full.holds_at(("hidden_by", a, b), "true")
            n += 1
    assert n == 1000


def _brute_force_matchings(nl, nr, edges):
    """Every matching's weight, by enumeration: {frozenset of (l, r): weight}."""
    out = {}
    for size in range(min(nl, nr, len(edges)) + 1):
        for subset in itertools.combinations(edges, size):
            ls = [e[0] for e in subset]
            rs = [e[1] for e in subset]
            if len(set(ls)) == len(ls) and len(set(rs)) == len(rs):
                out[frozenset((l, r) for l, r, _ in subset)] = sum(g for _, _, g in subset)
    return out


def test_matching_and_its_uniqueness_test_against_brute_force():
    rng = random.Random(4)
    outcomes = Counter()
    for _ in range(3000):
        nl, nr = rng.randint(1, 5), rng.randint(1, 5)
        lo, hi = rng.choice(((-3, 3), (-1, 4), (-20, 20), (-10**30, 10**30)))
        edges = [(l, r, rng.randint(lo, hi)) for l in range(nl) for r in range(nr) if rng.random() < 0.6]
        if not edges:
            continue
        every = _brute_force_matchings(nl, nr, edges)
        best = max(every.values())
        optima = [m for m, v in every.items() if v == best]
        try:
            mate = _max_weight_matching(nl, nr, edges)
        except FastPathDeclined as exc:
            assert exc.reason == "tie", exc.reason
            assert len(optima) > 1, (nl, nr, edges)
            outcomes["tie"] += 1
            continue
        assert len(optima) == 1, (nl, nr, edges, optima)
        assert frozenset((l, r) for l, r in enumerate(mate) if r >= 0) == optima[0]
        outcomes["unique"] += 1
    assert outcomes["tie"] > 300 and outcomes["unique"] > 300, outcomes


def test_matching_of_cost_vectors_against_brute_force():
    # fast_path._matching: least total cost vector over matchings (each node alone costs its solo
    # vector, an edge replaces its two solos), stars (one node on a side) in closed form, the rest
    # through the integer encoding; checked against every matching's vector sum, by enumeration
    rng = random.Random(6)
    outcomes = Counter()
    for _ in range(3000):
        nl, nr = rng.choice(((1, rng.randint(1, 5)), (rng.randint(1, 5), 1), (rng.randint(1, 4), rng.randint(1, 4))))
        lo, hi = rng.choice(((-1, 1), (0, 1), (-3, 3)))
        vec = lambda: tuple(rng.randint(lo, hi) for _ in range(2))  # noqa: E731
        solo_l, solo_r = [vec() for _ in range(nl)], [vec() for _ in range(nr)]
        edges = [(l, r, vec()) for l in range(nl) for r in range(nr) if rng.random() < 0.7]
        if not edges:
            continue
        totals = {}
        for m in _brute_force_matchings(nl, nr, [(l, r, 0) for l, r, _ in edges]):
            cost = dict(((l, r), c) for l, r, c in edges)
            used_l, used_r = {l for l, _ in m}, {r for _, r in m}
            parts = [cost[e] for e in m] + [solo_l[l] for l in range(nl) if l not in used_l] + \
                [solo_r[r] for r in range(nr) if r not in used_r]
            totals[m] = tuple(map(sum, zip(*parts)))
        least = min(totals.values())
        optima = [m for m, v in totals.items() if v == least]
        kind = "star" if nl == 1 or nr == 1 else "general"
        try:
            mate = _matching(nl, nr, solo_l, solo_r, edges)
        except FastPathDeclined as exc:
            assert exc.reason == "tie" and len(optima) > 1, (nl, nr, solo_l, solo_r, edges)
            outcomes[kind, "tie"] += 1
            continue
        assert len(optima) == 1 and frozenset((l, r) for l, r in enumerate(mate) if r >= 0) == optima[0], \
            (nl, nr, solo_l, solo_r, edges, optima)
        outcomes[kind, "unique"] += 1
    assert min(outcomes.values()) > 50 and len(outcomes) == 4, outcomes


def _optimal_answers(problem: FrameProblem, limit: int = 50) -> list[frozenset[str]]:
    """Every answer of the full CP-SAT model with the optimal value at every level, the
    tie-break's pair and explanation parts included (CP-SAT enumeration)."""
    from refimpl.solvers.cpsat import EXPLANATION

    consts = resolve_constants(problem)
    state = EventState.from_problem(problem)
    best = solve_lexicographic(build_model(problem, state, consts), problem).values
    am = build_model(problem, state, consts)
    for key, terms in am.objectives.items():
        if terms:
            am.model.add(sum(c * v for c, v in terms) == sum(c * best[v.name] for c, v in terms))
    atoms = list(am.actions.items()) + list(am.events.items())
    found: list[frozenset[str]] = []

    class Collect(cp_model.CpSolverSolutionCallback):
        def on_solution_callback(self):
            found.append(frozenset(a for a, v in atoms if self.value(v)))
            if len(found) >= limit:
                self.stop_search()

    solver = cp_model.CpSolver()
    solver.parameters.enumerate_all_solutions = True
    solver.parameters.num_workers = 1
    solver.solve(am.model, Collect())
    return found


def test_the_optimum_is_unique_and_the_fast_path_finds_it():
    # CP-SAT's own enumeration of every answer optimal at every level (tie-break included): one
    # answer on every frame, also when every explanation costs the same; where the fast path
    # answers, it is that answer (it never declines for a tie any more)
    rng = random.Random(5)
    outcomes = Counter()
    for i in range(400):
        p = random_frame(rng, with_history=True, n_trk=(1, 4), n_det=(0, 4))
        if i % 2:
            p = with_constants(p, EQUAL_COSTS)
        try:
            optima = _optimal_answers(p)
        except NoAdmissibleHypothesis:
            outcomes["infeasible"] += 1
            continue
        assert len(optima) == 1, p.to_facts()
        try:
            fast = solve_fast(p, EventState.from_problem(p), resolve_constants(p))
        except FastPathDeclined as exc:
            assert exc.reason != "tie", p.to_facts()
            outcomes[exc.reason] += 1
            continue
        assert frozenset(fast.actions) | {e[len("occurs_at("):e.rindex(",")] for e in fast.events} == optima[0]
        outcomes["fast"] += 1
    assert outcomes["fast"] >= 150, outcomes


def test_fast_path_decides_a_component_tied_above_the_event_level_by_the_explanations():
    # test_association's frame: two tracks, one detection, equal IoU, so the matchings tie on
    # every level above the event level (the fast path's first matching declines as a tie) and
    # the halts' explanations decide: the fast path answers, as the full model does
    from test_association import EQUAL_LIKELIHOOD_FACTS
    p = parse_facts(EQUAL_LIKELIHOOD_FACTS)
    fast = solve_fast(p, EventState.from_problem(p), resolve_constants(p))
    assert fast.actions == ["assign(trk_b,det_0)", "halt(trk_a)", "halt(trk_c)"]
    assert _compare([p], min_fast_share=1.0)["fast"] == 1


# -- fast path vs full model ---------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(4))
def test_fast_path_equals_full_model_on_random_frames(seed):
    rng = random.Random(1000 + seed)
    frames = [random_frame(rng, with_history=False, n_trk=(1, 8), n_det=(0, 8)) for _ in range(300)]
    frames += [random_frame(rng, with_history=True, n_trk=(1, 8), n_det=(0, 8)) for _ in range(300)]
    # the tracker's frames have no clipped active track; framegen's histories often do, and then
    # the fast path hands the frame to the full model (an active track with no halt)
    _compare(frames, min_fast_share=0.75)


def test_fast_path_equals_full_model_with_tying_explanations():
    rng = random.Random(77)
    frames = [with_constants(random_frame(rng, with_history=True, n_trk=(2, 7), n_det=(1, 7)), EQUAL_COSTS)
              for _ in range(500)]
    stats = _compare(frames, min_fast_share=0.3)
    assert stats["declined: tie"] == 0, stats  # the canonical tie-break leaves no tie


def test_fast_path_equals_full_model_on_tracker_like_and_odd_frames():
    # larger crowds (up to 19 x 20), match_type facts, image borders, more lenient thresholds
    rng = random.Random(8)
    frames = []
    for i in range(200):
        p = random_frame(rng, with_history=i % 3 == 0, n_trk=(5, 19), n_det=(5, 20))
        if i % 4 == 1:
            p = with_constants(p, {"iou_thresh": 5000, "iou_thresh_resume": 1000, "conf_thresh_resume": 0})
        frames.append(p)
    _compare(frames, min_fast_share=0.6)


@pytest.mark.parametrize("overlap", [0.2, 0.5, 0.8])
def test_fast_path_equals_full_model_on_synthetic_frames(overlap):
    frames = [synthetic_frame(n, overlap, seed) for n in (5, 10, 20, 50) for seed in range(5)]
    frames += [synthetic_frame(100, overlap, seed) for seed in range(2)]
    frames += [synthetic_frame(30, overlap, seed, with_history=False) for seed in range(3)]
    _compare(frames, min_fast_share=1.0)


def test_explicit_state_is_used_by_the_fast_path():
    rng = random.Random(9)
    for _ in range(100):
        p = random_frame(rng, with_history=True)
        empty = EventState([], [t.id for t in p.tracks])
        assert _answer(CpSatSolver(), p, empty) == _answer(CpSatSolver(fast_path=False), p, empty)


def test_fast_path_declines_rather_than_guess():
    # an active track that can be neither halted nor (here) assigned: the full model's error
    rng = random.Random(10)
    solver = CpSatSolver()
    for _ in range(200):
        p = random_frame(rng, with_history=True)
        try:
            solver.solve(p)
        except NoAdmissibleHypothesis:
            pass
    assert solver.stats["declined: track without a solo action"] > 0
    assert solver.stats["full"] == sum(v for k, v in solver.stats.items() if k.startswith("declined"))
    assert not any(k.startswith("declined: internal") for k in solver.stats)


# -- real sequences, every frame -----------------------------------------------------------------

REAL = [("mot15", "TUD-Campus"), ("mot15", "KITTI-17"), ("kitti-car", "0000")]


@pytest.mark.parametrize("suite,name", REAL)
def test_fast_path_equals_full_model_on_every_frame_of_a_real_sequence(shared_data, suite, name):
    from refimpl import io
    from refimpl.tracking.pipeline import Setup, run_sequence

    seqs = {s.name: s for s in benchmark_sequences(suite, shared_data)}
    if name not in seqs:
        pytest.skip(f"{suite} has no sequence {name} under {shared_data}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # KITTI: a dropped zero-area box is reported as a warning
        seq = io.load_detections(seqs[name])
    fast, full = CpSatSolver(), CpSatSolver(fast_path=False)
    frames = []

    def observe(problem, hyp):
        other = full.solve(problem)
        assert (hyp.actions, hyp.events, hyp.cost, hyp.optimal) == (other.actions, other.events, other.cost,
                                                                    other.optimal), problem.to_facts()
        frames.append(problem.time)

    run_sequence(seq, Setup(), solver=fast, observer=observe)
    assert len(frames) == len(seq.frames) > 50
    assert fast.stats["fast"] >= 0.95 * len(frames), fast.stats


# -- the benchmark command's mechanics (nothing timed is asserted) -------------------------------

def test_bench_scale_writes_tables_plot_and_json(tmp_path):
    from refimpl.experiments import benchmarks as bm
    from refimpl.cli import main

    doc = tmp_path / "bench.md"
    doc.write_text("# Prose kept\n\nintro\n\n" + bm.SCALE_BEGIN + "\nold\n" + bm.SCALE_END + "\n\noutro\n")
    raw = tmp_path / "raw.json"
    backends = "cpsat,cpsat-full,clingo"
    try:
        import clingo  # noqa: F401
    except ImportError:
        backends = "cpsat,cpsat-full"
    assert main(["bench-scale", "--sizes", "5,10", "--overlaps", "0.5", "--seeds", "2", "--backends", backends,
                 "--out", str(doc), "--json", str(raw), "--quiet"]) == 0
    text = doc.read_text()
    assert text.startswith("# Prose kept\n\nintro") and text.rstrip().endswith("outro") and "\nold\n" not in text
    assert "| 5 | 0.5 |" in text and "| 10 | 0.5 |" in text and "2/2 |" in text
    assert (tmp_path / "scalability.png").stat().st_size > 10_000
    result = bm.load_json(raw)
    assert len(result.runs) == 2 * 2 * len(backends.split(","))
    assert all(r.optimal and r.error is None for r in result.runs)
    assert result.fast_path == {"fast": 4}
    rows = bm.summarise_scale(result)
    assert [(r.n, r.compared, r.agree, r.same_answer) for r in rows] == [(5, 2, 2, 2), (10, 2, 2, 2)]
    # redrawn from the JSON: the same table
    again = tmp_path / "again.md"
    assert main(["bench-scale", "--from-json", str(raw), "--out", str(again), "--quiet"]) == 0
    assert bm.scale_table(result) in again.read_text()
    assert main(["bench-scale", "--backends", "cpsat,nope", "--out", "-"]) == 2


def test_bench_throughput_counts_frames(data_root_with_val):
    from refimpl.experiments import benchmarks as bm

    # kitti-car-val on a data root whose val split is 0012 and 0014: their label_02 files end at
    # frames 77 and 105 (0-based), 78 + 106 = 184 frames, every one tracked by each tracker
    root = data_root_with_val("0012", "0014")
    result = bm.bench_throughput(root, benchmarks=("kitti-car-val",), trackers=("baseline", "cpsat"))
    frames = {r.tracker: sum(x.frames for x in result.runs if x.tracker == r.tracker) for r in result.runs}
    assert frames == {"baseline": 184, "cpsat": 184}
    assert all(r.not_optimal == 0 for r in result.runs)
    table = bm.throughput_table(result)
    assert "| kitti-car-val | 2 | 184 |" in table
