"""Developer tools (fuzzers, benchmarks, measurements) run as scripts: ``python tests/tools/NAME.py``.

A package so that the tests import the fuzzers (tools.fuzzing) like any other module.
"""
