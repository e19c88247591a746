"""City benchmark: synthetic irregular street networks of about 100, 1,000 (and 10,000) blocks,
built end to end (streets -> blocks -> solve -> layout JSON + USD layers + city stage,
no overview PNG) by ``citysynth city`` in a fresh process and a fresh run folder each
time; blocks/s with 1 and 2 workers, CPU time per stage, peak memory of the whole
process tree (sampled every 0.1 s). One warm-up run first, then the median of --runs.
With 2 workers, also the seconds a fresh process takes to open the run's city.usda
(usd-core, every block loaded) and visit every prim of the stage, and then to visit
every prim again through the instance proxies (each instance's meshes).
--huge-runs adds a 10,000-block network on 2 workers.

    python -m bench.city [--runs 3] [--large-runs 1] [--huge-runs 1]

Targets: (issue 6) 1,000 blocks under 60 s on 2 cores, peak memory under 2 GB; (issue
15) 1,000 blocks under 12 s on 2 workers; 10,000 blocks under 2 minutes with peak
memory under 2 GB, their city.usda opened and traversed in under 10 s.
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


def open_and_traverse(city: Path) -> tuple[float, int, float, int]:
    """In a fresh process (usd-core): seconds to open ``city.usda`` with every block
    loaded and visit every prim of the stage (instances' shared prototypes once), and
    how many; then seconds to visit every prim again through the instance proxies (each
    instance's meshes, as a renderer sees them), and how many."""
    code = ("import sys, time; from pxr import Usd; t = time.perf_counter(); "
            "s = Usd.Stage.Open(sys.argv[1]); n = sum(1 for _ in s.Traverse()); "
            "t1 = time.perf_counter(); "
            "m = sum(1 for _ in Usd.PrimRange.Stage(s, Usd.TraverseInstanceProxies())); "
            "print(t1 - t, n, time.perf_counter() - t1, m)")
    out = subprocess.run([sys.executable, "-c", code, str(city)], check=True,
                         capture_output=True, text=True).stdout.split()
    return float(out[0]), int(out[1]), float(out[2]), int(out[3])


def run_once(streets: Path, workers: int, stage: bool = False) -> dict:
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
        if stage:
            (report["open_s"], report["prims"], report["proxies_s"],
             report["proxies"]) = open_and_traverse(Path(tmp) / "city.usda")
    report["wall"] = wall
    report["peak_mb"] = peak / 2 ** 20
    return report


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="runs of the 100-block network")
    ap.add_argument("--large-runs", type=int, default=1, help="runs of the 1,000-block one")
    ap.add_argument("--huge-runs", type=int, default=0,
                    help="runs of a 10,000-block network on 2 workers (no warm-up of its "
                         "own; about 20 minutes a run on 2 cores)")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for size, runs, workers_list in ((100, args.runs, (1, 2)),
                                         (1000, args.large_runs, (1, 2)),
                                         (10000, args.huge_runs, (2,))):
            if runs <= 0:
                continue
            streets = Path(tmp) / f"net{size}.geojson"
            streets.write_text(json.dumps(network(size)))
            if size < 10000:
                run_once(streets, 2)                    # warm-up (numba cache, files)
            for workers in workers_list:
                reps = [run_once(streets, workers, stage=workers == 2) for _ in range(runs)]
                wall = statistics.median(r["wall"] for r in reps)
                rows.append((size, workers, reps[0], wall, max(r["peak_mb"] for r in reps),
                             runs))
    print("citysynth bench/city.py — synthetic irregular networks, whole `citysynth city` "
          "runs (no overview), median of N runs after a warm-up")
    head = (f"{'net':>5} {'wk':>3} {'N':>2} {'blocks':>6} {'built':>6} {'failed':>6} "
            f"{'wall s':>7} {'blocks/s':>8} {'peak MB':>8} | {'solve':>6} {'layout':>6} "
            f"{'write':>6} {'inputs':>6}  (CPU s) | {'open s':>6} {'prims':>7} "
            f"{'proxies s':>9} {'proxies':>8}")
    print(head + "\n" + "-" * len(head))
    for size, workers, r, wall, peak, runs in rows:
        c, t = r["counts"], r["timings"]
        print(f"{size:>5} {workers:>3} {runs:>2} {r['blocks']:>6} {c['built']:>6} "
              f"{c['failed']:>6} {wall:>7.1f} {r['blocks'] / wall:>8.1f} {peak:>8.0f} | "
              f"{t.get('solve_s', 0):>6.1f} {t.get('layout_s', 0):>6.1f} "
              f"{t.get('write_s', 0):>6.1f} {t.get('inputs_s', 0):>6.1f}          | "
              + (f"{r['open_s']:>6.1f} {r['prims']:>7} {r['proxies_s']:>9.1f} "
                 f"{r['proxies']:>8}" if "open_s" in r else ""))


if __name__ == "__main__":
    main()
