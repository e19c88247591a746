"""``citysynth``: the command line.

Every sub-command maps user errors (:class:`solver.ProblemError`,
:class:`parts_db.LibraryError`, :class:`skeletons.SkeletonError`,
:class:`export.errors.ExportError` and their kin) to one line on stderr and exit code 2,
with no traceback; an infeasible problem is an answer, not an error, and exits 1
with its reason. Sub-commands live in their own modules and register themselves here.
"""

from __future__ import annotations

import argparse
import os
import sys
from importlib.metadata import PackageNotFoundError, version

from citysynth.export.errors import ExportError
from citysynth.parts_db import LibraryError
from citysynth.parts_db.library import CACHE_ENV
from citysynth.pipeline.commands import build, city, demo, diff, ingest, skeleton, solve
from citysynth.skeletons import SkeletonError
from citysynth.solver import ProblemError

EXIT_OK, EXIT_INFEASIBLE, EXIT_BAD_INPUT = 0, 1, 2


def _version() -> str:
    try:
        return version("citysynth")
    except PackageNotFoundError:   # running from a source tree that is not installed
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="citysynth",
        description="Example-based city generator: exact k-best layouts of building parts.",
    )
    parser.add_argument("--version", action="version", version=f"citysynth {_version()}")
    parser.add_argument("--cache", metavar="DIR", default=None,
                        help="folder for part-database caches (default: beside a library "
                             "you may write, else the user cache folder; or "
                             "$CITYSYNTH_CACHE)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (solve, ingest, skeleton, build, city, diff, demo):
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.cache:   # the environment carries it into worker processes too
        os.environ[CACHE_ENV] = os.path.abspath(args.cache)
    try:
        return int(args.run(args))
    except (ProblemError, LibraryError, SkeletonError, ExportError) as exc:
        print(f"citysynth {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("citysynth: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
