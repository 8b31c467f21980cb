"""Fuzz the scene reader with query / explain / plot, CLI argument values and output paths.

    python tools/fuzz_cli.py [--inputs 600] [--seed 0] [--only I]

The fuzzer is tools/fuzzing/cli_inputs.py (its doc says what is generated and how outcomes are
judged); this script only puts the repository on the import path and runs it.
"""

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from tools.fuzzing.cli_inputs import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
