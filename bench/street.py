"""Street-front benchmark (the paper's Fig. 7): the default method against FGS and the
plain DP floor.

A street front of 74 complete buildings (4-20 m on the 0.2 m grid, every transition
allowed, seeded costs) filled to an exact length of 20..200 m; and a three-resource
variant (length equality, intervals on doors and balconies). Every row at k = 1 and
k = 100: the default method's setup/solve/total, FGS's total and the ratio of the
totals; for one resource also the paper's intermediate graph (rcksp, k = 1) and the
plain compiled DP over (length, last element) (k = 1 only: the floor). All measured
in the same run, the methods called in turn: a warm-up, then the median of --runs
runs (bench/timing.py: more for calls of a few milliseconds; --cpu for CPU time).

The DP floor is timed on the compiled problem; a solve also compiles it (parsing
ids and transitions, quantising: about 1 ms here), so the ratio to the floor is
given both ways: "k1/DP" for the whole solve against the DP alone, "k1/(c+DP)" for
the whole solve against compiling plus the DP. The growth exponent is the slope of
log(time) over log(length). Peak memory of the 200 m three-resource case is the
peak RSS (VmHWM) of a child process that solves only that case.

    python -m bench.street [--runs 5] [--cpu] [--quick]
"""

from __future__ import annotations

import argparse
import math
import statistics
from pathlib import Path

from bench.dp_floor import dp_cost
from bench.timing import interleaved, ms, ratio, run_child, stat_median, use_cpu_time
from citysynth.solver import Problem, solve
from citysynth.solver.compiled import compile_problem
from citysynth.solver.samples import street_front

ROOT = Path(__file__).resolve().parent.parent


def slope(xs, ys) -> float:
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    mx, my = statistics.fmean(lx), statistics.fmean(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly, strict=True)) / \
        sum((a - mx) ** 2 for a in lx)


def _same_costs(a, b, what: str) -> None:
    if a and b:
        assert [s.cost for s in a[0].solutions] == [s.cost for s in b[0].solutions], what


def one_resource(lengths, runs: int) -> None:
    print("\n== one resource: length equality, 74 buildings, 5476 transitions ==")
    head = (f"{'length':>6} | {'setup1':>8} {'solve1':>8} {'total1':>8} {'total100':>8} | "
            f"{'DP':>8} {'k1/DP':>6} {'k1/(c+DP)':>9} | {'FGS1':>8} {'FGS100':>8} "
            f"{'k1/FGS1':>7} {'k100/FGS100':>11} | {'rcksp1':>8}")
    print(head + "\n" + "-" * len(head))
    t1s, dps = [], []
    for L in lengths:
        p = Problem.from_dict(street_front(L))
        cp = compile_problem(p)
        m = interleaved({
            "k1": lambda p=p: solve(p, k=1),
            "k100": lambda p=p: solve(p, k=100),
            "dp": lambda cp=cp: dp_cost(cp),
            "compile_dp": lambda p=p: dp_cost(compile_problem(p)),
            "fgs1": lambda p=p: solve(p, k=1, method="fgs", max_memory_mb=4096),
            "fgs100": lambda p=p: solve(p, k=100, method="fgs", max_memory_mb=4096),
            "rcksp1": lambda p=p: solve(p, k=1, method="rcksp"),
        }, runs)
        (t1, r1), (t100, r100) = m["k1"], m["k100"]
        tdp, cdp = m["dp"]
        assert abs(cdp[0] - r1[0].solutions[0].cost) < 1e-9, (cdp[0], r1[0].solutions[0].cost)
        _same_costs(r100, m["fgs100"][1], f"{L} m k=100")
        print(f"{L:6.0f} | {ms(stat_median(r1, 'setup_s'))} {ms(stat_median(r1, 'solve_s'))} "
              f"{ms(t1)} {ms(t100)} | {ms(tdp)} {ratio(t1, tdp)} "
              f"{ratio(t1, m['compile_dp'][0], 9)} | {ms(m['fgs1'][0])} "
              f"{ms(m['fgs100'][0])} {ratio(t1, m['fgs1'][0], 7)} "
              f"{ratio(t100, m['fgs100'][0], 11)} | {ms(m['rcksp1'][0])}")
        t1s.append(t1)
        dps.append(tdp)
    print(f"growth exponent over {lengths[0]:g}-{lengths[-1]:g} m: default k=1 "
          f"{slope(lengths, t1s):.2f}, DP {slope(lengths, dps):.2f} (paper: 1.29)")


