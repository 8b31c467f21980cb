"""A user's own ASP encoding of the model (``refimpl diff --asp-model DIR``), checked before use.

The one place where text a user wrote reaches clingo as a program: only the ``.lp`` files of a
folder named by that explicit option, never anything read from a data file.  The encoding gets
refimpl's fact interface (docs/model.md, "Your own encoding"): the frame problem's facts
(refimpl.core.spec.FrameProblem.to_facts without its ``#const`` lines), the tie-break facts
``tiebreak_pair/4`` and ``tiebreak_event/3`` (refimpl.solvers.common.tiebreak_facts) and every
model constant as ``-c name=value``; refimpl reads back the shown ``assign/2``, ``start/1``,
``end/1``, ``halt/1``, ``resume/2``, ``ignore_det/1``, ``ignore_trk/1`` and
``occurs_at(E, curr_time)`` atoms.  The costs of an answer are always recomputed by the
independent checker (refimpl.solvers.check), whatever priorities the encoding uses.

``load_asp_model(folder)`` reads the folder once: every ``*.lp`` file in name order, each parsed
and the whole grounded once without a problem (so a syntax error or an unsafe variable is found
before any frame is solved), and whether the encoding optimises refimpl's canonical tie-break,
i.e. whether a ``#minimize``/``#maximize`` element or weak constraint reads ``tiebreak_pair`` or
``tiebreak_event`` (comments and ``#defined`` lines do not count).  Without it the encoding can
only be compared on levels 10..1: two answers equal there are a tie the tie-break would decide.

The encoding runs with its own constants: refimpl passes ``-c name=value`` only for the constants
of the frame problem itself (``curr_time``, the image size, what the user set) and for the model
constants the folder does not define, so a ``#const iou_thresh=5000.`` in the user's copy is what
runs.  ``AspModel.differences`` is one line, printed before any frame is solved, naming every
constant whose value differs from the reference encoding's (model/) and every event, action and
fluent one of the two derives and the other does not (read off the rule heads: an event is the
functor under ``occurs_at/2``, a fluent the functor under ``fluent/1``, an action a derived
predicate that refimpl's action table or the encoding's ``#show`` names).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Sequence

from ..core.constants import default_constants, model_dir
from ..core.hypothesis import ACTION_TABLE
from ..core.records import read_text
from .certificate import CERTIFIED_STATEMENTS
from .clingo_process import kill_child, start_child, wait_reply

TIEBREAK_PREDICATES = ("tiebreak_pair", "tiebreak_event")


class AspModelError(ValueError):
    """The folder is not a usable encoding (one line: which folder, which file, why)."""


PROBE = "refimpl_constant_probe__"
"""The predicate of the facts through which clingo tells a constant's value (never shown)."""


@dataclass(frozen=True)
class Vocabulary:
    """What an encoding derives, read off its rule heads (module docstring), and its constants."""

    defined: tuple[str, ...]
    """The constants its files define (#const), in name order."""
    constants: tuple[tuple[str, str], ...]
    """(name, value as clingo prints it) of every model constant and every constant it defines,
    with the values it runs with (its own, else refimpl's ``-c``), in name order."""
    events: tuple[str, ...]
    actions: tuple[str, ...]
    fluents: tuple[str, ...]


