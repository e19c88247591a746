"""Structure benchmark: a Fig. 1(c)-like building (a cycle with nested T junctions)
and a 40-corner block cycle, without and with a per-block (structure-wide) interval
on the door count, at k = 1, 10 and 100, solved by the default method (``auto``:
shared stage graphs) in the same run as the decomposition into one problem per stage
and key pair (``decompose``, the reference; at k = 1 without the per-block interval and
on the Fig. 1(c)-like building only: with it, the 6,480 one-stage problems take
minutes). A
warm-up, then the median of --runs runs (bench/timing.py; --cpu for CPU time). The
two must agree on every cost, or the benchmark stops.

Targets (issue 15): a per-block interval at most 2x the cost of the same block
without it; k = 100 at most 3x k = 1 on the 40-corner block.

    python -m bench.structures [--runs 5] [--cpu]
"""

from __future__ import annotations

import argparse

from bench.timing import interleaved, use_cpu_time
from citysynth.solver.samples import block_cycle, fig1c_like
from citysynth.solver.structures import Structure, solve_structure

DOORS = (20.0, 60.0)   # the per-block interval of the door count (about 40 stages x 1/3)


def _row(name: str, st: Structure, k: int, runs: int, reference: bool) -> float:
    fns = {"auto": lambda: solve_structure(st, k)}
    if reference:
        fns["decompose"] = lambda: solve_structure(st, k, "decompose")
    m = interleaved(fns, runs)
    t_new, outs = m["auto"]
    a = outs[0]
    t_old = None
    if reference:
        t_old, olds = m["decompose"]
        if [s.cost for s in a.solutions] != [s.cost for s in olds[0].solutions]:
            raise SystemExit(f"{name}, k={k}: the solvers disagree")
    assert t_new is not None
    print(f"{name:<34} {len(st.keypoints):>4} {k:>4} | {1e3 * t_new:>9.1f} "
          f"{a.stats.get('stage_graphs', 0):>6} {a.stats.get('stage_queries', 0):>7} | "
          + (f"{1e3 * t_old:>9.1f} {t_old / t_new:>7.1f}x" if t_old else f"{'—':>9} {'':>8}"))
    return t_new


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--cpu", action="store_true", help="CPU time instead of wall time")
    args = ap.parse_args(argv)
    use_cpu_time(args.cpu)
    print(f"citysynth bench/structures.py — median of {args.runs} runs after warm-up, "
          f"{'CPU' if args.cpu else 'wall'} ms; auto = the default (shared stage graphs)")
    head = (f"{'structure':<34} {'keys':>4} {'k':>4} | {'auto':>9} {'graphs':>6} "
            f"{'queries':>7} | {'decompose':>9} {'speed-up':>8}")
    print(head + "\n" + "-" * len(head))
    fig = Structure.from_dict(fig1c_like())
    for k in (1, 10):
        _row("Fig. 1(c)-like building", fig, k, args.runs, True)
    t: dict[tuple[str, int], float] = {}
    for label, d in (("40-corner block", block_cycle(40)),
                     (f"40-corner block, doors {DOORS[0]:g}-{DOORS[1]:g}",
                      block_cycle(40, doors=DOORS))):
        st = Structure.from_dict(d)
        for k in (1, 10, 100):
            t[(label[:15] + ("+" if "doors" in label else ""), k)] = _row(
                label, st, k, args.runs, k == 1 and "doors" not in label)
    plain, doors = "40-corner block", "40-corner block+"
    print(f"\nper-block interval / without it: k=1 {t[(doors, 1)] / t[(plain, 1)]:.2f}x, "
          f"k=100 {t[(doors, 100)] / t[(plain, 100)]:.2f}x (target 2x)")
    print(f"k=100 / k=1 on the 40-corner block: {t[(plain, 100)] / t[(plain, 1)]:.2f}x "
          f"without the interval, {t[(doors, 100)] / t[(doors, 1)]:.2f}x with it (target 3x)")


if __name__ == "__main__":
    main()
