"""The floor to compare with: a plain compiled dynamic program over (length, last
element), the textbook solution of the one-resource equality case (k = 1 only).

best[c, f] = omega(f) + min over predecessors e of best[c - len(f), e] + delta(e, f),
filled for c = 0 .. L in increasing order; the answer is the minimum over back
elements of best[L, f]. It has no graph, no pruning and no k-best: it is what the
intermediate graph must stay close to on the problem where both apply.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _dp(L, length, omega, front, back, pred_ptr, pred_elem, pred_w):
    n = len(length)
    best = np.full((L + 1, n), np.inf)
    for f in range(n):
        if front[f] and length[f] <= L:
            best[length[f], f] = omega[f]
    for c in range(L + 1):
        for f in range(n):
            cp = c - length[f]
            if cp <= 0:
                continue
            row = best[cp]
            b = best[c, f]
            for j in range(pred_ptr[f], pred_ptr[f + 1]):
                v = row[pred_elem[j]] + pred_w[j]
                if v < b:
                    b = v
            best[c, f] = b
    out = np.inf
    for f in range(n):
        if back[f] and best[L, f] < out:
            out = best[L, f]
    return out


def dp_cost(cp) -> float:
    """Optimal cost of a compiled one-resource equality problem (see solver.compiled)."""
    if cp.R != 1 or cp.lo[0] != cp.hi[0]:
        raise ValueError("the DP floor handles one resource with an equality constraint")
    return float(_dp(int(cp.hi[0]), cp.r[:, 0].copy(), cp.omega, cp.front, cp.back,
                     cp.pred_ptr, cp.pred_elem, cp.pred_w))
