"""Every list of names the documents and docstrings spell out is its registry's (issue 40, item 5).

A list written by hand goes stale the day a row is added to its registry; these tests read the
registry and the text and fail, naming the place, where they differ:

* the command lines of the README's usage block and of every fenced block of the documents: each
  `--flag` shown is an option of that command, and each `--flag a|b|c` list is the option's
  accepted values (argparse's choices, or the registry the option reads: classes, presets,
  backends, peers, shifts), all of them unless the list also shows a placeholder (`NAME`) or
  `...`;
* `--flag a|b` in the prose of README.md, CONTRIBUTING.md and docs/*.md: every value is accepted
  by some command's `--flag` (prose may name a few);
* the README's dataset names (`benchmark NAME...`), its extras and its solvers row; the backend
  paragraphs of docs/model.md and docs/benchmarks.md; the option table, flags and count of
  docs/tracking.md; the `--peers` table of docs/peers.md;
* the docstrings that list a registry: the shifts (refimpl/io/shifts.py), the public
  benchmarks (refimpl.io.datasets.benchmark_sequences), the held-out datasets (calibrate, sweep);
* the command line's help texts that spell names (`--class`, `table6 --datasets`, `--preset`).
"""

from __future__ import annotations

import argparse
import ast
import json
import re
import tomllib
from pathlib import Path

import pytest

from refimpl.cli import build_parser
from refimpl.cli.common import CLASSES
from refimpl.tracking.peer_table import PEERS
from refimpl.io.shifts import SHIFTS
from refimpl.io.datasets import BENCHMARKS, DATASETS, HELD_OUT_DATASETS, TABLE6_DATASETS
from refimpl.solvers import BACKENDS, TRACKERS
from refimpl.tracking.options import TRACKER_OPTIONS, TrackerOptions
from refimpl.tracking.pipeline import AUTO, NONE

REPO = Path(__file__).resolve().parent.parent
README = REPO / "README.md"
DOCS = [README, REPO / "CONTRIBUTING.md", *sorted((REPO / "docs").glob("*.md"))]
PRESETS = tuple(json.loads((REPO / "model" / "presets.json").read_text(encoding="utf-8")))
COUNT_WORDS = {"two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8, "nine": 9,
               "ten": 10, "eleven": 11, "twelve": 12, "thirteen": 13, "fourteen": 14,
               "fifteen": 15, "sixteen": 16, "seventeen": 17, "eighteen": 18, "nineteen": 19,
               "twenty": 20}
COUNT_WORDS |= {f"twenty-{w}": 20 + n for w, n in
                {"one": 1, **{k: v for k, v in COUNT_WORDS.items() if v < 10}}.items()}  # twenty-one .. twenty-nine

# the values an option without argparse choices accepts, from the registry it reads ("all": the
# keyword of the list options that takes every row)
REGISTRY_VALUES = {
    "--class": {c.capitalize() for c in CLASSES.values()},
    "--preset": {AUTO, NONE, *PRESETS},
    "--frame-budget": {AUTO, NONE},
    "--backends": set(TRACKERS),
    "--trackers": set(TRACKERS),
    "--peers": {"all", *PEERS},
    "--shift": {"all", *SHIFTS},
    "--datasets": set(DATASETS),
    "--benchmarks": set(DATASETS),
}
PLACEHOLDER = re.compile(r"^[A-Z][A-Z0-9_]*(\.\w+)?$|^-$")  # NAME, MS, FILE.mp4, and '-' (standard output)
CHOICE_LIST = re.compile(r"(--[a-z][a-z0-9-]*)[ =]`?([\w.{},/-]+(?:\|[\w.{},/-]+)+)")
COMMA_LIST = re.compile(r"(--[a-z][a-z0-9-]*)[ =]`?([\w.-]+(?:,[\w.-]+)+)")
FENCE = re.compile(r"^\s*(```|~~~)")


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


SUBPARSERS = _subparsers()


def _option(command: str, flag: str) -> argparse.Action | None:
    return next((a for a in SUBPARSERS[command]._actions if flag in a.option_strings), None)


