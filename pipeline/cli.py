"""``citysynth``: the command line.

Every sub-command maps user errors (:class:`solver.ProblemError`,
:class:`parts_db.LibraryError`, :class:`skeletons.SkeletonError`,
:class:`export.errors.ExportError` and their kin) to one line on stderr and exit code 2,
with no traceback; an infeasible problem is an answer, not an error, and exits 1
with its reason. Sub-commands live in their own modules and register themselves here.
"""

from __future__ import annotations

import argparse
import sys

from export.errors import ExportError
from parts_db import LibraryError
from skeletons import SkeletonError
from solver import ProblemError

from . import build_cmd, city_cmd, demo_cmd, diff_cmd, ingest_cmd, skeleton_cmd, solve_cmd

EXIT_OK, EXIT_INFEASIBLE, EXIT_BAD_INPUT = 0, 1, 2


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="citysynth",
        description="Example-based city generator: exact k-best layouts of building parts.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (solve_cmd, ingest_cmd, skeleton_cmd, build_cmd, city_cmd, diff_cmd,
                   demo_cmd):
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
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
