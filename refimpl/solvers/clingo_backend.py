"""The ASP backend: the paper's answer set program (model/*.lp) solved with clingo.

One frame problem in, one Hypothesis out.  clingo is imported when a ClingoSolver is
constructed, never when refimpl is imported, so refimpl works without the 'asp' extra.

clingo options (fixed, so that a run is reproducible):

* ``--opt-mode=opt``          lexicographic optimisation: find improving models until one is
                              proven optimal (clingo's default for optimisation problems)
* ``--models=0``              no limit on the number of improving models
* ``--configuration=tweety``  one fixed search configuration (instead of 'auto')
* ``--seed=1``                the fixed random seed (clingo's default, written out)
* ``--parallel-mode=N``       N solver threads (default 1: single-threaded, deterministic; with
                              N > 1 clingo races N configurations and the optimal answer found
                              first may differ among equally good ones)
* ``--opt-strategy=usc,oll,stratify``  with the level-10 certificate (``certify``,
                              model/certificate.lp): core-guided optimisation with stratification.
                              Once the certificate pins level 10, what is left is a sum of
                              nearly independent choices (each action's explanation, start or
                              ignore per detection), which cores bound at once and branch and bound
                              (clingo's default, kept without the certificate) does not: a 200-track
                              crowd is proven in ~1 s of search with it and not in 40 s without.
                              Stratification (the heaviest weights first) because the tie-break's
                              weights are powers of two: plain ``usc`` took 20 s on some 4-5-track
                              frames that branch and bound proves in 0.04 s (docs/model.md 2.10).
                              Only where model/certificate.lp accepts the certificate (``cert_ok``
                              a fact after grounding): a rejected one prunes nothing, and without
                              the pruning the cores are unbounded (4 of 2,500 adversarial frames
                              ran for minutes with usc and solve in < 0.1 s with branch and bound,
                              each an active track without a possible halt that the witness left
                              unmatched); the search then goes back to branch and bound
* ``-c name=value``           every model constant (refimpl.core.constants.resolve_constants), so
                              model/constants.lp gives only the defaults and the problem's
                              ``#const`` lines are not passed in the fact text
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Sequence

from .check import recompute_cost
from ..core.constants import model_dir, resolve_constants
from ..core.ranges import OutOfClingoRange, clingo_overflow, counts_fit_clingo
from ..core.hypothesis import Hypothesis, PRIORITIES, TIEBREAK_LEVEL
from ..core.spec import FrameProblem, event_of, parse_atom
from . import CLINGO, NoAdmissibleHypothesis, SolveTimeout, Solver, SolverUnavailable, effective_limit
from .clingo_process import ClingoWorker, DEFAULT_RECYCLE
from .asp_model import ENCODING_MEMORY, certificate_preconditions
from .certificate import certificate, certificate_facts
from .common import tiebreak_facts, tiebreak_level, tiebreak_weights
from .decompose import Part, own_atoms, split
from .fallback import obvious_hypothesis

POLL = 0.1
"""Seconds between two checks of clingo's asynchronous search (time limit, SIGINT)."""

INLINE_SOLVES = 500
"""Solves a ClingoSolver runs in its own process before it moves clingo to a worker process: a
single frame (refimpl solve) pays no process start, a sequence's memory stays bounded."""

"""The cost levels of the model (docs/model-spec.md section 5), highest first."""

_INSTALL_HINT = "the clingo backend needs clingo: pip install 'refimpl[asp]'"


def default_model_files() -> tuple[Path, ...]:
    """Every model/*.lp file, constants.lp included (it holds the defaults), in name order."""
    return tuple(sorted(model_dir().glob("*.lp")))


def problem_facts(problem: FrameProblem) -> str:
    """The problem's facts without its #const lines, followed by the tie-break facts."""
    lines = [ln for ln in problem.to_facts().splitlines() if not ln.lstrip().startswith("#const")]
    return "\n".join(lines) + "\n" + tiebreak_facts(problem)


