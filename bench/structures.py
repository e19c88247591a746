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
without it; k = 100 at most 3x k = 1 on the 40-corner block. The last table times
the four 40-corner solves the targets compare in turn, round after round (bench/timing.py,
``interleaved``, three times --runs rounds), so each ratio is of medians taken in the
same rounds.

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
    for label, d in (("40-corner block", block_cycle(40)),
                     (f"40-corner block, doors {DOORS[0]:g}-{DOORS[1]:g}",
                      block_cycle(40, doors=DOORS))):
        st = Structure.from_dict(d)
        for k in (1, 10, 100):
            _row(label, st, k, args.runs, k == 1 and "doors" not in label)
    _targets(args.runs)


def _targets(runs: int) -> None:
    """The issue's two ratios, from the four solves timed in the same rounds."""
    plain = Structure.from_dict(block_cycle(40))
    doors = Structure.from_dict(block_cycle(40, doors=DOORS))
    fns = {(d, k): (lambda st=st, k=k: solve_structure(st, k))
           for d, st in (("plain", plain), ("doors", doors)) for k in (1, 100)}
    # three times the rounds: ratios of a few milliseconds move with a busy machine
    m = interleaved({f"{d} {k}": fn for (d, k), fn in fns.items()}, 3 * runs)
    t = {name: v[0] for name, v in m.items()}
    rows = [("per-block interval / without it, k = 1", "doors 1", "plain 1", 2.0),
            ("per-block interval / without it, k = 100", "doors 100", "plain 100", 2.0),
            ("k = 100 / k = 1, 40-corner block", "plain 100", "plain 1", 3.0),
            ("k = 100 / k = 1, with the interval", "doors 100", "doors 1", 3.0)]
    head = (f"{'target (40-corner block)':<42} | {'ms':>7} / {'ms':>7} | "
            f"{'ratio':>6} {'goal':>5}  met")
    print("\n" + head + "\n" + "-" * len(head))
    for label, a, b, goal in rows:
        ta, tb = t[a], t[b]
        assert ta is not None and tb is not None
        r = ta / tb
        print(f"{label:<42} | {1e3 * ta:>7.1f} / {1e3 * tb:>7.1f} | {r:>5.2f}x {goal:>4.0f}x  "
              f"{'yes' if r <= goal else 'NO'}")


if __name__ == "__main__":
    main()
