"""``python -m refimpl.scene anticipation-eval`` (refimpl.scene.scoring.main)."""

import sys

from .scoring import main


sys.exit(main())
