"""`python -m refimpl.cli` runs the command line, as `python -m refimpl` does."""

from . import run

run()
