"""What a caller of the solver chooses: the search method and the memory budget.

A module of its own, with no imports of the kernels, so the command line can offer
the choices (``--method``, ``--max-memory``) without loading numba.
"""

from __future__ import annotations

from typing import Literal, get_args

# the one-stage methods (see citysynth.solver.entry.solve); the CLI offers METHODS
Method = Literal["auto", "bounded", "rcksp", "fgs"]
METHODS: tuple[Method, ...] = get_args(Method)

DEFAULT_MAX_MEMORY_MB = 2048   # a problem estimated above this is refused, not tried