@dataclass(frozen=True)
class AspModel:
    folder: Path
    files: tuple[Path, ...]
    """Every *.lp file of the folder, in name order."""
    tiebreak: bool
    """Whether the encoding optimises refimpl's level-0 tie-break (module docstring)."""
    vocabulary: Vocabulary | None = None
    """Its constants, events, actions and fluents (None: not read, e.g. built by hand in a test)."""

    @property
    def label(self) -> str:
        """How reports name the backend running it: clingo[folder name]."""
        return f"clingo[{self.folder.name}]"

    @property
    def defined(self) -> tuple[str, ...]:
        """The constants its files define: refimpl passes no ``-c`` for them (module docstring)."""
        return () if self.vocabulary is None else self.vocabulary.defined

    def differences(self) -> str:
        """One line: every constant whose value differs from the reference encoding's, every
        event, action and fluent in one of the two only; or that there is none."""
        mine, ref = self.vocabulary, reference_vocabulary()
        if mine is None:
            return f"{self.label} against model/: not read"
        parts: list[str] = []
        ours, theirs = dict(mine.constants), dict(ref.constants)
        changed = [f"{n}={ours.get(n, 'undefined')} (model/: {theirs.get(n, 'undefined')})"
                   for n in sorted(set(ours) | set(theirs)) if ours.get(n) != theirs.get(n)]
        if changed:
            parts.append(f"{len(changed)} constant{'s differ' if len(changed) > 1 else ' differs'}: "
                         f"{', '.join(changed)}")
        for kind in ("events", "actions", "fluents"):
            a, b = set(getattr(mine, kind)), set(getattr(ref, kind))
            if b - a:
                parts.append(f"{kind} only in model/: {', '.join(sorted(b - a))}")
            if a - b:
                parts.append(f"{kind} only in {self.label}: {', '.join(sorted(a - b))}")
        if not parts:
            return f"{self.label} against model/: the same constants, events, actions and fluents"
        return f"{self.label} against model/: " + "; ".join(parts)


def load_asp_model(folder: str | Path, time_limit: float | None = None) -> AspModel:
    """The encoding in ``folder``, checked (module docstring); AspModelError if it is unusable,
    RuntimeError-free: every clingo complaint becomes that one line.  The check grounds the
    encoding in a child process (``_read_encoding_in_child``): one that grounds longer than
    ``time_limit`` seconds (None: no limit) or beyond ENCODING_MEMORY is refused, and a Ctrl-C
    meanwhile ends it."""
    root = Path(folder)
    if not root.exists():
        raise AspModelError(f"--asp-model {folder}: no such folder")
    if not root.is_dir():
        raise AspModelError(f"--asp-model {folder}: not a folder")
    files = tuple(sorted(p for p in root.glob("*.lp") if p.is_file()))
    if not files:
        raise AspModelError(f"--asp-model {folder}: no .lp files in it")
    tiebreak, vocabulary = _read_encoding_in_child(files, f"--asp-model {folder}", time_limit)
    return AspModel(root, files, tiebreak, vocabulary)


CHECK_MODULE = "refimpl.solvers.asp_model_worker"
"""The child program that checks a user's encoding (``python -m CHECK_MODULE FD``)."""
ENCODING_MEMORY = 2 * 2 ** 30
"""Bytes of address space the check of a user's encoding may use (the reference encoding's
check: ~0.3 GB with Python and clingo loaded): grounding without end is refused here rather than
by the machine's OOM killer."""
CHILD_START = 120.0
"""Seconds the checking process may take to start (Python and clingo imported) before it is given up."""


def _read_encoding_in_child(files: Sequence[Path], where: str, time_limit: float | None) -> tuple[bool, Vocabulary]:
    """``_read_encoding`` in a child process (refimpl.solvers.asp_model_worker), killed when it
    grounds longer than ``time_limit`` seconds after clingo's import, or when this process is
    interrupted (KeyboardInterrupt, the command line's SIGTERM); AspModelError naming the limit."""
    proc, conn = start_child(CHECK_MODULE)
    try:
        conn.send((tuple(str(f) for f in files), where, ENCODING_MEMORY))
        reply = wait_reply(proc, conn, CHILD_START)
        if reply is None:
            raise AspModelError(f"{where}: the clingo process that checks it did not start within {CHILD_START:g} s")
        if reply[0] == "ready":
            reply = wait_reply(proc, conn, time_limit)
    except RuntimeError:  # it ended without a word: clingo aborts when an allocation fails
        raise AspModelError(f"{where}: grounding it without a frame ended the clingo process (exit code "
                            f"{proc.returncode}), likely beyond its memory cap of {ENCODING_MEMORY / 2 ** 30:g} GiB: "
                            "does a rule derive atoms without end, such as p(X+1) :- p(X)?") from None
    finally:
        kill_child(proc, conn)
    if reply is None:
        raise AspModelError(f"{where}: grounding it without a frame took longer than the time limit "
                            f"({time_limit:g} s, --time-limit): does a rule derive atoms without end, such as "
                            "p(X+1) :- p(X)?")
    if reply[0] == "memory":
        raise AspModelError(f"{where}: grounding it without a frame went beyond the memory cap of "
                            f"{ENCODING_MEMORY / 2 ** 30:g} GiB: does a rule derive atoms without end, such as "
                            "p(X+1) :- p(X)?")
    if reply[0] == "error":
        raise AspModelError(reply[1])
    return reply[1]


