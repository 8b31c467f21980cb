"""What ``refimpl bench-peers`` adds to the peer and shift tables it regenerates in docs/peers.md:
which peers of the registry run (every one whose package imports) and which do not, said in one
line, and the generated "what was tuned on what" section, read from model/presets.json (each
preset's ``tuned_on``, ``fps`` and ``procedure``) and the dataset registry (each dataset's role in
the tuning rule and the tables it is in: refimpl.io.datasets).
"""

from __future__ import annotations

from typing import Iterable, Mapping, Sequence

from ..io.datasets import CATALOGUE, ROLES, TUNING, Dataset
from ..tracking.presets import Preset
from .peers import PEERS, PeersUnavailable, peer, peer_class

TUNED_BEGIN, TUNED_END = "<!-- tuned-on:begin -->", "<!-- tuned-on:end -->"
"""The markers of the generated "what was tuned on what" section of docs/peers.md."""


def installed_peers(names: Iterable[str] = tuple(PEERS)) -> tuple[tuple[str, ...], dict[str, str]]:
    """The peers among ``names`` whose package imports, in order, and {peer: its package} of the others."""
    run, missing = [], {}
    for name in names:
        try:
            peer_class(name)
        except PeersUnavailable:
            missing[name] = peer(name).package
        else:
            run.append(name)
    return tuple(run), missing


def not_run_note(missing: Mapping[str, str]) -> str:
    """One line naming the peers of the registry that did not run and why; "" when every one ran."""
    if not missing:
        return ""
    packages = ", ".join(dict.fromkeys(missing.values()))
    return f"not run: {', '.join(missing)} (package not installed: {packages})"


def procedure_clauses(procedure: str) -> tuple[str, ...]:
    """A preset's procedure split at its top-level "; " (not inside parentheses)."""
    out, depth, start = [], 0, 0
    for i, ch in enumerate(procedure):
        depth += {"(": 1, ")": -1}.get(ch, 0)
        if ch == ";" and depth == 0:
            out.append(procedure[start:i].strip())
            start = i + 1
    out.append(procedure[start:].strip())
    return tuple(c for c in out if c)


def _shared_clauses(presets: Sequence[Preset]) -> tuple[str, ...]:
    """The leading clauses every preset's procedure has in common."""
    split = [procedure_clauses(p.procedure) for p in presets]
    shared: list[str] = []
    for clauses in zip(*split):
        if len(set(clauses)) != 1:
            break
        shared.append(clauses[0])
    return tuple(shared) if len(presets) > 1 else ()


def _tuned_on(preset: Preset, catalogue: Mapping[str, Dataset]) -> str:
    """The sets a preset was tuned on, each flagged unless the registry holds it as a tuning set."""
    out = []
    for name in (n for n in preset.tuned_on.split("+") if n):
        entry = catalogue.get(name)
        flag = "" if entry is not None and entry.role == TUNING else \
            f" (**{'unknown set' if entry is None else entry.role}**, not a tuning set)"
        out.append(f"`{name}`{flag}")
    return ", ".join(out) or "-"


def _value(v: object) -> str:
    """A tracker option's value as the table says it: yes / no for a switch, else as written."""
    return ("yes" if v else "no") if isinstance(v, bool) else str(v)


def tuned_on_report(presets: Mapping[str, Preset], command: str,
                    catalogue: Mapping[str, Dataset] = CATALOGUE) -> str:
    """The generated section: a table of the presets (tuned on, fps, procedure beyond the clauses every
    preset shares, said once below it), a table of what each holds (its constants, the tracker options
    it changes), then a table of every dataset's role and tables."""
    chosen = list(presets.values())
    shared = _shared_clauses(chosen)
    out = [f"Made by `{command}`, from model/presets.json and the dataset registry (refimpl/io/datasets.py).\n",
           "| preset | tuned on | fps | procedure |", "|---|---|---:|---|"]
    for p in chosen:
        own = "; ".join(procedure_clauses(p.procedure)[len(shared):]) or "the shared steps below"
        fps = "-" if p.fps is None else f"{p.fps:g}"
        out.append(f"| {p.name} | {_tuned_on(p, catalogue)} | {fps} | {own} |")
    if shared:
        out.append(f"\nEvery preset: {'; '.join(shared)}.")
    out += ["\nWhat each preset holds: its model constants (the rest as model/constants.lp says) and the tracker "
            "options it changes (the rest as docs/tracking.md says); durations in frames at its fps.\n",
            "| preset | model constants | tracker options |", "|---|---|---|"]
    for p in chosen:
        constants = ", ".join(f"{k} {v}" for k, v in sorted(p.constants.items())) or "-"
        options = ", ".join(f"{k} {_value(v)}" for k, v in sorted(p.tracker.changed().items())) or "-"
        out.append(f"| {p.name} | {constants} | {options} |")
    out += ["\n| dataset | role | in the tables | title |", "|---|---|---|---|"]
    for role in ROLES:
        for d in (d for d in catalogue.values() if d.role == role):
            tables = ", ".join(t for t, on in (("peers", d.peer_table), ("shifts", d.shift_table)) if on) or "-"
            tuned = f" (its preset tuned on `{d.tune_on}`)" if d.tune_on and d.tune_on != d.name else ""
            out.append(f"| `{d.name}` | **{role}**: {ROLES[role]}{tuned} | {tables} | {d.title} |")
    return "\n".join(out) + "\n"
