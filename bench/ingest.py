"""Ingest benchmark: the shipped sample library, a generated 1,000-part library, and
the cache hit of a second ingest.

Each figure is the median of --runs runs after a warm-up (the cache hit after the
library was ingested once). The 1,000 parts are complete buildings and facade parts
written by the sample generator with seeded widths, storeys and styles; writing them
is not timed.

    python -m bench.ingest [--runs 3] [--parts 1000]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from citysynth.parts_db import ingest
from citysynth.parts_db.sample import CLASSIC, MODERN, OUT, facade_chunk


def synthetic_library(out: Path, n: int, seed: int = 11) -> None:
    rng = np.random.default_rng(seed)
    (out / "meshes").mkdir(parents=True, exist_ok=True)
    lines = ["[library]", 'name = "synthetic"', "quantum = 0.2", ""]
    for i in range(n):
        style = CLASSIC if rng.integers(0, 2) else MODERN
        w = float(rng.integers(15, 121)) * 0.2
        st = int(rng.integers(2, 8))
        bays = max(1, round(w / style.bay_w))
        P = facade_chunk(style, 0.0, w, st, door=int(rng.integers(0, bays)),
                         balconies={int(rng.integers(1, st))} if st > 1 else set(),
                         roof=bool(rng.integers(0, 3)))
        pid = f"p{i:04d}"
        (out / "meshes" / f"{pid}.glb").write_bytes(P.glb())
        cls = "building" if i % 3 else "middle"
        lines += ["[[part]]", f'id = "{pid}"', f'file = "meshes/{pid}.glb"',
                  f'class = "{cls}"', f'style = "{style.name}"', ""]
    (out / "manifest.toml").write_text("\n".join(lines))


def median_time(fn, runs: int) -> float:
    fn()
    ts = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--parts", type=int, default=1000)
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        db_dir = tmp / "sample_db"
        t = median_time(lambda: ingest(OUT, db_dir, force=True), args.runs)
        hit = median_time(lambda: ingest(OUT, db_dir), max(args.runs, 5))
        rows.append(("sample library", len(ingest(OUT, db_dir).parts), t, hit, 10.0))
        lib = tmp / "synthetic"
        t0 = time.perf_counter()
        synthetic_library(lib, args.parts)
        gen = time.perf_counter() - t0
        t = median_time(lambda: ingest(lib, tmp / "syn_db", force=True), args.runs)
        hit = median_time(lambda: ingest(lib, tmp / "syn_db"), max(args.runs, 5))
        rows.append((f"generated ({gen:.0f} s to write)", args.parts, t, hit, 60.0))
    print(f"citysynth bench/ingest.py — median of {args.runs} runs after warm-up")
    head = f"{'library':<28} {'parts':>6} {'ingest s':>9} {'cache hit s':>12} {'target s':>9}"
    print(head + "\n" + "-" * len(head))
    for name, n, t, hit, target in rows:
        print(f"{name:<28} {n:>6} {t:>9.2f} {hit:>12.3f} {target:>9.0f}")
    print("cache-hit target: under 1 s")


if __name__ == "__main__":
    main()
