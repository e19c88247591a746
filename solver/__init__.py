"""citysynth solver: exact k-best sequences under multiple resource constraints.

Implements Hartmann et al., "Efficient Multi-Constrained Optimization for
Example-Based Synthesis" §2-3.1: ``Problem`` (the data), ``solve`` (the entry
point), with the intermediate graph in :mod:`solver.graph`, the k-best enumeration
in :mod:`solver.kbest` and the FGS baseline in :mod:`solver.fgs`. This package knows
only numbers and imports no geometry library.

>>> from solver import Problem, solve
>>> p = Problem.from_dict({
...     "resources": ["length"],
...     "elements": [{"id": "A", "resources": {"length": 4.0}},
...                  {"id": "B", "resources": {"length": 6.2}}],
...     "transitions": [["A", "B", 0.5], ["B", "A", 0.25], ["B", "B", 1.0]],
...     "constraints": {"length": [20.6, 20.6]}})
>>> r = solve(p, k=2)
>>> [(s.sequence, s.cost) for s in r.solutions]
[(['A', 'B', 'A', 'B'], 1.25), (['B', 'A', 'B', 'A'], 1.25)]
"""

from citysynth.solver.errors import ProblemError, TooLargeError
from citysynth.solver.problem import Element, Problem
from citysynth.solver.solve import METHODS, Result, Solution, solve

__all__ = ["Element", "Problem", "ProblemError", "Result", "Solution", "TooLargeError",
           "METHODS", "solve"]
