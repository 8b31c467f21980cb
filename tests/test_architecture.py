"""The layer table of docs/architecture.md holds for the code: every module of refimpl/ is in
exactly one layer, and imports refimpl modules only from its own layer or the layers it may use."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PACKAGE = REPO / "refimpl"
DOC = REPO / "docs" / "architecture.md"


def layer_table() -> tuple[dict[str, str], dict[str, set[str]]]:
    """folder (or top-level module) -> layer, and layer -> the layers it may import (its own included).

    The table's second cell names folders (`core/`) and top-level modules (`api`)."""
    place_layer: dict[str, str] = {}
    may: dict[str, set[str]] = {}
    rows = []
    for line in DOC.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4 or not cells[1].startswith("`"):
            continue
        layer = cells[0]
        rows.append(layer)
        for place in re.findall(r"`([\w.]+)/?`", cells[1]):
            assert place not in place_layer, f"{place} is in two layers"
            place_layer[place] = layer
        allowed = {x.strip() for x in cells[2].split(",") if x.strip() not in ("", "—")}
        may[layer] = {layer} | (set(rows) if allowed == {"every layer"} else allowed)
    return place_layer, may


def layer_of(module: str, place_layer: dict[str, str]) -> str | None:
    """A module's layer: that of its folder (the first part of its name), or its own row."""
    return place_layer.get(module.split(".")[0])


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def refimpl_imports(path: Path) -> set[str]:
    """The refimpl modules a file imports (relative or absolute), as names relative to refimpl."""
    here = module_name(path).split(".") if path.name != "__init__.py" else module_name(path).split(".") + ["x"]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - node.level]
                target = [p for p in base if p] + (node.module.split(".") if node.module else [])
            elif node.module and node.module.split(".")[0] == "refimpl":
                target = node.module.split(".")[1:]
            else:
                continue
            names = [a.name for a in node.names]
            # 'from . import x' / 'from .solvers import cpsat': a submodule when such a file exists
            for name in names:
                candidate = ".".join(target + [name])
                if candidate and _is_module(candidate):
                    out.add(candidate)
                elif target:
                    out.add(".".join(target))
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "refimpl" and len(a.name.split(".")) > 1:
                    out.add(".".join(a.name.split(".")[1:]))
    return {m for m in out if m}


def _is_module(name: str) -> bool:
    p = PACKAGE.joinpath(*name.split("."))
    return p.with_suffix(".py").is_file() or (p / "__init__.py").is_file()


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py")) if module_name(p)}


def test_every_module_is_in_exactly_one_layer():
    # every folder of refimpl/ and every top-level module is a row of the table ('refimpl'
    # itself, the package's public names, is exempt); and the table names nothing that is gone
    place_layer, _ = layer_table()
    missing = sorted(m for m in modules() if layer_of(m, place_layer) is None)
    places = {m.split(".")[0] for m in modules()}
    unknown = sorted(set(place_layer) - places)
    assert not missing, f"modules in no layer of docs/architecture.md: {missing}"
    assert not unknown, f"docs/architecture.md names folders or modules that do not exist: {unknown}"


def test_the_folders_are_the_layers():
    # no module of the package but the face's sits at the top: the folders show the layers
    place_layer, _ = layer_table()
    top = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")
    assert all(place_layer.get(m) == "face" for m in top), top


def test_every_import_respects_the_layers():
    place_layer, may = layer_table()
    bad = []
    for name, path in modules().items():
        here = layer_of(name, place_layer)
        for dep in sorted(refimpl_imports(path)):
            there = layer_of(dep, place_layer)
            if there is None or here is None:
                continue  # a package re-export ('refimpl' itself)
            if there not in may[here]:
                bad.append(f"{name} ({here}) imports {dep} ({there})")
    assert not bad, "\n".join(bad)


def test_the_checker_can_tell_a_bad_import():
    # the layer rule must be able to fail: the loop may not import the files layer, a solver
    # not the command line
    place_layer, may = layer_table()
    assert layer_of("io.results", place_layer) not in may[layer_of("tracking.tracker", place_layer)]
    assert layer_of("cli.parser", place_layer) not in may[layer_of("solvers.cpsat", place_layer)]
    assert layer_of("runs.diff", place_layer) not in may[layer_of("scene.queries", place_layer)]