def clingo_arguments(problem: FrameProblem, threads: int = 1, certify: bool = False,
                     own_constants: Sequence[str] = ()) -> list[str]:
    """The clingo command-line options for this problem (see the module docstring).  No ``-c`` for
    a constant of ``own_constants`` (those a user's encoding defines itself,
    refimpl.solvers.asp_model) unless the problem sets it (``curr_time``, the image size, a
    ``--const``): the encoding runs with its own values."""
    args = [
        "--opt-mode=opt",
        "--models=0",
        "--configuration=tweety",
        "--seed=1",
        f"--parallel-mode={threads}",
    ]
    if certify:
        args.append("--opt-strategy=usc,oll,stratify")
    own = set(own_constants) - {name for name, _ in problem.constants} - {"curr_time"}
    for name, value in resolve_constants(problem).items():
        if name not in own:
            args += ["-c", f"{name}={value}"]
    return args


def _certificate_holds(ctl, clingo) -> bool:
    """Whether model/certificate.lp accepted the certificate: ``cert_ok`` a fact once grounded
    (every check it makes is on facts, so grounding decides it)."""
    atom = ctl.symbolic_atoms[clingo.Function("cert_ok")]
    return atom is not None and atom.is_fact


def _branch_and_bound(ctl) -> None:
    """Every solver thread back to clingo's default optimisation strategy (module docstring)."""
    solvers = ctl.configuration.solver
    for k in range(len(solvers)):
        solvers[k].opt_strategy = "bb"


KILLABLE_IOU = 3000
"""A sub-problem of at least this many iou/3 facts solved under a time limit goes to the worker
process whatever the count of solves: grounding cannot be stopped half-way in this process, but
the worker is killed when it overruns (refimpl.solvers.clingo_process), so the limit holds with
grounding included.  A dense 100-track crowd has ~3,600 (refimpl.experiments.synthetic.dense_frame);
a 400-track one, ~14,600, grounded in 10-20 s on this machine."""

PART_NODES = 48
"""The clingo backend's default sub-problem size: own tracks and detections *and* context tracks
(``split(..., context=True)``, refimpl.solvers.decompose).  Each clingo call costs ~10 ms of
parsing and grounding the model whatever its size, and grounding grows with the square of a
sub-problem's tracks (every ordered pair has events and a fluent), context tracks included: 48
makes every frame of KITTI Car 0001 one call (2.3 calls per frame with ``LEGACY_PART_NODES``),
and synthetic crowds of 20-200 tracks at overlap 0.8 took 0.5-0.9 of the time of that grouping
in one run (docs/benchmarks.md, "clingo on KITTI, end to end")."""

LEGACY_PART_NODES = 16
"""The grouping before issue 38: 16 own nodes, context tracks not counted (``split(problem, 16)``).
A frame whose grouping by PART_NODES has a sum beyond clingo's range is solved in this one when it
fits (``clingo_parts``): no frame that clingo solved with it is refused."""


def clingo_parts(problem: FrameProblem, part_nodes: int = PART_NODES) -> list[Part]:
    """The sub-problems the clingo backend hands to clingo: components grouped up to
    ``part_nodes`` nodes, context tracks counted, a group closed before its level 10..1 sums would
    leave clingo's 32-bit range (refimpl.core.ranges.counts_fit_clingo); if a sub-problem still
    does not fit (a single unit too large, or level 0), the grouping of ``LEGACY_PART_NODES``
    when that fits; else OutOfClingoRange, as ``check_representable`` raises it."""
    consts = resolve_constants(problem)
    parts = split(problem, part_nodes, context=True, fits=lambda nt, nd: counts_fit_clingo(consts, nt, nd))
    if not _overflows(parts):
        return parts
    legacy = split(problem, LEGACY_PART_NODES)
    check_representable(problem, legacy)
    return legacy


def _overflows(parts: Sequence[Part]) -> list[str]:
    """Why each sub-problem that clingo cannot represent cannot (refimpl.core.ranges.clingo_overflow)."""
    return [why for part in parts
            if (why := clingo_overflow(part.problem, tiebreak_weights(part.problem).shift)) is not None]