def clingo_module(where: str):
    """clingo, imported (AspModelError naming ``where`` without it)."""
    try:
        import clingo
        import clingo.ast  # noqa: F401
    except ImportError:
        raise AspModelError("--asp-model needs clingo: pip install 'refimpl[asp]'") from None
    return clingo


def read_encoding(files: Sequence[str | Path], where: str) -> tuple[bool, Vocabulary]:
    """``_read_encoding`` for the child process (refimpl.solvers.asp_model_worker)."""
    return _read_encoding(tuple(Path(f) for f in files), where)


@lru_cache(maxsize=1)
def reference_vocabulary() -> Vocabulary:
    """The reference encoding's (model/*.lp) constants, events, actions and fluents."""
    return _read_encoding(tuple(sorted(model_dir().glob("*.lp"))), "model/")[1]


def _read_encoding(files: Sequence[Path], where: str) -> tuple[bool, Vocabulary]:
    """(whether it optimises the tie-break, its vocabulary) of the encoding ``files``: each file
    parsed, then the whole grounded once without a problem, with the constants it does not define
    from refimpl (clingo reports unsafe variables and the like only then); AspModelError naming
    ``where`` on any clingo complaint."""
    clingo = clingo_module(where)
    messages: list[str] = []

    def logger(code, message: str) -> None:
        messages.append(" ".join(message.split()))

    def first_error(exc: Exception) -> str:
        errors = [m for m in messages if "error" in m] or messages
        return errors[0] if errors else str(exc)

    uses_tiebreak = False
    defined: set[str] = set()
    shown: set[str] = set()
    heads: list = []  # the symbolic atoms of every rule head

    def visit(stm) -> None:
        nonlocal uses_tiebreak
        kind = stm.ast_type
        if kind == clingo.ast.ASTType.Minimize and any(p + "(" in str(stm) for p in TIEBREAK_PREDICATES):
            uses_tiebreak = True
        elif kind == clingo.ast.ASTType.Definition:
            defined.add(stm.name)
        elif kind == clingo.ast.ASTType.ShowSignature and stm.positive:
            shown.add(stm.name)
        elif kind == clingo.ast.ASTType.Rule:
            heads.extend(n.symbol for n in _nodes(stm.head, clingo.ast)
                         if n.ast_type == clingo.ast.ASTType.SymbolicAtom)

    for path in files:
        try:
            clingo.ast.parse_files([str(path)], visit, logger=logger, message_limit=5)
        except RuntimeError as exc:
            raise AspModelError(f"{where}: {first_error(exc)}") from None
    names = sorted(defined | set(default_constants()))
    args = [x for name, value in default_constants().items() if name not in defined
            for x in ("-c", f"{name}={value}")]
    args += ["-c", "curr_time=0"]
    ctl = clingo.Control(args, logger=logger, message_limit=5)
    probe = "".join(f'{PROBE}("{n}", {n}).\n' for n in names if n != "curr_time")
    try:
        for path in files:
            ctl.load(str(path))
        ctl.add("base", [], probe)
        ctl.ground([("base", [])])
    except RuntimeError as exc:
        raise AspModelError(f"{where}: {first_error(exc)}") from None
    values: dict[str, str] = {}
    for atom in ctl.symbolic_atoms.by_signature(PROBE, 2):
        name, value = atom.symbol.arguments
        # a name no file defines and refimpl does not pass stays a symbol of that name: undefined
        values[name.string] = "undefined" if str(value) == name.string else str(value)
    actions = set(ACTION_TABLE) | (shown - {"occurs_at"})
    events, fluents, derived = set(), set(), set()
    for term in heads:
        if term.ast_type != clingo.ast.ASTType.Function:
            continue
        derived.add(term.name)
        inner = term.arguments[0] if len(term.arguments) >= 1 else None
        if inner is None or inner.ast_type != clingo.ast.ASTType.Function:
            continue
        if term.name == "occurs_at" and len(term.arguments) == 2:
            events.add(inner.name)
        elif term.name == "fluent" and len(term.arguments) == 1:
            fluents.add(inner.name)
    vocabulary = Vocabulary(tuple(sorted(defined)), tuple(sorted(values.items())), tuple(sorted(events)),
                            tuple(sorted(derived & actions)), tuple(sorted(fluents)))
    return uses_tiebreak, vocabulary