def _accepted(command: str | None, flag: str) -> set[str] | None:
    """What `--flag` of the command accepts (any command's when None); None: a free value."""
    actions = [_option(command, flag)] if command else [_option(c, flag) for c in SUBPARSERS]
    choices = {str(c) for a in actions if a is not None and a.choices for c in a.choices}
    return choices or REGISTRY_VALUES.get(flag)


def _values(listed: str) -> list[str]:
    """'all|sort,bytetrack,...' -> ['all', 'sort', 'bytetrack', '...']"""
    return [v for alt in listed.split("|") for v in alt.split(",") if v]


def _check_list(where: str, command: str | None, flag: str, listed: str, exact: bool) -> list[str]:
    values = _values(listed)
    named = {v for v in values if v != "..." and not PLACEHOLDER.match(v)}
    if not named:
        return []
    accepted = _accepted(command, flag)
    if accepted is None:
        return [f"{where}: `{flag} {listed}` lists values, but the test knows no registry of {flag} "
                "(add it to REGISTRY_VALUES)"]
    fold = {a.lower(): a for a in accepted}
    wrong = sorted(v for v in named if v.lower() not in fold)
    if wrong:
        return [f"{where}: `{flag} {listed}`: {wrong} not accepted (accepted: {sorted(accepted)})"]
    complete = exact and len(named) == len(values)
    missing = sorted(set(fold) - {v.lower() for v in named})
    if complete and missing:
        return [f"{where}: `{flag} {listed}` misses {[fold[m] for m in missing]}"]
    return []


def _fenced_command_lines(doc: Path) -> list[tuple[int, str]]:
    """(line number, text) of each `refimpl ...` line of the fenced blocks, its indented
    continuation lines joined to it (the README's usage block writes one command over several)."""
    out: list[tuple[int, str]] = []
    inside, last = False, 0
    for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
        if FENCE.match(line):
            inside = not inside
            continue
        if not inside:
            continue
        m = re.match(r"^\s*(?:\$\s+)?(?:python3?\s+-m\s+)?(refimpl\s.*)$", line)
        if m:
            out.append((n, m.group(1)))
            last = n
        elif out and line.startswith(" ") and line.lstrip().startswith(("[--", "--")) and last == n - 1:
            out[-1] = (out[-1][0], out[-1][1] + "\n" + line)
            last = n
    return out


def _commands(text: str) -> list[tuple[str | None, str, str]]:
    """(command, code, comments) of a usage line: 'refimpl query S | explain S [--track N]' is two
    commands; comments are what follows '#' on each physical line."""
    code_lines, comments = [], []
    for physical in text.splitlines():
        code, _, comment = physical.partition("  #")
        code_lines.append(code)
        comments.append(comment)
    code = " ".join(code_lines)
    words = code.split()
    assert words[0] == "refimpl"
    commands: list[tuple[str | None, str, str]] = []
    start = 1
    for k in range(1, len(words) + 1):
        at_end = k == len(words)
        if at_end or (words[k] == "|" and k + 1 < len(words) and words[k + 1] in SUBPARSERS):
            first = words[start] if start < len(words) else None
            command = first if first in SUBPARSERS else None
            commands.append((command, " ".join(words[start:k]), " ".join(comments)))
            start = k + 1
    return commands


def _usage_block() -> list[tuple[int, str]]:
    text = README.read_text(encoding="utf-8")
    start = text.index("## Usage")
    first_line = text[:start].count("\n") + 1
    lines = [(n, t) for n, t in _fenced_command_lines(README) if n > first_line]
    block_end = next(n for n, line in enumerate(text.splitlines(), 1)
                     if n > first_line + 2 and line.startswith("```"))
    return [(n, t) for n, t in lines if n < block_end]


def test_the_usage_block_is_found():
    lines = _usage_block()
    assert len(lines) >= 20, lines  # the README's usage block: one line per command, and more
    assert {c for _, t in lines for c, _, _ in _commands(t)} >= {"track", "benchmark", "eval", "solve", "diff"}


def test_every_flag_of_a_shown_command_is_an_option_of_that_command():
    wrong = []
    for doc in DOCS:
        for n, text in _fenced_command_lines(doc):
            for command, code, _ in _commands(text):
                for flag in re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", code):
                    known = (SUBPARSERS[command]._option_string_actions if command
                             else {"--version": None, "--help": None})
                    if flag not in known:
                        wrong.append(f"{doc.relative_to(REPO)}:{n}: refimpl {command or ''} has no {flag}")
    assert not wrong, "\n".join(wrong)


