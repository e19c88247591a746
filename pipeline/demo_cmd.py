"""``citysynth demo``: the embedded demo, runnable with no user data.

For now it fills an 83.4 m street front with complete buildings from the sample
street problem (:mod:`pipeline.samples`) and prints the three best layouts with a
to-scale strip of each. Later stages extend it to USD output.
"""

from __future__ import annotations

from solver import Problem, solve

from .report import format_result
from .samples import street_front

DEMO_LENGTH_M = 83.4
DEMO_K = 3


def register(sub) -> None:
    p = sub.add_parser("demo", help="run the embedded demo (no user data needed)",
                       description="Solve the sample 83.4 m street front and print the "
                                   "three best layouts.")
    p.set_defaults(run=run)


def strip(sequence: list[str], widths: dict[str, float], scale: float = 1.0) -> str:
    """A to-scale text strip: one cell per building, 1 character per metre."""
    cells = []
    for b in sequence:
        w = max(int(round(widths[b] / scale)), 3)
        label = f"{widths[b]:g}"
        cells.append(label.center(w - 1, "-")[: w - 1])
    return "|" + "|".join(cells) + "|"


def run(args) -> int:
    problem = Problem.from_dict(street_front(DEMO_LENGTH_M, k=DEMO_K))
    result = solve(problem)
    print(f"citysynth demo: a {DEMO_LENGTH_M} m street front from "
          f"{len(problem.elements)} complete buildings (4-20 m, 0.2 m grid)\n")
    print(format_result(result))
    widths = {e.id: e.resources["length"] for e in problem.elements}
    print("\nto scale (1 character = 1 m, widths in m):")
    for i, sol in enumerate(result.solutions, 1):
        print(f"#{i} {strip(sol.sequence, widths)}")
    return 0 if result.status == "ok" else 1