def _nodes(node, ast):
    """Every AST node under ``node`` (itself included), depth first."""
    yield node
    for key in node.child_keys:
        child = getattr(node, key)
        if child is None:
            continue
        if isinstance(child, ast.AST):
            yield from _nodes(child, ast)
        else:
            for c in child:
                yield from _nodes(c, ast)


CERTIFICATE_ATOMS = ("ignore_det", "ignore_trk")
"""The solo actions the certificate's witness relies on (docs/model.md 2.10)."""


def certificate_preconditions(files: Sequence[str | Path]) -> tuple[str, ...]:
    """Why the level-10 certificate (refimpl.solvers.certificate) is not sound for the encoding
    ``files``, one reason per statement, in file order; () when it is.  A statement breaks the
    preconditions if it is not one of CERTIFIED_STATEMENTS and mentions ignore_det or ignore_trk,
    or weighs at a priority of 5 or more (a term at 6..9 or above 10 would change which answers
    are optimal at level 10 too), or at one that is not a number.  A file clingo cannot
    parse is a reason too (the solve reports the error itself)."""
    return _preconditions(tuple((str(f), read_text(f)) for f in files))


@lru_cache(maxsize=8)
def _preconditions(texts: tuple[tuple[str, str], ...]) -> tuple[str, ...]:
    import clingo.ast
    reasons: list[str] = []
    for name, text in texts:
        def visit(stm) -> None:
            kind = stm.ast_type
            if kind in (clingo.ast.ASTType.Comment, clingo.ast.ASTType.ShowSignature, clingo.ast.ASTType.Program):
                return
            printed = str(stm)
            if printed in CERTIFIED_STATEMENTS:
                return
            atoms = {n.symbol.name for n in _nodes(stm, clingo.ast) if n.ast_type == clingo.ast.ASTType.SymbolicAtom
                     and n.symbol.ast_type == clingo.ast.ASTType.Function}
            if atoms & set(CERTIFICATE_ATOMS):
                reasons.append(f"{Path(name).name}:{stm.location.begin.line}: {printed} reads "
                               f"{' and '.join(sorted(atoms & set(CERTIFICATE_ATOMS)))}")
            elif kind == clingo.ast.ASTType.Minimize and not _below_level_5(str(stm.priority)):
                reasons.append(f"{Path(name).name}:{stm.location.begin.line}: {printed} weighs at priority "
                               f"{stm.priority}")

        try:
            clingo.ast.parse_string(text, visit, logger=lambda code, message: None)
        except RuntimeError:
            reasons.append(f"{Path(name).name}: clingo cannot parse it")
    return tuple(reasons)


def _below_level_5(priority: str) -> bool:
    """Whether a priority, as clingo prints it, is an integer below 5."""
    try:
        return int(priority) < 5
    except ValueError:  # a variable or an expression: unknown
        return False
