"""No import cycle among refimpl's modules, and imports at the top (docs/architecture.md, "Imports").

* The import graph counts every import statement at any depth: a function-local import
  (``def f(): from .x import y``) is an edge like a top-level one, so a cycle cannot hide behind a
  deferred import.
* No refimpl module is imported inside a function: the one lazy loading of refimpl code is a
  registry entry naming its module (``"refimpl.cli.tracking:cmd_track"``), resolved by
  ``refimpl.core.loader.load``, the only user of ``importlib.import_module`` / ``__import__``.
* A heavy or optional third-party library is imported inside a function (never at a module's top)
  and only by the module(s) the table of docs/architecture.md names for it.
"""

from __future__ import annotations

import ast
import re
import sys

from refimpl.cli.parser import COMMANDS, build_parser
from refimpl.core.loader import load
from test_architecture import DOC, modules, refimpl_imports

LOADER = "core.loader"
"""The one module that imports by name (refimpl.core.loader)."""

NOT_YET: dict[str, str] = {}
"""Modules whose function-local refimpl imports are tolerated for now, with the reason; a module may
leave this list (it is not required to have one), never join it."""

TOP_LEVEL_LIBRARIES = {"numpy"}
"""Third-party libraries any module may import at its top (light, and needed by every path)."""


def import_graph() -> dict[str, set[str]]:
    """module -> the refimpl modules it imports (statements at any depth; a package's own
    submodules excluded: ``refimpl.io`` re-exporting ``io.lines`` is not a dependency of
    ``io.lines`` on ``refimpl.io`` unless io.lines imports the package itself)."""
    mods = modules()
    graph = {name: {d for d in refimpl_imports(path) if d in mods and d != name} for name, path in mods.items()}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph as [a, b, ..., a], the first in sorted module order; None if acyclic."""
    colour: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        colour[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if colour.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in colour:
                found = visit(nxt)
                if found:
                    return found
        path.pop()
        colour[node] = 2
        return None

    for start in sorted(graph):
        if start not in colour:
            found = visit(start)
            if found:
                return found
    return None


def test_the_cycle_finder_finds_and_names_a_cycle():
    # a -> b -> c -> a is a cycle (named from a, the first module in sorted order); d -> a is not on it
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_no_import_cycle_among_refimpl_modules():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


# -- where imports are -------------------------------------------------------------------------

def _runtime_statements(tree: ast.Module):
    """(statement, enclosing function name or None) for every import statement and call, at any
    depth, leaving out ``if TYPE_CHECKING:`` blocks (never run)."""
    def walk(node, function):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and isinstance(child.test, ast.Name) and child.test.id == "TYPE_CHECKING":
                continue
            inner = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else function
            if isinstance(child, (ast.Import, ast.ImportFrom, ast.Call)):
                yield child, function
            yield from walk(child, inner)
    yield from walk(tree, None)


def _imported(node) -> list[str]:
    """The absolute names an import statement imports (relative ones as 'refimpl...')."""
    if isinstance(node, ast.ImportFrom):
        return ["refimpl." + (node.module or "") if node.level else node.module or ""]
    return [a.name for a in node.names]


def import_offences(source: str, module: str) -> list[str]:
    """What breaks the import rules in one module's source: ``"<module>:<line>: <statement> (in <function>)"``."""
    out = []
    for node, function in _runtime_statements(ast.parse(source)):
        where = f"{module}:{node.lineno}: {ast.unparse(node)}"
        if isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
            if name in ("import_module", "__import__") and module != LOADER:
                out.append(f"{where} (only refimpl.core.loader imports by name)")
            continue
        names = _imported(node)
        full = [f"{n}.{a.name}" for n in names for a in node.names] if isinstance(node, ast.ImportFrom) else names
        if any(n.split(".")[0] == "importlib" and not n.startswith("importlib.metadata") for n in full) \
                and module != LOADER:
            out.append(f"{where} (only refimpl.core.loader imports by name)")
        if function is not None and any(n == "refimpl" or n.startswith("refimpl.") for n in names):
            out.append(f"{where} (in {function}: import it at the top, or name it in a registry entry)")
    return out


def test_no_refimpl_module_is_imported_inside_a_function():
    offences = []
    for module, path in modules().items():
        found = import_offences(path.read_text(encoding="utf-8"), module)
        if module in NOT_YET:
            found = [f for f in found if "only refimpl.core.loader" in f]
        offences += found
    assert not offences, "imports to move to the top of their module:\n" + "\n".join(offences)


