"""The paper's Fig. 7 with the sample library's own complete buildings: the time to fill
a straight street of R metres (``citysynth street``'s solve: one run, the city's
stretch tolerance, one door per 12 m or so asked), against R, and the growth exponent
beside the paper's R^1.29.

Each row is the median of --runs solves after a warm-up (bench/timing.py; --cpu for CPU
time on a shared machine), the library ingested once before. The layout and the files
are not timed (bench/export.py times those).

    python -m bench.street_buildings [--runs 5] [--cpu]
"""

from __future__ import annotations

import argparse

from shapely.geometry import LineString

from bench.street import slope
from bench.timing import interleaved, ms, use_cpu_time
from citysynth.examples import SAMPLE_LIBRARY
from citysynth.parts_db import load_library
from citysynth.pipeline.streets import StreetAsk, solve_street

LENGTHS = (40, 80, 120, 160, 200, 300, 400)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--cpu", action="store_true", help="time CPU time, not wall time")
    args = ap.parse_args(argv)
    use_cpu_time(args.cpu)
    db = load_library(SAMPLE_LIBRARY)
    n = len(db.select("building"))
    print(f"== a street of R m, {n} complete buildings of the sample library, k=1 ==")
    print(f"{'R (m)':>6} {'doors':>9} {'buildings':>9} {'distinct':>8} {'solve (ms)':>10}")
    times = []
    for r in LENGTHS:
        doors = (r // 15, r // 10)
        ask = StreetAsk(("left",), constraints=(("doors", float(doors[0]), float(doors[1])),))
        line = LineString([(0, 0), (r, 0)])
        res = interleaved({"street": lambda line=line, ask=ask: solve_street(
            "bench", line, db, ask)}, args.runs)
        t, outs = res["street"]
        built = outs[0]
        seq = built.layouts[0].structures[0]["stages"][0]["parts"]
        times.append(t)
        print(f"{r:>6} {str(list(doors)):>9} {len(seq):>9} {len(set(seq)):>8} {ms(t, 10)}")
    print(f"growth exponent over {LENGTHS[0]}-{LENGTHS[-1]} m: "
          f"{slope(LENGTHS, times):.2f} (paper: 1.29)")


if __name__ == "__main__":
    main()
