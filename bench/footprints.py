"""Footprints per second: the generated residential district
(:mod:`citysynth.examples.footprint_shapes`) re-skinned end to end by ``citysynth city
--footprints`` in a fresh process and run folder each time (clean, solve, layout JSON
and USD; no overview), on ``--workers`` cores. One warm-up run, then the median of
``--rounds``.

    python -m bench.footprints [--houses 220] [--workers 2] [--rounds 3] [--k 1]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from citysynth.examples.footprint_shapes import footprints

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"


def one_run(fp: Path, cfg: Path, workers: int, folder: Path) -> tuple[float, dict]:
    """Wall seconds of one city run, and its report."""
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "citysynth.pipeline.cli", "city", "--footprints",
                    str(fp), "--library", str(LIB), "--config", str(cfg), "-o", str(folder),
                    "--workers", str(workers), "--no-overview"], check=False,
                   capture_output=True)
    wall = time.perf_counter() - t
    return wall, json.loads((folder / "report.json").read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--houses", type=int, default=220)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--k", type=int, default=1)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-footprints-") as tmp:
        d = Path(tmp)
        fp = d / "houses.geojson"
        fp.write_text(json.dumps(footprints(a.houses)))
        cfg = d / "city.toml"
        cfg.write_text(f'k = {a.k}\npick = "best"\n')
        one_run(fp, cfg, a.workers, d / "warm-up")
        walls, report = [], {}
        for i in range(a.rounds):
            wall, report = one_run(fp, cfg, a.workers, d / f"run{i}")
            walls.append(wall)
        c = report["counts"]
        med = statistics.median(walls)
        print(f"houses {a.houses}  workers {a.workers}  k {a.k}  built {c['built']}  "
              f"failed {c['failed']}  wall {med:.1f} s (median of {a.rounds})  "
              f"{c['built'] / med:.2f} footprints/s")


if __name__ == "__main__":
    main()