def three_resources(lengths, runs: int) -> None:
    print("\n== three resources: length equality, doors and balconies intervals ==")
    head = (f"{'length':>6} {'doors':>11} {'balc.':>12} | {'setup1':>8} {'solve1':>8} "
            f"{'total1':>8} {'total100':>8} {'labels100':>9} | {'FGS1':>8} {'FGS100':>9} "
            f"{'k1/FGS1':>7} {'k100/FGS100':>11}")
    print(head + "\n" + "-" * len(head))
    for L in lengths:
        d = street_front(L, resources=3)
        p = Problem.from_dict(d)
        m = interleaved({
            "k1": lambda p=p: solve(p, k=1),
            "k100": lambda p=p: solve(p, k=100),
            "fgs1": lambda p=p: solve(p, k=1, method="fgs", max_memory_mb=4096),
            "fgs100": lambda p=p: solve(p, k=100, method="fgs", max_memory_mb=4096),
        }, runs)
        (t1, r1), (t100, r100) = m["k1"], m["k100"]
        _same_costs(r100, m["fgs100"][1], f"{L} m three resources k=100")
        c = d["constraints"]
        print(f"{L:6.0f} {str(c['doors']):>11} {str(c['balconies']):>12} | "
              f"{ms(stat_median(r1, 'setup_s'))} {ms(stat_median(r1, 'solve_s'))} "
              f"{ms(t1)} {ms(t100)} {r100[0].stats.get('labels', 0):9,} | "
              f"{ms(m['fgs1'][0])} {ms(m['fgs100'][0], 9)} {ratio(t1, m['fgs1'][0], 7)} "
              f"{ratio(t100, m['fgs100'][0], 11)}")


_CHILD = """
import json, sys, time
sys.path.insert(0, {root!r})
from citysynth.solver.samples import street_front
from citysynth.solver import Problem, solve

p = Problem.from_dict(street_front({length}, resources=3))
solve(Problem.from_dict(street_front(20.0, resources=3)), k={k})
base = hwm()
t = time.perf_counter()
r = solve(p, k={k}{method})
t = time.perf_counter() - t
print(json.dumps({{"base_mb": base, "peak_mb": hwm(), "s": t, "method": r.stats["method"],
                  "explored": r.stats.get("labels", r.stats.get("nodes"))}}))
"""


def peak_memory(length: float, k: int, method: str | None = None) -> None:
    extra = f", method={method!r}" if method else ""
    d = run_child(_CHILD.format(root=str(ROOT), length=length, k=k, method=extra))
    print(f"peak memory, {length:g} m three-resource, k={k}, {d['method']}: "
          f"{d['peak_mb']:,.0f} MB peak RSS ({d['peak_mb'] - d['base_mb']:,.0f} MB above the "
          f"{d['base_mb']:,.0f} MB of a warmed-up interpreter); {d['explored']:,} explored, "
          f"{d['s'] * 1e3:,.1f} ms")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="timed runs per case (median)")
    ap.add_argument("--cpu", action="store_true",
                    help="time with CPU time instead of wall time (a shared machine)")
    ap.add_argument("--quick", action="store_true", help="fewer lengths, for a smoke run")
    args = ap.parse_args(argv)
    use_cpu_time(args.cpu)
    one = [20, 40, 60, 80, 100, 120, 140, 160, 180, 200]
    three = [20, 40, 80, 120, 200]
    if args.quick:
        one, three = [20, 80, 200], [20, 80]
    print(f"citysynth bench/street.py — median of {args.runs} runs after warm-up (more for "
          f"calls of a few ms), {'CPU' if args.cpu else 'wall'} time in ms; k1/k100 = the "
          "default method at k=1/k=100; ratios are totals")
    print()
    peak_memory(200.0, 1)
    peak_memory(200.0, 100)
    one_resource(one, args.runs)
    three_resources(three, args.runs)


if __name__ == "__main__":
    main()