def test_every_package_folder_is_installed():
    # a non-editable `pip install .` installs only the packages pyproject.toml lists: a new
    # package folder missing there breaks the installed `refimpl` command, not the checkout
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]["packages"])
    folders = {".".join(p.parent.relative_to(REPO).parts) for p in PACKAGE.rglob("__init__.py")}
    assert folders <= listed, f"package folders missing from pyproject.toml: {sorted(folders - listed)}"


# The product's entry points: the library, and the modules of the commands a user tracks, solves,
# cross-checks, scores and reads scenes with (cli.parser.COMMANDS: track; solve and diff; eval;
# query, explain, plot, report, render).
PRODUCT_ROOTS = ("api", "cli.tracking", "cli.solving", "cli.evaluation", "cli.scenes")

def reached_from(roots) -> dict[str, str]:
    """Every refimpl module importing the roots loads, each with the module that first imports it:
    a module's refimpl imports and the packages it sits in (importing a.b.c runs a/__init__ and
    a/b/__init__ first)."""
    known = modules()
    by: dict[str, str] = {r: "" for r in roots}
    todo = list(roots)
    while todo:
        here = todo.pop()
        parts = here.split(".")
        parents = {".".join(parts[:i]) for i in range(1, len(parts))}
        for dep in sorted(refimpl_imports(known[here]) | parents):
            if dep in known and dep not in by:
                by[dep] = here
                todo.append(dep)
    return by


def test_the_product_does_not_reach_the_lab_bench():
    # experiments/ holds what is measured; the library and the product's commands run through
    # runs/, tracking/ and below, never through it (issue 40)
    # (the parser, which builds every command's options, the benchmarks' too, reads the names
    # their help lists from registries below: tracking.peer_table, io.shifts, io.datasets)
    by = reached_from(PRODUCT_ROOTS)
    bench = {m: by[m] for m in by if m.split(".")[0] == "experiments"}
    assert not bench, "\n".join(f"{m} imported by {i}" for m, i in sorted(bench.items()))
    assert "cli.parser" in by
    # the product's runner sits below experiments/: the layer table keeps it there
    place_layer, may = layer_table()
    assert "experiments" not in may[layer_of("runs.scaleout", place_layer)]
    assert {"runs.scaleout", "runs.tasks", "runs.diff", "runs.progress"} <= set(by)


def test_the_product_check_can_tell_a_bench_import():
    # the walk follows packages and relative imports: benchmark's module reaches the benchmarks
    assert "experiments.benchmarks" in reached_from(["cli.benchmarks"])
    assert "experiments.benchmarks" not in reached_from(PRODUCT_ROOTS)


def test_the_product_loads_no_bench_module():
    # the same, as Python loads it: importing the library and the product's command modules puts
    # no module of experiments/ in sys.modules, nor building the parser of every command
    code = ("import sys, " + ", ".join(f"refimpl.{r}" for r in PRODUCT_ROOTS) + "\n"
            "from refimpl.cli.parser import build_parser\nbuild_parser()\n"
            "print(' '.join(sorted(m for m in sys.modules if m.startswith('refimpl.experiments'))))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True).stdout
    assert out.split() == []


# The rooms one can hold in mind (CONTRIBUTING, "House rules"): a module under ~600 lines, a
# function under ~80 (120 at most). Lines are counted as the file has them, docstring and
# comments included: what a reader scrolls through.
MODULE_LINES, FUNCTION_LINES = 600, 120


def long_functions(path: Path, limit: int) -> list[str]:
    """Every function or method of a file longer than ``limit`` lines, with its length."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    shown = path.relative_to(REPO) if path.is_relative_to(REPO) else path
    return [f"{shown}:{node.lineno} {node.name} ({node.end_lineno - node.lineno + 1} lines)"
            for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > limit]


def test_no_module_and_no_function_is_too_long():
    too_long = [f"{p.relative_to(REPO)} ({n} lines)" for p in modules().values()
                if (n := len(p.read_text(encoding="utf-8").splitlines())) > MODULE_LINES]
    too_long += [f for p in modules().values() for f in long_functions(p, FUNCTION_LINES)]
    assert not too_long, "\n".join(too_long)


def test_the_length_check_can_tell_a_long_function(tmp_path):
    # a def line, 119 body lines and one more: 121 lines, one over; the 120-line one passes
    body = "".join(f"    x{i} = {i}\n" for i in range(119))
    path = tmp_path / "long.py"
    path.write_text(f"def ok():\n{body}\ndef long():\n{body}    return 0\n", encoding="utf-8")
    found = long_functions(path, FUNCTION_LINES)
    assert [f.split()[1:] for f in found] == [["long", "(121", "lines)"]]
