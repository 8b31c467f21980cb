"""Seeded, bounded fuzzing of the fact-format parser and the MOTChallenge / KITTI readers.

    python tests/tools/fuzz.py --inputs 10000 --seed 0

The fuzzer is the package tools.fuzzing (its doc says what is generated and how outcomes are
judged); this script only puts the repository on the import path and runs its driver.
"""

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
for _path in (REPO, REPO / "tests"):  # this checkout's refimpl, and tests/tools as `tools`
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from tools.fuzzing.driver import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
