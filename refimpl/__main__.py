"""`python -m refimpl` runs the command line."""

from .cli import run

run()
