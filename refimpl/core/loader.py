"""The one place refimpl imports a module by name, when it is first needed.

A registry entry may name the module that implements a thing instead of importing it: the
command table of the `refimpl` command (``"refimpl.cli.tracking:cmd_track"``), the backend registry
(``refimpl.solvers.cpsat`` / ``CpSatSolver``), the package's ``refimpl.Tracker``, ``track --scene``'s scene builder (refimpl.runs.tasks), and the peer
trackers' packages (``trackers``, ``boxmot``: refimpl.tracking.peer_table).  Such an entry is
resolved here and nowhere else, so that running one command or one backend imports only what it
needs (``refimpl track`` does not import the scorers, the plots or clingo).  Every other import of a
refimpl module is a statement at the top of its module; ``tests/test_import_cycles.py`` fails on an
import statement of a refimpl module inside a function, and on ``importlib`` or ``__import__``
anywhere but here.
"""

from __future__ import annotations

import importlib


def load(entry: str):
    """The object an entry names: ``"package.module:attribute"``, or the module itself for
    ``"package.module"``; an attribute path may be dotted (``"module:Class.method"``)."""
    module, _, attribute = entry.partition(":")
    found = importlib.import_module(module)
    for name in attribute.split(".") if attribute else ():
        found = getattr(found, name)
    return found
