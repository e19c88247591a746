"""The paper's Tables 2 and 3 on a synthetic motion graph: the default method against FGS.

The graph (:func:`citysynth.solver.samples.motion_graph`) is shaped like the walk
subset of HDM05 the paper times: 600 walking segments of 20-60 frames, each followed
by its 32 best-matching segments (pose-feature distances), distance in 5 cm quanta,
and the path-following cost of the paper's eq. 4. Rows, as in the paper:

* Table 2, one constraint: the distance, exactly 5, 6, 7 and 8 m (frames summed).
* Table 3, two constraints: distance and frame count, exactly 5 m / 146, 6 m / 146
  and 7 m / 187 frames.
* The full HDM05 size: 9,709 segments and 310,688 transitions, 7 m / 187 frames, with
  the peak memory of a child process that solves only that row (VmHWM) against the
  default memory budget.

For each row and k = 1 and k = 100: the default method's setup and solve time (as the
solver reports them) and total wall time, FGS's total, and the ratio of the totals;
at k = 1 also the paper's intermediate graph (rcksp, walking the transition lists).
All measured in the same run: a warm-up, then the median of --runs runs (bench/timing.py:
more for calls of a few milliseconds; --cpu for CPU time), the methods interleaved. A
method beyond its memory budget shows "refused".

    python -m bench.motion [--runs 5] [--cpu] [--quick] [--no-hdm05]
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

from bench.timing import interleaved, run_child, use_cpu_time
from citysynth.solver import Problem, solve
from citysynth.solver.samples import motion_graph

ROOT = Path(__file__).resolve().parent.parent
HDM05 = 9709
# The paper's own figures (seconds: setup, solve, FGS), printed under each table.
PAPER = {(5, None): (5.5, 0.16, 19.1), (6, None): (18.8, 1.0, 67.3),
         (7, None): (75.2, 3.7, 160.7), (8, None): (164.6, 11.9, 452.7),
         (5, 146): (3.4, 0.17, 84.7), (6, 146): (23.1, 0.38, 185.6),
         (7, 187): (108.1, 4.7, 834.9)}


def fmt_s(x: float | None) -> str:
    if x is None:
        return "refused"
    return f"{x * 1e3:8.1f}ms" if x < 1 else f"{x:8.2f}s "


def row(label: str, p: Problem, runs: int) -> None:
    """One line per k: ours (setup, solve, total), FGS, ratio, search size."""
    for k in (1, 100):
        fns = {"ours": lambda k=k: solve(p, k=k),
               "fgs": lambda k=k: solve(p, k=k, method="fgs")}
        if k == 1:
            fns["rcksp"] = lambda: solve(p, k=1, method="rcksp")
        res = interleaved(fns, runs)
        t_ours, r_ours = res["ours"]
        t_fgs, r_fgs = res["fgs"]
        setup = statistics.median(r.stats["setup_s"] for r in r_ours)
        solve_s = statistics.median(r.stats["solve_s"] for r in r_ours)
        first = r_ours[0]
        if t_fgs is not None:
            got = [s.cost for s in first.solutions]
            assert got == [s.cost for s in r_fgs[0].solutions], (label, k)
        ratio = "—" if t_fgs is None else f"{t_ours / t_fgs:6.3f}"
        size = first.stats.get("labels", first.stats.get("nodes", 0))
        rcksp = fmt_s(res["rcksp"][0]) if k == 1 else f"{'':>10}"
        print(f"{label:<22} {k:>4} | {fmt_s(setup)} {fmt_s(solve_s)} {fmt_s(t_ours)} | "
              f"{fmt_s(t_fgs)} | {ratio:>6} | {first.stats.get('path', ''):>5} {size:>9,} | "
              f"{rcksp} | {first.solutions[0].cost if first.solutions else float('nan'):.4f}")


def header(title: str) -> None:
    print(f"\n== {title} ==")
    head = (f"{'row':<22} {'k':>4} | {'setup':>10} {'solve':>10} {'total':>10} | "
            f"{'FGS':>10} | {'ratio':>6} | {'path':>5} {'explored':>9} | {'rcksp':>10} | "
            "best cost")
    print(head + "\n" + "-" * len(head))


def paper_note(rows) -> None:
    """The paper's figures for the same rows (its machine, its implementation)."""
    parts = []
    for key in rows:
        s, v, f = PAPER[key]
        name = f"{key[0]} m" + (f"/{key[1]}" if key[1] else "")
        parts.append(f"{name}: {s:g}+{v:g} s vs FGS {f:g} s")
    print("paper (k=1): " + "; ".join(parts))


