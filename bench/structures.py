"""Structure benchmark: a Fig. 1(c)-like building (a cycle with nested T junctions)
and a 40-corner block cycle, k=1 and k=10, solved by the shared stage graphs (the
default, ``rcksp``) and by the decomposition into one problem per stage and key pair
(``decompose``, the reference), in the same run: a warm-up, then the median of --runs
runs of each. The two must agree on every cost, or the benchmark stops.

    python -m bench.structures [--runs 5]
"""

from __future__ import annotations

import argparse

from bench.timing import timed
from citysynth.solver.samples import block_cycle, fig1c_like
from citysynth.solver.structures import Structure, solve_structure

TARGET_MS = 100.0


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args(argv)
    cases = [("Fig. 1(c)-like building", fig1c_like()),
             ("40-corner block cycle", block_cycle(40))]
    print(f"citysynth bench/structures.py — median of {args.runs} runs after warm-up, ms; "
          f"target: under {TARGET_MS:g} ms each (rcksp)")
    head = (f"{'structure':<26} {'key pts':>7} {'stages':>6} {'k':>3} | {'rcksp':>8} "
            f"{'graphs':>6} {'queries':>7} | {'decompose':>9} {'problems':>8} | "
            f"{'speed-up':>8}")
    print(head + "\n" + "-" * len(head))
    for name, d in cases:
        st = Structure.from_dict(d)
        for k in (1, 10):
            t_new, new = timed(lambda st=st, k=k: solve_structure(st, k), args.runs)
            t_old, old = timed(lambda st=st, k=k: solve_structure(st, k, "decompose"),
                               args.runs)
            a, b = new[0], old[0]
            if [s.cost for s in a.solutions] != [s.cost for s in b.solutions]:
                raise SystemExit(f"{name}, k={k}: the solvers disagree")
            print(f"{name:<26} {len(st.keypoints):>7} {len(st.stages):>6} {k:>3} | "
                  f"{1e3 * t_new:>8.1f} {a.stats['stage_graphs']:>6} "
                  f"{a.stats['stage_queries']:>7} | {1e3 * t_old:>9.1f} "
                  f"{b.stats['stage_problems']:>8} | {t_old / t_new:>7.1f}x")


if __name__ == "__main__":
    main()
