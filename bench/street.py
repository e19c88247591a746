"""Street-front benchmark (the paper's Fig. 7): rcksp against a plain DP and FGS.

A street front of 74 complete buildings (4-20 m on the 0.2 m grid, every transition
allowed, seeded costs) filled to an exact length of 20..200 m; and a three-resource
variant (length equality, intervals on doors and balconies). For every length it
prints the graph size, the median setup/solve times of rcksp for k=1 and k=100,
the plain compiled DP over (length, last element) (k=1 only: the floor), FGS for
k=1 and k=100, and the ratios, all measured in the same run: a warm-up, then the
median of --runs runs, the methods interleaved. The growth exponent is the slope of
log(time) over log(length). Peak memory of the 200 m three-resource case is the
peak RSS (VmHWM) of a child process that solves only that case.

    python -m bench.street [--runs 5] [--quick]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import time
from pathlib import Path

from bench.dp_floor import dp_cost
from citysynth.solver import Problem, TooLargeError, solve
from citysynth.solver.compiled import compile_problem
from citysynth.solver.samples import street_front

ROOT = Path(__file__).resolve().parent.parent


def timed(fn, runs: int):
    """Median wall time of fn() over `runs` calls after one warm-up, and the results."""
    outs = [fn()]
    ts = []
    for _ in range(runs):
        t = time.perf_counter()
        outs.append(fn())
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), outs[1:]


def stat_median(results, key: str) -> float:
    """Median of one timing the solver reports (setup_s / solve_s) over the runs."""
    return statistics.median(r.stats[key] for r in results)


def ms(x: float | None) -> str:
    return "—" if x is None else f"{1e3 * x:8.2f}"


def ratio(a: float | None, b: float | None) -> str:
    return "—" if a is None or b is None else f"{a / b:6.2f}"


def slope(xs, ys) -> float:
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    mx, my = statistics.fmean(lx), statistics.fmean(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly, strict=True)) / \
        sum((a - mx) ** 2 for a in lx)


def fgs_time(p: Problem, k: int, runs: int, budget_mb: float) -> float | None:
    try:
        t, _ = timed(lambda: solve(p, k=k, method="fgs", max_memory_mb=budget_mb), runs)
    except TooLargeError:
        return None
    return t


def one_resource(lengths, runs: int) -> None:
    print("\n== one resource: length equality, 74 buildings, 5476 transitions ==")
    head = (f"{'length':>6} {'nodes':>8} | {'setup1':>8} {'solve1':>8} {'total1':>8} "
            f"{'total100':>8} {'k100/k1':>7} | {'DP':>8} {'k1/DP':>6} | {'FGS1':>8} "
            f"{'FGS100':>8} {'FGS1/k1':>7} {'FGS100/k100':>11}")
    print(head + "\n" + "-" * len(head))
    t1s, dps = [], []
    for L in lengths:
        p = Problem.from_dict(street_front(L))
        cp = compile_problem(p)
        t1, r1 = timed(lambda p=p: solve(p, k=1), runs)
        t100, _ = timed(lambda p=p: solve(p, k=100), runs)
        tdp, cdp = timed(lambda cp=cp: dp_cost(cp), runs)
        assert abs(cdp[0] - r1[0].solutions[0].cost) < 1e-9, (cdp[0], r1[0].solutions[0].cost)
        f1 = fgs_time(p, 1, runs, 4096)
        f100 = fgs_time(p, 100, max(1, runs // 2), 4096)
        setup, solve1 = stat_median(r1, "setup_s"), stat_median(r1, "solve_s")
        print(f"{L:6.0f} {r1[0].stats['nodes']:8,} | {ms(setup)} {ms(solve1)} "
              f"{ms(t1)} {ms(t100)} {ratio(t100, t1):>7} | {ms(tdp)} {ratio(t1, tdp):>6} | "
              f"{ms(f1)} {ms(f100)} {ratio(f1, t1):>7} {ratio(f100, t100):>11}")
        t1s.append(t1)
        dps.append(tdp)
    print(f"growth exponent over {lengths[0]:g}-{lengths[-1]:g} m: rcksp k=1 "
          f"{slope(lengths, t1s):.2f}, DP {slope(lengths, dps):.2f} (paper: 1.29)")


def three_resources(lengths, runs: int) -> None:
    print("\n== three resources: length equality, doors and balconies intervals ==")
    head = (f"{'length':>6} {'doors':>8} {'balc.':>8} {'nodes':>11} | {'setup1':>8} "
            f"{'solve1':>8} {'total1':>9} {'total100':>9} {'k100/k1':>7} | {'FGS1':>9} "
            f"{'FGS100':>9}")
    print(head + "\n" + "-" * len(head))
    for L in lengths:
        d = street_front(L, resources=3)
        p = Problem.from_dict(d)
        n = runs if L <= 100 else max(1, runs // 2)
        t1, r1 = timed(lambda p=p: solve(p, k=1), n)
        t100, _ = timed(lambda p=p: solve(p, k=100), n)
        f1 = fgs_time(p, 1, n, 4096)
        f100 = fgs_time(p, 100, 1, 4096) if L <= 80 else None
        c = d["constraints"]
        print(f"{L:6.0f} {str(c['doors']):>8} {str(c['balconies']):>8} "
              f"{r1[0].stats['nodes']:11,} | {ms(stat_median(r1, 'setup_s'))} "
              f"{ms(stat_median(r1, 'solve_s'))} {ms(t1):>9} {ms(t100):>9} "
              f"{ratio(t100, t1):>7} | {ms(f1):>9} {ms(f100):>9}")


_CHILD = """
import json, sys, time
sys.path.insert(0, {root!r})
from citysynth.solver.samples import street_front
from citysynth.solver import Problem, solve

def hwm():  # peak RSS of this process image (VmHWM; ru_maxrss survives exec)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024

p = Problem.from_dict(street_front({length}, resources=3))
solve(Problem.from_dict(street_front(20.0, resources=3)))
base = hwm()
t = time.perf_counter()
r = solve(p, k={k})
t = time.perf_counter() - t
print(json.dumps({{"base_mb": base, "peak_mb": hwm(), "s": t,
                  "nodes": r.stats["nodes"], "table": r.stats["estimate"]["table"]}}))
"""


def peak_memory(length: float, k: int) -> None:
    out = subprocess.run([sys.executable, "-c", _CHILD.format(root=str(ROOT), length=length,
                                                               k=k)],
                         capture_output=True, text=True, check=True)
    d = json.loads(out.stdout)
    print(f"\npeak memory, {length:g} m three-resource, k={k}: {d['peak_mb']:,.0f} MB peak RSS "
          f"({d['peak_mb'] - d['base_mb']:,.0f} MB above the {d['base_mb']:,.0f} MB of a "
          f"warmed-up interpreter); {d['nodes']:,} nodes kept, {d['table']} rows, "
          f"{d['s']:.1f} s")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="timed runs per case (median)")
    ap.add_argument("--quick", action="store_true", help="fewer lengths, for a smoke run")
    args = ap.parse_args(argv)
    one = [20, 40, 60, 80, 100, 120, 140, 160, 180, 200]
    three = [20, 40, 80, 120, 200]
    if args.quick:
        one, three = [20, 80, 200], [20, 40]
    print(f"citysynth bench/street.py — median of {args.runs} runs after warm-up; "
          "times in ms; k1 = rcksp k=1 total, k100 = rcksp k=100 total")
    if not args.quick:
        peak_memory(200.0, 1)
    one_resource(one, args.runs)
    three_resources(three, args.runs)


if __name__ == "__main__":
    main()
