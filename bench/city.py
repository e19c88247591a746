"""City benchmark: synthetic irregular street networks of about 100 and 1,000 blocks,
built end to end (streets -> blocks -> solve -> layout JSON + USD layers + city stage,
no overview PNG) by ``citysynth city`` in a fresh process and a fresh run folder each
time; blocks/s with 1 and 2 workers, CPU time per stage, peak memory of the whole
process tree (sampled every 0.1 s). One warm-up run first, then the median of --runs.

    python -m bench.city [--runs 3] [--large-runs 1]

Target (issue 6): 1,000 blocks under 60 s on 2 cores, peak memory under 2 GB.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import psutil

from citysynth.skeletons import lonlat_from_local

ROOT = Path(__file__).resolve().parent.parent
ORIGIN = (13.4, 52.52)
HIGHWAYS = ("primary", "secondary", "tertiary", "residential", "residential")


def network(blocks: int, seed: int = 1, spacing: float = 95.0) -> dict:
    """A grid of about ``blocks`` blocks, its junctions jittered by up to 12 m, its
    lines bent, plus two diagonal avenues: irregular quadrilaterals, triangles and
    trapezoids, with corners of many angles and a mix of street classes."""
    rng = np.random.default_rng(seed)
    n = int(math.ceil(math.sqrt(blocks))) + 1
    jitter = rng.uniform(-12, 12, size=(n, n, 2))
    pts = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1) * spacing
    pts = pts + jitter
    feats = []

    def line(coords, cls):
        feats.append({"type": "Feature", "properties": {"highway": cls},
                      "geometry": {"type": "LineString",
                                   "coordinates": lonlat_from_local(coords, ORIGIN)}})
    for i in range(n):
        line(pts[i, :, :], HIGHWAYS[i % len(HIGHWAYS)])
        line(pts[:, i, :], HIGHWAYS[(i + 2) % len(HIGHWAYS)])
    span = (n - 1) * spacing
    line([(0.2 * span, -5), (0.9 * span, span + 5)], "primary")
    line([(-5, 0.7 * span), (span + 5, 0.1 * span)], "secondary")
    return {"type": "FeatureCollection", "features": feats}


def run_once(streets: Path, workers: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "citysynth.pipeline.cli", "city", "--streets", str(streets),
               "--library", str(ROOT / "examples" / "library"), "-o", tmp,
               "--workers", str(workers), "--no-overview"]
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        parent = psutil.Process(proc.pid)
        peak = 0
        while proc.poll() is None:
            try:
                tree = [parent, *parent.children(recursive=True)]
                peak = max(peak, sum(p.memory_info().rss for p in tree if p.is_running()))
            except psutil.Error:
                pass
            time.sleep(0.1)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            raise SystemExit(f"citysynth city failed ({proc.returncode}) on {streets}")
        report = json.loads((Path(tmp) / "report.json").read_text())
    report["wall"] = wall
    report["peak_mb"] = peak / 2 ** 20
    return report


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="runs of the 100-block network")
    ap.add_argument("--large-runs", type=int, default=1, help="runs of the 1,000-block one")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for size, runs in ((100, args.runs), (1000, args.large_runs)):
            streets = Path(tmp) / f"net{size}.geojson"
            streets.write_text(json.dumps(network(size)))
            run_once(streets, 2)                        # warm-up (numba cache, files)
            for workers in (1, 2):
                reps = [run_once(streets, workers) for _ in range(runs)]
                wall = statistics.median(r["wall"] for r in reps)
                rows.append((size, workers, reps[0], wall, max(r["peak_mb"] for r in reps),
                             runs))
    print("citysynth bench/city.py — synthetic irregular networks, whole `citysynth city` "
          "runs (no overview), median of N runs after a warm-up")
    head = (f"{'net':>5} {'wk':>3} {'N':>2} {'blocks':>6} {'built':>6} {'failed':>6} "
            f"{'wall s':>7} {'blocks/s':>8} {'peak MB':>8} | {'solve':>6} {'layout':>6} "
            f"{'write':>6} {'inputs':>6}  (CPU s)")
    print(head + "\n" + "-" * len(head))
    for size, workers, r, wall, peak, runs in rows:
        c, t = r["counts"], r["timings"]
        print(f"{size:>5} {workers:>3} {runs:>2} {r['blocks']:>6} {c['built']:>6} "
              f"{c['failed']:>6} {wall:>7.1f} {r['blocks'] / wall:>8.1f} {peak:>8.0f} | "
              f"{t.get('solve_s', 0):>6.1f} {t.get('layout_s', 0):>6.1f} "
              f"{t.get('write_s', 0):>6.1f} {t.get('inputs_s', 0):>6.1f}")


if __name__ == "__main__":
    main()
