"""Backend agreement on accepted inputs: every backend, the same answer, the checker's approval.

    python tests/tools/fuzz_agreement.py --inputs 2000 --seed 0

The fuzzer is tools.fuzzing.agreement (its doc says what is generated and how outcomes are
judged); this script only puts the repository on the import path and runs it.
"""

import sys

import _paths  # noqa: F401,E402  (this checkout's refimpl, and tests/tools as `tools`)
from tools.fuzzing.agreement import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