_CHILD = """
import sys, time
sys.path.insert(0, {root!r})
from citysynth.solver import Problem, TooLargeError, solve
from citysynth.solver.samples import motion_graph

solve(Problem.from_dict(motion_graph(5.0, 146)))   # warm the compiled kernels
p = Problem.from_dict(motion_graph({distance}, {frames}, segments={segments}))
base = hwm()
out = {{"base_mb": base}}
for k in (1, 100):
    t = time.perf_counter()
    try:
        r = solve(p, k=k, method={method!r})
        out[k] = {{"s": time.perf_counter() - t, "cost": r.solutions[0].cost,
                  "explored": r.stats.get("labels", r.stats.get("nodes"))}}
    except TooLargeError as exc:
        out[k] = {{"s": time.perf_counter() - t, "refused": str(exc)}}
    out[str(k) + "_peak_mb"] = hwm()
import json
print(json.dumps(out))
"""


def hdm05_row(method: str, distance: float, frames: int) -> dict:
    """The full-size row in a child process: times and peak memory; returns the
    child's figures."""
    d = run_child(_CHILD.format(root=str(ROOT), distance=distance, frames=frames,
                                segments=HDM05, method=method))
    for k in ("1", "100"):
        run = d[k]
        what = (f"refused after {run['s']:.1f} s: {run['refused'][:90]}..." if "refused" in run
                else f"{fmt_s(run['s']).strip()}, {run['explored']:,} explored, best cost "
                     f"{run['cost']:.4f}")
        print(f"  {method:<6} k={k:<3} {what}; peak {d[k + '_peak_mb']:,.0f} MB "
              f"(interpreter and problem: {d['base_mb']:,.0f} MB)")
    return d


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="timed runs per case (median)")
    ap.add_argument("--cpu", action="store_true",
                    help="time with CPU time instead of wall time (a shared machine)")
    ap.add_argument("--quick", action="store_true", help="fewer rows, for a smoke run")
    ap.add_argument("--no-hdm05", action="store_true", help="skip the full-size row")
    args = ap.parse_args(argv)
    use_cpu_time(args.cpu)
    one = [5.0, 6.0, 7.0, 8.0]
    two = [(5.0, 146), (6.0, 146), (7.0, 187)]
    if args.quick:
        one, two = [5.0], [(5.0, 146)]
    print(f"citysynth bench/motion.py — median of {args.runs} runs after warm-up (more for "
          f"calls of a few ms), {'CPU' if args.cpu else 'wall'} time; ours = the default "
          "method; ratio = ours total / FGS total")
    header("Table 2: one constraint (distance), 600 segments, 19,200 transitions")
    for D in one:
        row(f"{D:g} m", Problem.from_dict(motion_graph(D)), args.runs)
    paper_note([(int(D), None) for D in one])
    header("Table 3: two constraints (distance, frames), 600 segments")
    for D, F in two:
        row(f"{D:g} m / {F} frames", Problem.from_dict(motion_graph(D, F)), args.runs)
    paper_note([(int(D), F) for D, F in two])
    if not args.no_hdm05:
        print(f"\n== HDM05 size: {HDM05:,} segments, {32 * HDM05:,} transitions, "
              "7 m / 187 frames, default budget (child process, peak RSS) ==")
        ours = hdm05_row("auto", 7.0, 187)
        fgs = hdm05_row("fgs", 7.0, 187)
        print("  ratio (one run each): " + ", ".join(
            f"k={k} {ours[k]['s'] / fgs[k]['s']:.3f}" for k in ("1", "100")
            if "refused" not in ours[k] and "refused" not in fgs[k]))


if __name__ == "__main__":
    main()