def check_representable(problem: FrameProblem, parts: Sequence[Part] | None = None) -> None:
    """OutOfClingoRange (one line) if any sub-problem clingo would be given (``parts``, by
    default those of ``clingo_parts(problem)``) has an optimisation sum beyond its 32-bit
    integers (refimpl.core.ranges.clingo_overflow); the others are not solved either: an answer for
    part of a frame is no answer."""
    if parts is None:
        clingo_parts(problem)
        return
    bad = _overflows(parts)
    if bad:
        what = "the frame" if len(parts) == 1 else f"{len(bad)} of its {len(parts)} independent sub-problems"
        raise OutOfClingoRange(f"clingo cannot represent {what}: {bad[0]}; the cpsat and cpsat-full "
                               "backends solve it (64-bit sums)", f"t={problem.time}", len(bad))


def _clingo_module():
    """The clingo module; SolverUnavailable (one line) without the 'asp' extra."""
    try:
        import clingo
        import clingo.ast  # noqa: F401  (the model is parsed once: ClingoSolver._program)
    except ImportError:
        raise SolverUnavailable(_INSTALL_HINT) from None
    return clingo


class _Best:
    """Keeps a copy of the last model clingo reports (the best so far); called from clingo's thread."""

    def __init__(self) -> None:
        self.atoms: list[str] | None = None
        self.cost: dict[int, int] = {}
        self.proven = False
        self.count = 0

    def on_model(self, model) -> None:
        self.atoms = [str(sym) for sym in model.symbols(shown=True)]
        self.cost = dict(zip(model.priority, model.cost))
        self.proven = model.optimality_proven
        self.count += 1


