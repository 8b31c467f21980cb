"""The optimal assignment of a cost matrix (the Hungarian method), for SORT's association
(refimpl.tracking.baseline), the scorers' matching of results to ground truth
(refimpl.evaluation.evaluate) and the witness of clingo's level-10 certificate
(refimpl.solvers.certificate).

scipy's ``linear_sum_assignment`` does the work; this module is the one place scipy is imported,
when an assignment is first asked for: ``import scipy.optimize`` took 1.1 s here (``python -X importtime``),
and an abduction ``refimpl track`` never needs it.
"""

from __future__ import annotations

import numpy as np


def linear_sum_assignment(cost: np.ndarray, maximize: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(row indices, column indices) of an assignment of least (``maximize``: greatest) summed
    cost, rows in increasing order: exactly ``scipy.optimize.linear_sum_assignment``."""
    from scipy.optimize import linear_sum_assignment as solve

    return solve(cost, maximize=maximize)
