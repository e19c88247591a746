"""``citysynth solve FILE``: solve one problem file (the JSON of ``Problem.from_dict``)."""

from __future__ import annotations

import json
import sys
from typing import TYPE_CHECKING

from citysynth.pipeline.commands.results_text import format_result
from citysynth.pipeline.errors import UsageError, names_its_file
from citysynth.solver.errors import ProblemError
from citysynth.solver.methods import DEFAULT_MAX_MEMORY_MB, METHODS

if TYPE_CHECKING:
    from citysynth.solver.structures import Structure


def register(sub) -> None:
    p = sub.add_parser("solve", help="solve one sequence problem file",
                       description="Solve one problem file and print the k best sequences. "
                                   "Exit 0 with solutions, 1 when infeasible, 2 on bad input.")
    p.add_argument("file", help="problem JSON (see README, 'Problem files')")
    p.add_argument("--k", type=int, default=None, help="number of solutions (default: the "
                   "file's k, else 1)")
    p.add_argument("--method", choices=METHODS, default="auto",
                   help="auto (default): the fastest exact method for the problem (the "
                   "cost-bounded search, or shared stage graphs for a structure); "
                   "bounded: the cost-bounded search; rcksp: the intermediate graph; "
                   "fgs: the baseline")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--max-memory", type=float, default=DEFAULT_MAX_MEMORY_MB, metavar="MB",
                   help=f"refuse problems estimated above this (default {DEFAULT_MAX_MEMORY_MB})")
    p.set_defaults(run=run)


@names_its_file("file", ProblemError)   # TooLargeError too
def run(args) -> int:
    """Solve the file's problem or structure; every error names the file."""
    return _run(args)


def _run(args) -> int:
    from citysynth.solver import Problem, solve  # numba: when run (see pipeline.cli)
    from citysynth.solver.entry import check_budget
    from citysynth.solver.problem import load_json
    from citysynth.solver.structures import Structure

    if args.k is not None and args.k < 1:
        raise UsageError(f"--k must be a positive integer, got {args.k}")
    try:                       # an option's fault, said before the file is read
        check_budget(args.max_memory)
    except ProblemError as exc:
        raise UsageError(f"--max-memory: {exc}") from None
    data = load_json(args.file)
    if isinstance(data, dict) and "stages" in data:
        return run_structure(args, Structure.from_dict(data, args.file))
    problem = Problem.from_dict(data, args.file)
    result = solve(problem, k=args.k, method=args.method, max_memory_mb=args.max_memory)
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(format_result(result))
    if result.status != "ok":
        print(f"citysynth solve: {result.reason}", file=sys.stderr)
        return 1
    return 0


def run_structure(args, st: Structure) -> int:
    """A structure file (it has "stages"): chains and cycles of substructures."""
    from citysynth.solver.structures import solve_structure

    result = solve_structure(st, args.k, method=args.method, max_memory_mb=args.max_memory)
    if args.json:
        print(json.dumps({"status": result.status, "reason": result.reason,
                          "solutions": [vars(s) for s in result.solutions],
                          "stats": result.stats}, indent=2))
    else:
        print(f"status: {result.status}  (structure: {len(st.keypoints)} key points, "
              f"{len(st.stages)} stages, {'with a cycle' if st.closed else 'a tree'})")
        if result.reason:
            print(f"reason: {result.reason}")
        for i, sol in enumerate(result.solutions, 1):
            print(f"#{i:<3} cost {round(sol.cost, 6):g}")
            for j, (stage, fill) in enumerate(zip(st.stages, sol.stages, strict=True)):
                res = ", ".join(f"{k} {round(v, 6):g}" for k, v in sol.resources[j].items())
                print(f"     stage {j}: [{sol.keys[stage.start]}] {' '.join(fill)} "
                      f"[{sol.keys[stage.end]}]  ({res})")
    if result.status != "ok":
        print(f"citysynth solve: {result.reason}", file=sys.stderr)
        return 1
    return 0
