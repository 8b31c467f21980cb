"""Event log files: the abduced events in the paper's syntax ('occurs_at(E,T).') or as JSON lines,
written atomically (refimpl.io.outputs)."""

from __future__ import annotations

import json
from typing import Iterable

from .outputs import write_atomic


def event_line(e) -> str:
    """One line of the event log in the paper's syntax: 'occurs_at(E,T).'"""
    return f"{e}.\n"


def event_json_line(e) -> str:
    """One JSON line of the event log: time, event name, arguments and the atom."""
    return json.dumps({"time": e.time, "event": e.event.name, "args": [str(a) for a in e.event.args],
                       "atom": str(e)}) + "\n"


def write_event_log(path: str, events: Iterable) -> None:
    """The event sequence in the paper's syntax, one 'occurs_at(E,T).' per line, in time order."""
    write_atomic(path, "".join(event_line(e) for e in events))


def write_event_log_json(path: str, events: Iterable) -> None:
    """The event sequence as JSON lines: time, event name, arguments and the atom."""
    write_atomic(path, "".join(event_json_line(e) for e in events))