def test_every_value_list_of_a_shown_command_is_the_options_registry():
    wrong = []
    for doc in DOCS:
        for n, text in _fenced_command_lines(doc):
            for command, code, _ in _commands(text):
                for flag, listed in CHOICE_LIST.findall(code):
                    if command:
                        wrong += _check_list(f"{doc.relative_to(REPO)}:{n}", command, flag, listed, exact=True)
    assert not wrong, "\n".join(wrong)


def test_every_value_list_in_the_prose_is_accepted_by_its_option():
    # `--flag a|b` anywhere, and a value list of an option with a registry (`--backends cpsat,clingo`)
    wrong = []
    for doc in DOCS:
        for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
            for flag, listed in CHOICE_LIST.findall(line):
                wrong += _check_list(f"{doc.relative_to(REPO)}:{n}", None, flag, listed, exact=False)
            for flag, listed in COMMA_LIST.findall(line):
                if _accepted(None, flag) is not None:
                    wrong += _check_list(f"{doc.relative_to(REPO)}:{n}", None, flag, listed, exact=False)
    assert not wrong, "\n".join(wrong)


def _brace_expand(word: str) -> list[str]:
    m = re.search(r"\{([^{}]*)\}", word)
    if not m:
        return [word]
    return [x for alt in m.group(1).split(",") for x in _brace_expand(word[:m.start()] + alt + word[m.end():])]


def test_the_readme_names_every_dataset_benchmark_takes():
    # the usage block's `refimpl benchmark NAME... # NAME: mot15 mot15-sort6 kitti-{car,ped}-{val,train} ...`
    (comment,) = [c for _, t in _usage_block() for cmd, code, c in _commands(t)
                  if cmd == "benchmark" and "NAME:" in c]
    names = [x for w in comment.split("NAME:", 1)[1].split() for x in _brace_expand(w)]
    assert sorted(names) == sorted(_option_choices("benchmark", "names"))
    assert set(_option_choices("benchmark", "names")) == set(DATASETS)


def _option_choices(command: str, dest: str) -> list[str]:
    (action,) = [a for a in SUBPARSERS[command]._actions if a.dest == dest]
    return list(action.choices)


def test_the_readme_shows_every_tracker_option_of_track():
    (track,) = [code for _, t in _usage_block() for cmd, code, _ in _commands(t)
                if cmd == "track" and "--out RESULTS.txt" in code]
    missing = [o.name for o in TRACKER_OPTIONS if "--" + o.name.replace("_", "-") not in track]
    assert not missing, f"README's track line misses the tracker options {missing}"


def _paragraph(doc: Path, starts: str) -> str:
    (para,) = [p for p in re.split(r"\n\s*\n", doc.read_text(encoding="utf-8")) if p.lstrip().startswith(starts)]
    return para


def _count_word(text: str, noun: str) -> int:
    m = re.search(r"\b([\w-]+) " + noun, text)
    assert m and m.group(1).lower() in COUNT_WORDS, f"no count word before {noun!r}: {text[:80]!r}"
    return COUNT_WORDS[m.group(1).lower()]


@pytest.mark.parametrize("doc, starts", [("docs/model.md", "Three backends answer a frame"),
                                         ("docs/benchmarks.md", "Three backends solve the same frames")])
def test_a_paragraph_naming_the_backend_registry_names_every_backend(doc, starts):
    para = _paragraph(REPO / doc, starts)
    assert _count_word(para, "backends") == len(BACKENDS)
    named = set(re.findall(r"`([\w-]+)`", para)) & set(TRACKERS) | ({"clingo"} & set(para.split()))
    assert named == set(BACKENDS), f"{doc}: {sorted(named)} against the registry's {list(BACKENDS)}"


def test_the_readmes_solvers_row_names_every_backend():
    (row,) = [line for line in README.read_text(encoding="utf-8").splitlines()
              if line.startswith("| `refimpl/solvers/` |")]
    assert set(re.findall(r"`([\w-]+)` \(", row)) == set(BACKENDS)


