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
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..core.constants import default_constants

TIEBREAK_PREDICATES = ("tiebreak_pair", "tiebreak_event")


class AspModelError(ValueError):
    """The folder is not a usable encoding (one line: which folder, which file, why)."""


@dataclass(frozen=True)
class AspModel:
    folder: Path
    files: tuple[Path, ...]
    """Every *.lp file of the folder, in name order."""
    tiebreak: bool
    """Whether the encoding optimises refimpl's level-0 tie-break (module docstring)."""

    @property
    def label(self) -> str:
        """How reports name the backend running it: clingo[folder name]."""
        return f"clingo[{self.folder.name}]"


def load_asp_model(folder: str | Path) -> AspModel:
    """The encoding in ``folder``, checked (module docstring); AspModelError if it is unusable,
    RuntimeError-free: every clingo complaint becomes that one line."""
    root = Path(folder)
    if not root.exists():
        raise AspModelError(f"--asp-model {folder}: no such folder")
    if not root.is_dir():
        raise AspModelError(f"--asp-model {folder}: not a folder")
    files = tuple(sorted(p for p in root.glob("*.lp") if p.is_file()))
    if not files:
        raise AspModelError(f"--asp-model {folder}: no .lp files in it")
    try:
        import clingo
        import clingo.ast
    except ImportError:
        raise AspModelError("--asp-model needs clingo: pip install 'refimpl[asp]'") from None
    messages: list[str] = []

    def logger(code, message: str) -> None:
        messages.append(" ".join(message.split()))

    def first_error(exc: Exception) -> str:
        errors = [m for m in messages if "error" in m] or messages
        return errors[0] if errors else str(exc)

    uses_tiebreak = False

    def visit(stm) -> None:
        nonlocal uses_tiebreak
        if stm.ast_type == clingo.ast.ASTType.Minimize and any(p + "(" in str(stm) for p in TIEBREAK_PREDICATES):
            uses_tiebreak = True

    for path in files:
        try:
            clingo.ast.parse_files([str(path)], visit, logger=logger, message_limit=5)
        except RuntimeError as exc:
            raise AspModelError(f"--asp-model {folder}: {first_error(exc)}") from None
    # ground once without a problem: clingo reports unsafe variables and the like only here
    args = [x for name, value in default_constants().items() for x in ("-c", f"{name}={value}")]
    args += ["-c", "curr_time=0"]
    ctl = clingo.Control(args, logger=logger, message_limit=5)
    try:
        for path in files:
            ctl.load(str(path))
        ctl.ground([("base", [])])
    except RuntimeError as exc:
        raise AspModelError(f"--asp-model {folder}: {first_error(exc)}") from None
    return AspModel(root, files, uses_tiebreak)
