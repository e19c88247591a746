"""Structure benchmark: a Fig. 1(c)-like building (a cycle with nested T junctions)
and a 40-corner block cycle, k=1 and k=10; median of --runs runs after a warm-up.

    python -m bench.structures [--runs 5]
"""

from __future__ import annotations

import argparse

from bench.street import timed
from pipeline.samples import block_cycle, fig1c_like
from solver.structure import Structure, solve_structure


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args(argv)
    cases = [("Fig. 1(c)-like building", fig1c_like()), ("40-corner block cycle",
                                                         block_cycle(40))]
    print(f"citysynth bench/structures.py — median of {args.runs} runs after warm-up "
          "(decomposition solver); target: under 100 ms each")
    head = (f"{'structure':<26} {'key pts':>7} {'stages':>6} {'k':>3} {'ms':>9} "
            f"{'stage problems':>15}")
    print(head + "\n" + "-" * len(head))
    for name, d in cases:
        st = Structure.from_dict(d)
        for k in (1, 10):
            t, rs = timed(lambda st=st, k=k: solve_structure(st, k), args.runs)
            r = rs[0]
            print(f"{name:<26} {len(st.keypoints):>7} {len(st.stages):>6} {k:>3} "
                  f"{1e3 * t:>9.1f} {r.stats['stage_problems']:>15}")


if __name__ == "__main__":
    main()