def test_the_import_check_names_a_local_import_and_a_by_name_import():
    # a deliberate violation of each rule, in a module that is not the loader: both are named
    # with their line and (for the local import) the function
    source = ("import numpy as np\n"
              "from .x import y\n"                       # line 2: at the top, allowed
              "def f():\n"
              "    from ..io import outputs\n"           # line 4: a refimpl module inside f
              "    import json\n"                        # line 5: the standard library, allowed
              "    return importlib.import_module(n)\n")  # line 6: by name, outside the loader
    assert import_offences(source, "cli.tracking") == [
        "cli.tracking:4: from ..io import outputs (in f: import it at the top, or name it in a registry entry)",
        "cli.tracking:6: importlib.import_module(n) (only refimpl.core.loader imports by name)"]
    assert import_offences(source, LOADER) == [
        "core.loader:4: from ..io import outputs (in f: import it at the top, or name it in a registry entry)"]


def test_the_tolerated_modules_still_need_it():
    # NOT_YET only shrinks: a module listed there whose local imports are gone must leave it
    mods = modules()
    stale = [m for m in NOT_YET if m not in mods or not import_offences(mods[m].read_text(encoding="utf-8"), m)]
    assert not stale, f"drop {stale} from NOT_YET: no function-local refimpl import left there"


# -- heavy and optional libraries ----------------------------------------------------------------

def wrapper_table() -> dict[str, set[str]]:
    """library -> the modules that may import it, from docs/architecture.md's table under "Imports"."""
    text = DOC.read_text(encoding="utf-8")
    section = text.split("\n## Imports", 1)[1].split("\n## ", 1)[0]
    table: dict[str, set[str]] = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 3 or not cells[0].startswith("`"):
            continue
        for library in re.findall(r"`([\w.]+)`", cells[0]):
            table[library] = set(re.findall(r"`([\w.]+)`", cells[1]))
    return table


def library_offences(source: str, module: str, table: dict[str, set[str]]) -> list[str]:
    """Third-party imports that break the table: a listed library imported by another module or at
    a module's top, an unlisted one (not numpy, not the standard library) anywhere."""
    out = []
    for node, function in _runtime_statements(ast.parse(source)):
        if not isinstance(node, (ast.Import, ast.ImportFrom)) or getattr(node, "level", 0):
            continue
        for name in _imported(node):
            top = name.split(".")[0]
            if top in sys.stdlib_module_names or top in ("refimpl", "__future__") or top in TOP_LEVEL_LIBRARIES:
                continue
            where = f"{module}:{node.lineno}: {ast.unparse(node)}"
            if top not in table:
                out.append(f"{where} ({top} is in no row of docs/architecture.md's library table)")
            elif module not in table[top]:
                out.append(f"{where} ({top} is imported only by {', '.join(sorted(table[top]))})")
            elif function is None:
                out.append(f"{where} (at the top: every command that reaches {module} would import {top})")
    return out


def test_heavy_libraries_are_imported_only_by_their_wrapper_and_only_when_used():
    table = wrapper_table()
    mods = modules()
    assert {"scipy", "motmetrics", "trackeval", "matplotlib", "clingo", "ortools", "dask", "distributed"} <= set(table)
    assert all(m in mods for wrappers in table.values() for m in wrappers), table
    offences = [o for module, path in mods.items()
                for o in library_offences(path.read_text(encoding="utf-8"), module, table)]
    assert not offences, "\n".join(offences)


def test_the_library_check_names_a_stray_and_a_top_level_import():
    table = {"scipy": {"core.assignment"}}
    source = ("import numpy as np\n"
              "import scipy\n"                              # line 2: the wrapper, but at the top
              "def f():\n"
              "    from scipy.optimize import linprog\n"    # line 4: the wrapper, in a function: allowed
              "    import pandas\n")                        # line 5: in no row
    assert library_offences(source, "core.assignment", table) == [
        "core.assignment:2: import scipy (at the top: every command that reaches core.assignment would import scipy)",
        "core.assignment:5: import pandas (pandas is in no row of docs/architecture.md's library table)"]
    assert library_offences("def g():\n    import scipy\n", "tracking.baseline", table) == [
        "tracking.baseline:2: import scipy (scipy is imported only by core.assignment)"]


# -- the command table -----------------------------------------------------------------------------

def test_every_command_is_a_row_of_the_command_table_and_loads():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    assert sorted(sub.choices) == sorted(COMMANDS)
    for name, entry in COMMANDS.items():
        module, _, function = entry.partition(":")
        assert module.startswith("refimpl.cli.") and function.startswith("cmd_"), (name, entry)
        assert callable(load(entry)), (name, entry)
