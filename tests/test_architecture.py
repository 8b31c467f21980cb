"""The layer table of docs/architecture.md holds for the code: every module of refimpl/ is in
exactly one layer, and imports refimpl modules only from its own layer or the layers it may use."""

from __future__ import annotations

import ast

import pytest
import re
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PACKAGE = REPO / "refimpl"
DOC = REPO / "docs" / "architecture.md"


def layer_table() -> tuple[dict[str, str], dict[str, set[str]]]:
    """module -> layer, and layer -> the layers it may import (its own included)."""
    module_layer: dict[str, str] = {}
    may: dict[str, set[str]] = {}
    for line in DOC.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4 or not cells[1].startswith("`"):
            continue
        layer = cells[0]
        for module in re.findall(r"`([\w.]+)`", cells[1]):
            assert module not in module_layer, f"{module} is in two layers"
            module_layer[module] = layer
        may[layer] = {layer} | {x.strip() for x in cells[2].split(",") if x.strip() not in ("", "—")}
    return module_layer, may


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
    module_layer, _ = layer_table()
    missing = sorted(set(modules()) - set(module_layer))
    unknown = sorted(set(module_layer) - set(modules()))
    assert not missing, f"modules missing from docs/architecture.md: {missing}"
    assert not unknown, f"docs/architecture.md names modules that do not exist: {unknown}"


def test_every_import_respects_the_layers():
    module_layer, may = layer_table()
    bad = []
    for name, path in modules().items():
        for dep in sorted(refimpl_imports(path)):
            if dep not in module_layer:
                continue  # a package re-export ('refimpl' itself)
            if module_layer[dep] not in may[module_layer[name]]:
                bad.append(f"{name} ({module_layer[name]}) imports {dep} ({module_layer[dep]})")
    assert not bad, "\n".join(bad)


def test_the_checker_can_tell_a_bad_import():
    # the layer rule must be able to fail: the loop may not import the files layer
    module_layer, may = layer_table()
    assert module_layer["io"] not in may[module_layer["tracker"]]
    assert module_layer["cli"] not in may[module_layer["solvers.cpsat"]]


def test_every_package_folder_is_installed():
    # a non-editable `pip install .` installs only the packages pyproject.toml lists: a new
    # package folder missing there breaks the installed `refimpl` command, not the checkout
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]["packages"])
    folders = {".".join(p.parent.relative_to(REPO).parts) for p in PACKAGE.rglob("__init__.py")}
    assert folders <= listed, f"package folders missing from pyproject.toml: {sorted(folders - listed)}"
