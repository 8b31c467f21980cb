"""Fuzz the scene reader with query / explain / plot, CLI argument values and output paths.

    python tests/tools/fuzz_cli.py [--inputs 600] [--seed 0] [--only I]

The fuzzer is tests/tools/fuzzing/cli_inputs.py (its doc says what is generated and how outcomes are
judged); this script only puts the repository on the import path and runs it.
"""

import sys

import _paths  # noqa: F401,E402  (this checkout's refimpl, and tests/tools as `tools`)
from tools.fuzzing.cli_inputs import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
