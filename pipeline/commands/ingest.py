"""``citysynth ingest LIBRARY_DIR [-o OUT]``: build (or reuse) a part database."""

from __future__ import annotations

import sys
import time


def register(sub) -> None:
    p = sub.add_parser("ingest", help="ingest a part library into a part database",
                       description="Measure every part of a library (meshes + manifest.toml), "
                                   "compute the transition costs and write the database. An "
                                   "unchanged library is a cache hit. Exit 2 on a bad part, "
                                   "with nothing written.")
    p.add_argument("library", help="library folder (manifest.toml + meshes)")
    p.add_argument("-o", "--out", default=None,
                   help="database folder (default: LIBRARY/.citysynth)")
    p.add_argument("--force", action="store_true", help="ingest even if the cache is valid")
    p.set_defaults(run=run)


def run(args) -> int:
    from citysynth.parts_db import ingest  # trimesh: when run (see pipeline.cli)
    from citysynth.parts_db.summary import summary

    t = time.perf_counter()
    interactive = sys.stderr.isatty()

    def progress(i: int, n: int, pid: str) -> None:
        if interactive:
            print(f"\r  measuring {i + 1}/{n}: {pid[:40]:<40}", end="", file=sys.stderr,
                  flush=True)

    db = ingest(args.library, args.out, force=args.force, progress=progress)
    if interactive:
        print("\r" + " " * 70 + "\r", end="", file=sys.stderr)
    print(summary(db, time.perf_counter() - t))
    return 0
