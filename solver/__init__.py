"""citysynth solver: exact k-best sequences under multiple resource constraints.

Implements Hartmann et al., "Efficient Multi-Constrained Optimization for
Example-Based Synthesis" §2-3.1: ``Problem`` (the data), ``solve`` (the entry
point), with the default cost-bounded search in :mod:`citysynth.solver.bounded`, the
intermediate graph in :mod:`citysynth.solver.graph`, the k-best enumeration in
:mod:`citysynth.solver.kbest` and the FGS baseline in :mod:`citysynth.solver.fgs`;
structures (§3.2) are :mod:`citysynth.solver.structures`.
This package knows only numbers and imports no geometry library.

A street front of exactly 20.4 m from two parts, the three cheapest fillings:

>>> from citysynth.solver import Problem, solve
>>> p = Problem.from_dict({
...     "resources": ["length"],
...     "elements": [{"id": "A", "resources": {"length": 4.0}},
...                  {"id": "B", "resources": {"length": 6.2}}],
...     "transitions": [["A", "B", 0.5], ["B", "A", 0.25], ["B", "B", 1.0]],
...     "constraints": {"length": [20.4, 20.4]}})
>>> r = solve(p, k=3)
>>> r.status
'ok'
>>> [(s.sequence, s.cost) for s in r.solutions]
[(['B', 'A', 'B', 'A'], 1.0), (['A', 'B', 'A', 'B'], 1.25), (['A', 'B', 'B', 'A'], 1.75)]

An interval no sequence meets is an answer too, with the reason in the user's units:

>>> p = Problem.from_dict({**p.to_dict(), "constraints": {"length": [20.6, 20.6]}})
>>> r = solve(p)
>>> r.status, r.solutions
('infeasible', [])
>>> for part in r.reason.split("; "):
...     print(part)
length = 20.6 is out of reach even ignoring the other minimums
nearest achievable: 20.4 (below), 22.6 (above)
"""

from typing import TYPE_CHECKING

from citysynth.solver.errors import ProblemError, TooLargeError
from citysynth.solver.exports import lazy_exports

# numba and the kernels load only when one of these names is first used
if TYPE_CHECKING:   # what type checkers and editors read
    from citysynth.solver.entry import Result as Result
    from citysynth.solver.entry import Solution as Solution
    from citysynth.solver.entry import solve as solve
    from citysynth.solver.methods import METHODS as METHODS
    from citysynth.solver.problem import Element as Element
    from citysynth.solver.problem import Problem as Problem
else:   # what runs: the same names, imported when first used (solver.exports)
    __getattr__, __dir__, _lazy = lazy_exports(__name__, {
        "problem": ("Element", "Problem"),
        "entry": ("Result", "Solution", "solve"),
        "methods": ("METHODS",),
    })
    __all__ = ["ProblemError", "TooLargeError", *_lazy]
