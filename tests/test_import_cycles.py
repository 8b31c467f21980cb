"""No import cycle among refimpl's modules, counting every import statement at any depth: a
function-local import (``def f(): from .x import y``) is an edge like a top-level one, so a
cycle cannot hide behind a deferred import.  (Deferred imports stay allowed for optional or heavy
third-party libraries; between refimpl modules they would only hide the order of the layers.)"""

from __future__ import annotations

import ast

from test_architecture import modules, refimpl_imports


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


def _top_level_import_lines(path) -> set[int]:
    return {n.lineno for n in ast.parse(path.read_text(encoding="utf-8")).body
            if isinstance(n, (ast.Import, ast.ImportFrom))}


def test_local_imports_are_edges():
    # cli.scenes imports scene.report_html, and tracking.pipeline imports tracking.tracker, only
    # inside functions (the command modules load what a command needs when it runs): both are
    # edges of the graph
    graph = import_graph()
    mods = modules()
    for module, target, text in (("cli.scenes", "scene.report_html", "from ..scene.report_html import"),
                                 ("tracking.pipeline", "tracking.tracker", "from .tracker import")):
        source = mods[module].read_text(encoding="utf-8").splitlines()
        lines = {i for i, line in enumerate(source, start=1) if line.strip().startswith(text)}
        assert lines and not lines & _top_level_import_lines(mods[module]), (module, target)
        assert target in graph[module], (module, target)


def test_no_import_cycle_among_refimpl_modules():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)
