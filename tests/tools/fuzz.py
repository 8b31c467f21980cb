"""Seeded, bounded fuzzing of the fact-format parser and the MOTChallenge / KITTI readers.

    python tests/tools/fuzz.py --inputs 10000 --seed 0

The fuzzer is the package tools.fuzzing (its doc says what is generated and how outcomes are
judged); this script only puts the repository on the import path and runs its driver.
"""

import sys

import _paths  # noqa: F401,E402  (this checkout's refimpl, and tests/tools as `tools`)
from tools.fuzzing.driver import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
