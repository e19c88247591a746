"""How big a problem is before we allocate anything for it.

The node count is bounded by (elements that fit) x (states in the box); the box is
already tightened by the longest possible sequence (:mod:`solver.compiled`). We
refuse when that bound, in bytes, exceeds the caller's budget, and say which
resource makes the box large and what to change. Growth also stops at the same
budget, so a loose estimate can never turn into an out-of-memory crash.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .compiled import Compiled
from .errors import TooLargeError

BYTES_PER_NODE = 36          # elem, state, g, h, two bucket links
BYTES_PER_HASH_NODE = 48     # key + value at load 1/4..1/2
DENSE_TABLE_MAX_BYTES = 1 << 27
DEFAULT_MAX_MEMORY_MB = 2048


@dataclass(frozen=True)
class Estimate:
    nodes: int          # upper bound on nodes
    bytes: int          # memory for that many nodes plus the node table
    dense: bool         # dense node table (else hashed)
    max_nodes: int      # node budget enforced during growth

    def to_dict(self) -> dict:
        return {"nodes_bound": self.nodes, "bytes_bound": self.bytes,
                "table": "dense" if self.dense else "hash"}


def estimate(cp: Compiled, max_memory_mb: float = DEFAULT_MAX_MEMORY_MB) -> Estimate:
    budget = int(max_memory_mb * 2**20)
    fitting = int((cp.r <= cp.cap).all(axis=1).sum())
    nodes = max(fitting, 1) * cp.S
    dense_bytes = cp.S * cp.n * 4
    dense = dense_bytes <= DENSE_TABLE_MAX_BYTES
    table = dense_bytes if dense else nodes * BYTES_PER_HASH_NODE
    need = nodes * BYTES_PER_NODE + table
    per_node = BYTES_PER_NODE + (0 if dense else BYTES_PER_HASH_NODE)
    max_nodes = max((budget - (dense_bytes if dense else 0)) // per_node, 1)
    est = Estimate(int(nodes), int(need), dense, int(max_nodes))
    if need > budget:
        raise TooLargeError(too_large_message(cp, est.nodes, need, budget))
    return est


def too_large_message(cp: Compiled, nodes: int, need: int, budget: int) -> str:
    widest = int(np.argmax(cp.cap))
    name = cp.bounded[widest]
    q = cp.quant[widest]
    values = int(cp.cap[widest]) + 1
    return (
        f"problem too large: up to {nodes:,} graph states (~{need / 2**20:,.0f} MB) "
        f"exceed the memory budget of {budget / 2**20:,.0f} MB. "
        f'The widest resource is "{name}" ({values:,} values at quantum {q.quantum:g}): '
        f'use a coarser quantum for it (e.g. "quantum": {{"{name}": {2 * q.quantum:g}}}), '
        "tighten its bounds, or raise the budget (--max-memory MB)"
    )