def test_the_readmes_extras_are_pyprojects():
    extras = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    para = _paragraph(README, "The extras add what some commands need")
    named = re.findall(r"`([\w-]+)` \(", para)
    assert sorted(named) == sorted(extras), f"README names {named}, pyproject.toml has {sorted(extras)}"


def test_docs_tracking_md_lists_every_tracker_option_with_its_default():
    doc = REPO / "docs" / "tracking.md"
    text = doc.read_text(encoding="utf-8")
    intro = _paragraph(doc, "The tracker has")
    assert _count_word(intro, "options") == len(TRACKER_OPTIONS)
    for option in TRACKER_OPTIONS:  # the flags sentence: each with its choices (checked above)
        assert "--" + option.name.replace("_", "-") in intro, option.name
    rows = {cells[0].strip("`"): cells[1].strip("`") for line in text.splitlines()
            if line.startswith("| `") and len(cells := [c.strip() for c in line.strip("|").split("|")]) == 3}
    defaults = TrackerOptions()
    shown = {o.name: _as_written(getattr(defaults, o.name)) for o in TRACKER_OPTIONS}
    assert {k: v for k, v in rows.items() if "_" in k or k in shown} == shown


def _as_written(value) -> str:
    """How docs/tracking.md's table writes a default: an enum's value, yes/no, a number as %g."""
    if hasattr(value, "value"):
        return value.value
    if isinstance(value, bool):
        return "yes" if value else "no"
    return f"{value:g}"


def test_docs_peers_md_table_has_a_row_per_peer():
    text = (REPO / "docs" / "peers.md").read_text(encoding="utf-8")
    head = text.index("| `--peers` | package (extra) |")
    rows = text[head:].split("\n\n", 1)[0].splitlines()[2:]
    named = [n for row in rows for n in re.findall(r"`([\w-]+)`", row.split("|")[1])]
    assert named == list(PEERS)


def _docstring(path: str, function: str | None = None) -> str:
    tree = ast.parse((REPO / path).read_text(encoding="utf-8"))
    if function is None:
        return ast.get_docstring(tree)
    (node,) = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == function]
    return ast.get_docstring(node)


def _rst_names(text: str) -> list[str]:
    """``name`` literals, `` `` / `` `` pairs expanded (``kitti-car`` / ``kitti-ped``)."""
    return re.findall(r"``([^`]+)``", text)


def test_the_shifts_docstring_describes_every_shift():
    names = set(_rst_names(_docstring("refimpl/io/shifts.py")))
    assert set(SHIFTS) - {"none"} <= names, sorted(set(SHIFTS) - names)
    # and no name that is not one (a renamed shift): the literals that look like a shift's name
    assert {n for n in names if re.fullmatch(r"[a-z]+-[\w.-]+", n)} <= set(SHIFTS)


def test_the_benchmark_sequences_docstring_names_every_public_benchmark():
    names = {n for n in _rst_names(_docstring("refimpl/io/datasets.py", "benchmark_sequences"))
             if re.fullmatch(r"(mot|kitti)[\w-]*", n)}
    assert names == set(BENCHMARKS)


@pytest.mark.parametrize("path", ["refimpl/experiments/calibrate.py", "refimpl/experiments/sweep.py"])
def test_the_held_out_datasets_named_in_a_docstring_are_the_catalogues(path):
    # "(``kitti-cyc``, ``mot15-acf``: refimpl.io.datasets ``held_out``)": the parenthesis citing the field
    (listed,) = re.findall(r"\(([^()]*``held_out``[^()]*)\)", _docstring(path))
    assert set(_rst_names(listed)) - {"held_out"} == set(HELD_OUT_DATASETS), path


def test_the_help_texts_that_spell_names_spell_the_registrys():
    classes = "|".join(c.capitalize() for c in CLASSES.values())
    for command in ("track", "eval"):
        assert _option(command, "--class").help.endswith(classes), command
    assert _option("table6", "--datasets").help.endswith(",".join(TABLE6_DATASETS))
    example = re.search(r"\(([^()]*), \.\.\.\)", _option("track", "--preset").help).group(1)
    assert set(example.split(", ")) <= set(PRESETS)