class ClingoSolver(Solver):
    """Solves a FrameProblem with clingo and the ASP model in model/*.lp.

    Options: ``threads`` (clingo's --parallel-mode), ``model_files``, ``decompose`` (default True:
    per sub-problem of independent components, up to ``part_nodes`` nodes each, context tracks
    counted: ``clingo_parts``), ``isolate``
    (default True: after ``inline_solves`` solves in this process, clingo runs in a child process
    replaced every ``recycle`` solves, see refimpl.solvers.clingo_worker and clingo_process; False: always in this
    process, whose memory then grows with every symbol clingo sees), ``checked_costs`` (default
    False; True: the cost vector is always the independent checker's, refimpl.solvers.check.recompute_cost,
    never the priorities clingo reports: for a user's encoding, refimpl.solvers.asp_model), ``name``
    (the backend name its answers carry: ``get_solver`` passes its entry's, a user's encoding its label),
    ``certify`` (default: True for the model in model/, False for other ``model_files``; True: each
    solve also gets the certificate of level 10 (refimpl.solvers.certificate) as facts, which
    model/certificate.lp checks and uses to prune, docs/model.md 2.10), ``own_constants`` (the
    constants a user's encoding defines itself, passed to it by no ``-c``: clingo_arguments),
    ``memory_cap`` (bytes of address space for the child process that solves a user's encoding;
    default asp_model.ENCODING_MEMORY; the reference model runs under none: a frame beyond it is
    refused in one line, clingo_process.EncodingMemoryError)."""

    def __init__(self, threads: int = 1, model_files: Sequence[str | Path] | None = None,
                 decompose: bool = True, part_nodes: int = PART_NODES, isolate: bool = True,
                 recycle: int | None = None, inline_solves: int = INLINE_SOLVES, checked_costs: bool = False,
                 name: str = CLINGO, certify: bool | None = None, own_constants: Sequence[str] = (),
                 memory_cap: int | None = None):
        if int(threads) < 1:
            raise ValueError(f"threads must be >= 1, got {threads}")
        self._clingo = _clingo_module()
        self.name = name
        """The registry name it answers under (``get_solver`` passes its entry's)."""
        self.threads = int(threads)
        self.decompose = decompose
        self.part_nodes = int(part_nodes)
        self.model_files = (
            tuple(Path(p) for p in model_files) if model_files is not None else default_model_files()
        )
        self.own_constants = tuple(own_constants)
        """Constants the encoding defines itself: no ``-c`` for them (clingo_arguments)."""
        self.certify = (model_files is None) if certify is None else bool(certify)
        """Whether a solve passes the certificate facts (model/certificate.lp checks them)."""
        self.certificate_withdrawn: tuple[str, ...] = ()
        """Why the encoding is not offered the certificate although asked (its preconditions,
        refimpl.solvers.asp_model.certificate_preconditions); () when it is, or was not asked."""
        if self.certify:
            self.certificate_withdrawn = certificate_preconditions(self.model_files)
            self.certify = not self.certificate_withdrawn
        self.isolate = isolate
        self.checked_costs = bool(checked_costs)
        self.inline_solves = int(inline_solves)
        self._calls = 0
        self._statements = None
        """The model files parsed once (clingo.ast statements), added to each solve's Control:
        parsing the text again for every call cost ~2 ms of each (``_program``)."""
        self._worker = None
        if isolate:  # clingo in a child process (refimpl.solvers.clingo_process): bounded memory
            # a user's encoding runs under the memory cap of its check (asp_model.ENCODING_MEMORY);
            # the reference model under none
            cap = None if model_files is None else (memory_cap or ENCODING_MEMORY)
            self._worker = ClingoWorker({"threads": self.threads, "model_files": self.model_files,
                                         "certify": self.certify, "own_constants": self.own_constants,
                                         "memory_cap": cap},
                                        DEFAULT_RECYCLE if recycle is None else recycle)

    def __getstate__(self) -> dict:
        """Pickled (``pickle``, ``copy.deepcopy``, a Dask task) without the clingo module and the
        worker's child process, which cannot be pickled: the copy imports clingo again on
        unpickling and starts a child of its own when it first needs one (ClingoWorker's state).
        clingo keeps nothing between two solves, so the copy answers as the original does."""
        state = dict(self.__dict__)
        del state["_clingo"]
        state["_statements"] = None  # clingo's AST cannot be pickled: parsed again by the copy
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._clingo = _clingo_module()

    @property
    def child_cpu_seconds(self) -> float:
        """CPU time clingo's worker processes spent in this solver's solves (benchmarks add it)."""
        return 0.0 if self._worker is None else self._worker.cpu_seconds

    # ------------------------------------------------------------------------------------
    def control(self, problem: FrameProblem, extra: str = "", certify: bool = False):
        """A clingo Control with the model and the problem loaded, not yet grounded.

        ``extra`` is more ASP text for the same program (tests use it to force atoms).  It has no
        certificate facts (their pruning keeps only answers optimal at level 10, and tests force
        others), unless ``certify``.
        """
        return self._control(problem, (certificate_facts(certificate(problem)) if certify else "") + extra)[0]

    def _control(self, problem: FrameProblem, extra: str = ""):
        messages: list[str] = []

        def logger(code, message: str) -> None:
            messages.append(" ".join(message.split()))

        ctl = self._clingo.Control(clingo_arguments(problem, self.threads, self.certify, self.own_constants),
                                   logger=logger,
                                   message_limit=20)
        try:
            statements = self._program(logger)
            with self._clingo.ast.ProgramBuilder(ctl) as builder:
                for statement in statements:
                    builder.add(statement)
            ctl.add("base", [], problem_facts(problem) + extra)
        except RuntimeError as exc:
            raise RuntimeError(f"clingo could not parse the model: {'; '.join(messages) or exc}") from None
        return ctl, messages

    def _program(self, logger) -> tuple:
        """The statements of the model files but their comments, parsed at the first call (each
        file begins in ``#program base.``, as ``Control.load`` reads it); RuntimeError, its messages sent to
        ``logger``, where clingo cannot parse one (then parsed again at the next call)."""
        if self._statements is None:
            statements: list = []
            self._clingo.ast.parse_files([str(path) for path in self.model_files], statements.append,
                                         logger=logger, message_limit=20)
            comment = getattr(self._clingo.ast.ASTType, "Comment", None)  # 390 of model/'s 652 statements
            self._statements = tuple(s for s in statements if s.ast_type != comment)
        return self._statements

    def solve(self, problem: FrameProblem, time_limit: float | None = None,
              budget: float | None = None) -> Hypothesis:
        """The optimal hypothesis, or with ``time_limit`` (seconds) the best found in time (the
        time-out contract of refimpl.solvers; ``budget``, the frame budget's seconds left, ends the
        search the same way).  The frame is solved per sub-problem of independent components
        (refimpl.solvers.decompose) unless ``decompose=False``."""
        started = time.perf_counter()
        time_limit = effective_limit(time_limit, budget)
        deadline = None if time_limit is None else started + time_limit
        if self.decompose:
            parts = clingo_parts(problem, self.part_nodes)
        else:
            parts = [Part(problem, frozenset())]
            check_representable(problem, parts)
        whole = len(parts) == 1
        actions: list[str] = []
        events: list[str] = []
        optimal = True
        cost: dict[int, int] = {}
        for n, part in enumerate(parts):
            now = time.perf_counter()
            if deadline is not None and now >= deadline:
                found = None
            else:
                share = None if deadline is None else deadline - now  # all that is left: most parts are trivial
                self._calls += 1
                in_child = self._worker is not None and (
                    self._calls > self.inline_solves or (share is not None and len(part.problem.iou) >= KILLABLE_IOU))
                found = self._worker.solve_one(part.problem, share) if in_child else self._solve_one(part.problem, share)
            if found is None:  # out of time without a model: the obvious answer of this part
                fallback = obvious_hypothesis(part.problem, self.name)
                if fallback is None:
                    limit = "none" if time_limit is None else f"{time_limit:g} s"
                    raise SolveTimeout(f"no answer at t={problem.time} within the time limit ({limit})")
                atoms = list(fallback.actions) + list(fallback.events)
                part_optimal = False
            else:
                atoms, cost, part_optimal = found
            optimal = optimal and part_optimal
            evs = [a for a in atoms if parse_atom(a).name == "occurs_at"]
            acts = [a for a in atoms if parse_atom(a).name != "occurs_at"]
            if not whole:
                acts, evs = own_atoms(part, acts, evs)
            actions += acts
            events += evs
        if whole and cost and optimal is not None and found is not None and not self.checked_costs:
            levels = {p: cost.get(p, 0) for p in PRIORITIES}
        else:  # several parts (or the fallback): the levels of the merged answer
            names = [event_of(e).name for e in events]
            levels = dict(recompute_cost(problem, actions, names, events, resolve_constants(problem)))
        levels[TIEBREAK_LEVEL] = tiebreak_level(problem, actions, events)
        return Hypothesis(
            time=problem.time,
            actions=tuple(actions),
            events=tuple(events),
            cost=tuple((p, levels[p]) for p in PRIORITIES),
            optimal=optimal,
            backend=self.name,
            solve_ms=(time.perf_counter() - started) * 1000.0,
        )

    def _solve_one(self, problem: FrameProblem, time_limit: float | None, grounded=None):
        """(shown atoms, cost by priority, proven optimal) of one clingo call, or None when the
        time ran out before any model; NoAdmissibleHypothesis when the program has no model.
        ``grounded``: called once grounding is done (the worker process tells its parent, which
        kills a child still grounding at its limit at once: refimpl.solvers.clingo_process)."""
        started = time.perf_counter()
        deadline = None if time_limit is None else started + time_limit
        ctl, messages = self._control(problem, certificate_facts(certificate(problem)) if self.certify else "")
        try:
            ctl.ground([("base", [])])
        except RuntimeError as exc:
            msgs = "; ".join(messages) or str(exc)
            raise RuntimeError(f"clingo could not ground the model: {msgs}") from None
        if self.certify and not _certificate_holds(ctl, self._clingo):
            _branch_and_bound(ctl)
        if grounded is not None:
            grounded()
        if deadline is not None and time.perf_counter() >= deadline:
            return None  # grounding used the time up (it counts; it cannot be stopped half-way)

        best = _Best()
        timed_out = False
        with ctl.solve(on_model=best.on_model, async_=True) as handle:
            # short waits: a SIGINT raises KeyboardInterrupt here within POLL seconds, and
            # leaving the with block cancels the search
            while True:
                wait = POLL if deadline is None else min(POLL, deadline - time.perf_counter())
                if wait <= 0:
                    handle.cancel()
                    timed_out = True
                    break
                if handle.wait(wait):
                    break
            result = handle.get()
        if best.atoms is None:
            if timed_out:
                return None
            if result.unsatisfiable:
                raise NoAdmissibleHypothesis(
                    f"no admissible hypothesis at t={problem.time}: every candidate answer breaks a rule of the model")
            return None
        optimal = (bool(result.exhausted) and not timed_out) or best.proven
        return best.atoms, best.cost, optimal
