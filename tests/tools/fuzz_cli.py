"""Fuzz the scene reader with query / explain / plot, CLI argument values and output paths.

    python tests/tools/fuzz_cli.py [--inputs 600] [--seed 0] [--only I]

The fuzzer is tests/tools/fuzzing/cli_inputs.py (its doc says what is generated and how outcomes are
judged); this script only puts the repository on the import path and runs it.
"""

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
for _path in (REPO, REPO / "tests"):  # this checkout's refimpl, and tests/tools as `tools`
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from tools.fuzzing.cli_inputs import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
