"""Gated global-nearest-neighbour assignment (scipy's linear_sum_assignment; no ROS)."""

import numpy as np
from scipy.optimize import linear_sum_assignment

INFEASIBLE = 1e9


def assign(cost, gate):
    """Pairs (row, col) minimising the total cost among pairs whose cost is < ``gate``.

    ``cost`` [R, C] (NaN or inf: never); returns (pairs, unmatched rows, unmatched cols)."""
    cost = np.asarray(cost, dtype=float)
    rows, cols = cost.shape if cost.ndim == 2 else (0, 0)
    if rows == 0 or cols == 0:
        return [], list(range(rows)), list(range(cols))
    masked = np.where(np.isfinite(cost) & (cost < gate), cost, INFEASIBLE)
    r, c = linear_sum_assignment(masked)
    pairs = [(int(i), int(j)) for i, j in zip(r, c, strict=True) if masked[i, j] < INFEASIBLE]
    used_r, used_c = {i for i, _ in pairs}, {j for _, j in pairs}
    return pairs, [i for i in range(rows) if i not in used_r], [j for j in range(cols) if j not in used_c]


def distance_matrix(a, b):
    """Euclidean distances [len(a), len(b)] between 2-D points."""
    a = np.asarray(a, dtype=float).reshape(-1, 2)
    b = np.asarray(b, dtype=float).reshape(-1, 2)
    return np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
